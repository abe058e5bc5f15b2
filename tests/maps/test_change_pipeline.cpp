// The change-report pipeline with its real parts: pl-sim maps a stretch of the town (v1, served by
// pl-server); two vehicles drive it six months later, pl-localize sends each drive's report, and
// pl-map update publishes v2 from the reports the store holds. Only tiles where the simulator's
// truth has a change are rebuilt; every other tile keeps v1's bytes.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <future>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "pl/common/tile_key.hpp"
#include "pl/eval/changes.hpp"
#include "pl/maps/map_update.hpp"
#include "pl/schema/http_client.hpp"
#include "pl/schema/store.hpp"
#include "server_process.hpp"
#include "test_util.hpp"

namespace {

using pl::test::run;
using pl::test::tool;

const std::string kReportToken = "report-e2e-3c81", kUploadToken = "upload-e2e-7d04";
constexpr int kFrames = 60;

struct Vehicle {
  std::string drive, vehicle;
  int seed;
  long start;  // seconds since 1970: a day apart, so the two are independent passes
};

// The tiles a changed thing of pl-sim's changes.csv stands on, where it stood or stands (its
// footprint's bounding box, `margin_m` wider: evidence at a thing's edge may fall on either side).
std::set<pl::TileKey> tiles_with_changes(const std::string& changes_csv, const pl::TileGrid& grid, double margin_m) {
  std::istringstream in(pl::test::read_file(changes_csv));
  std::string line;
  std::getline(in, line);
  std::map<std::string, std::size_t> col;
  {
    std::istringstream h(line);
    std::string name;
    for (std::size_t i = 0; std::getline(h, name, ','); ++i) col[name] = i;
  }
  std::set<pl::TileKey> out;
  while (std::getline(in, line)) {
    std::vector<std::string> f;
    std::istringstream row(line);
    for (std::string field; std::getline(row, field, ',');) f.push_back(field);
    f.resize(col.size());
    for (const char* epoch : {"0", "1"}) {
      auto field = [&](const std::string& name) -> const std::string& { return f[col.at(name + epoch)]; };
      if (field("x").empty()) continue;  // added (nothing in epoch 0) or removed (nothing in epoch 1)
      const double x = std::stod(field("x")), y = std::stod(field("y"));
      const double hx = std::stod(field("half_x")), hy = std::stod(field("half_y")), yaw = std::stod(field("yaw"));
      const double ex = std::abs(std::cos(yaw)) * hx + std::abs(std::sin(yaw)) * hy + margin_m;
      const double ey = std::abs(std::sin(yaw)) * hx + std::abs(std::cos(yaw)) * hy + margin_m;
      const pl::TileKey lo = grid.key_of(x - ex, y - ey), hi = grid.key_of(x + ex, y + ey);
      for (int tx = lo.tx; tx <= hi.tx; ++tx)
        for (int ty = lo.ty; ty <= hi.ty; ++ty) out.insert({tx, ty});
    }
  }
  return out;
}

}  // namespace

TEST(ChangePipeline, TwoVehiclesReportsRebuildOnlyTheTilesThatChanged) {
  pl::test::TempDir dir;
  const std::string db = dir / "maps.sqlite";
  const std::vector<Vehicle> vehicles = {{"e1_a", "vehicle-101", 101, 1800000000}, {"e1_b", "vehicle-102", 102, 1800086400}};
  auto sim = [&](const std::string& out, int epoch, int drive_seed) {
    return run(tool("pl-sim") + " --route loop --seed 1 --frames " + std::to_string(kFrames) + " --epoch " +
               std::to_string(epoch) + " --drive-seed " + std::to_string(drive_seed) + " --out " + (dir / out));
  };

  // Epoch 0: the mapping drive, mapped at its true poses into version 1. The vehicles' epoch-1
  // drives are simulated meanwhile.
  auto r = sim("e0", 0, 1);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  auto later = std::async(std::launch::async, [&] {
    std::vector<pl::test::RunResult> out;
    for (const Vehicle& v : vehicles) out.push_back(sim(v.drive, 1, v.seed));
    return out;
  });
  for (const std::string& cmd : {tool("pl-map") + " build --dataset " + (dir / "e0") + " --poses gt --out " + (dir / "map.pcd"),
                                 tool("pl-map") + " tile --cloud " + (dir / "map.pcd") + " --db " + db + " --map town",
                                 tool("pl-map") + " publish --db " + db + " --map town --version 1"}) {
    r = run(cmd);
    ASSERT_EQ(r.exit_code, 0) << cmd << "\n" << r.output;
  }
  for (const auto& s : later.get()) ASSERT_EQ(s.exit_code, 0) << s.output;

  pl::test::write_file(dir / "tokens.txt", "report " + kReportToken + "\nupload " + kUploadToken + "\n");
  pl::test::ServerProcess server(db, {"--tokens", dir / "tokens.txt"});

  // Epoch 1: each vehicle localizes on v1 over HTTP and its spool sends the drive's report (also
  // written to a file, to compare with what the service stored).
  std::vector<std::future<pl::test::RunResult>> drives;
  for (const Vehicle& v : vehicles)
    drives.push_back(std::async(std::launch::async, [&, v] {
      return run(tool("pl-localize") + " --dataset " + (dir / v.drive) + " --server " + server.url() +
                 " --map town --beams 16 --odometry encoder --init gt --out " + (dir / v.drive + ".tum") + " --change-report " +
                 (dir / v.drive + ".json") + " --vehicle " + v.vehicle + " --drive-id " + v.drive + " --drive-start " +
                 std::to_string(v.start) + " --report-spool " + (dir / "spool-" + v.vehicle) + " --report-token " + kReportToken);
    }));
  for (auto& d : drives) {
    const auto out = d.get();
    ASSERT_EQ(out.exit_code, 0) << out.output;
  }

  // The service holds each vehicle's report, byte for byte, against v1; no spool keeps one back.
  pl::api::HttpClient http(server.url());
  const auto listed = http.get("/v1/maps/town/reports", {{"Authorization", "Bearer " + kUploadToken}});
  ASSERT_EQ(listed.status, 200) << listed.body;
  const nlohmann::json reports = nlohmann::json::parse(listed.body)["reports"];
  ASSERT_EQ(reports.size(), vehicles.size()) << listed.body;
  for (const Vehicle& v : vehicles) {
    const auto it = std::find_if(reports.begin(), reports.end(), [&](const auto& j) { return j["drive"] == v.drive; });
    ASSERT_NE(it, reports.end()) << v.drive << " not stored: " << listed.body;
    EXPECT_EQ((*it)["vehicle"], v.vehicle);
    EXPECT_EQ((*it)["version"], 1);
    EXPECT_EQ((*it)["hash"], pl::store::content_hash(pl::test::read_file(dir / v.drive + ".json")));
    for (const auto& e : std::filesystem::recursive_directory_iterator(dir / "spool-" + v.vehicle))
      EXPECT_FALSE(e.is_regular_file()) << "left in the spool: " << e.path();
  }

  // The update from the reports the store holds: version 2, published and served.
  r = run(tool("pl-map") + " update --db " + db + " --map town --publish");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(nlohmann::json::parse(http.get("/v1/maps/town").body)["current_version"], 2) << r.output;
  const auto store = pl::store::Store::open(db, false);
  ASSERT_EQ(store.find_map("town")->current, 2) << r.output;
  EXPECT_EQ(store.find_version("town", 2)->parent, 1);

  // The tiles it rebuilt, as its log says, each from both vehicles' passes.
  std::set<pl::TileKey> rebuilt;
  for (const auto& [key, reason] : pl::maps::update_reasons(store, "town", 2)) {
    rebuilt.insert(key);
    for (const Vehicle& v : vehicles)
      EXPECT_NE(reason.find(v.vehicle + "/" + v.drive), std::string::npos) << key.tx << " " << key.ty << ": " << reason;
  }
  ASSERT_FALSE(rebuilt.empty()) << r.output;

  // Every other tile keeps v1's bytes; each rebuilt one has new bytes, or is gone.
  std::map<pl::TileKey, std::string> v1, v2;
  for (const auto& t : store.list_tiles("town", 1)) v1[t.key] = t.hash;
  for (const auto& t : store.list_tiles("town", 2)) v2[t.key] = t.hash;
  for (const auto& [key, hash] : v1) {
    const auto now = v2.find(key);
    if (rebuilt.count(key)) {
      EXPECT_TRUE(now == v2.end() || now->second != hash) << "rebuilt with the same bytes: " << key.tx << " " << key.ty;
    } else {
      ASSERT_NE(now, v2.end()) << "lost: " << key.tx << " " << key.ty;
      EXPECT_EQ(now->second, hash) << "changed without a reason: " << key.tx << " " << key.ty;
    }
  }
  for (const auto& [key, hash] : v2) EXPECT_TRUE(v1.count(key) || rebuilt.count(key)) << "new tile: " << key.tx << " " << key.ty;

  // The simulator's truth: a changed thing stands, or stood, on every rebuilt tile, and on one at
  // least the drives' probe rays saw the change (pl-eval's rule of a truly changed tile).
  const pl::TileGrid grid(store.find_map("town")->tile_size);
  std::string rebuilt_csv = "tx,ty,passes,candidate\n";
  for (const auto& k : rebuilt) rebuilt_csv += std::to_string(k.tx) + "," + std::to_string(k.ty) + ",2,1\n";
  pl::test::write_file(dir / "rebuilt.csv", rebuilt_csv);
  std::set<pl::TileKey> changed;
  std::size_t seen_changed = 0;
  for (const Vehicle& v : vehicles) {
    const std::string truth = dir / v.drive + "/changes.csv";
    const auto tiles = tiles_with_changes(truth, grid, 1.0);
    changed.insert(tiles.begin(), tiles.end());
    seen_changed = std::max(seen_changed, pl::eval::score_changes(truth, dir / "rebuilt.csv").true_positives);
  }
  for (const auto& k : rebuilt) EXPECT_TRUE(changed.count(k)) << "rebuilt, but nothing changed there: " << k.tx << " " << k.ty;
  EXPECT_GE(seen_changed, 1u) << r.output;
}
