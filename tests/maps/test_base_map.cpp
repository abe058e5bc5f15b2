// Adding a drive to an existing map (pl-map build --base-map): the base map's drives stay where they
// were, so the tiles the new drive does not reach keep their bytes when the map is tiled again into
// the same store, and those it reaches change. Plus the record of the drives beside every map, and
// the refusals of a base map that cannot be repeated.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <sstream>
#include <vector>
#include <map>
#include <set>
#include <string>

#include <nlohmann/json.hpp>

#include "pl/common/error.hpp"
#include "pl/maps/drive_record.hpp"
#include "pl/schema/store.hpp"
#include "test_util.hpp"

using pl::test::run;
using pl::test::TempDir;
using pl::test::tool;

namespace {

// The first `scans` scans of a pl-sim drive (the scans linked; times, poses, GPS and encoders cut): a
// drive over part of the stretch, through the same world (pl-sim's world depends on the stretch).
void keep_first_scans(const std::string& drive, std::size_t scans, const std::string& out) {
  namespace fs = std::filesystem;
  fs::create_directories(out + "/velodyne");
  fs::create_directories(out + "/point_times");
  char name[32];
  for (std::size_t i = 0; i < scans; ++i) {
    std::snprintf(name, sizeof name, "/%06zu.bin", i);
    for (const std::string sub : {"/velodyne", "/point_times"})  // relative: the folders move together
      fs::create_symlink(fs::relative(drive + sub + name, out + sub), out + sub + name);
  }
  fs::copy_file(drive + "/meta.json", out + "/meta.json");
  auto lines = [](const std::string& path) {
    std::vector<std::string> v;
    std::istringstream in(pl::test::read_file(path));
    for (std::string line; std::getline(in, line);) v.push_back(line);
    return v;
  };
  const auto times = lines(drive + "/times.txt"), poses = lines(drive + "/poses.txt");
  const double end = std::stod(times.at(scans - 1)) + 0.05;
  std::string t, p;
  for (std::size_t i = 0; i < scans; ++i) t += times[i] + "\n", p += poses[i] + "\n";
  pl::test::write_file(out + "/times.txt", t);
  pl::test::write_file(out + "/poses.txt", p);
  for (const char* csv : {"/gps.csv", "/encoder.csv"}) {  // a header, then rows led by their time
    const auto rows = lines(drive + csv);
    std::string kept = rows.at(0) + "\n";
    for (std::size_t i = 1; i < rows.size() && std::stod(rows[i]) <= end; ++i) kept += rows[i] + "\n";
    pl::test::write_file(out + csv, kept);
  }
}

// A stretch of the town (110 scans, 16 beams), and a drive over its first 30 scans on another day.
std::string drives() {
  return pl::test::made_once("base-map-drives", [](const std::string& d) {
    const std::string sim = tool("pl-sim") + " --route loop --seed 5 --traffic 4 --frames 110 --lidar vlp16 ";
    auto a = run(sim + "--drive-seed 1 --out " + d + "/base");
    ASSERT_EQ(a.exit_code, 0) << a.output;
    auto b = run(sim + "--drive-seed 3 --out " + d + "/day2");
    ASSERT_EQ(b.exit_code, 0) << b.output;
    keep_first_scans(d + "/day2", 30, d + "/new");
  });
}

// Both builds crop returns at 30 m, so that the short drive reaches only part of the base map.
const char* const kCrop = " --max-range 30";

std::map<std::pair<int, int>, std::string> tile_hashes(const std::string& db, std::int64_t version) {
  std::map<std::pair<int, int>, std::string> out;
  for (const auto& t : pl::store::Store::open(db, false).list_tiles("m", version)) out[{t.key.tx, t.key.ty}] = t.hash;
  return out;
}

}  // namespace

TEST(BaseMap, ADriveAddedKeepsTheTilesItDoesNotReachByteForByte) {
  const std::string d = drives();
  TempDir dir;
  const std::string db = dir / "maps.sqlite";
  // The base map at the drive's true poses (its odometry is not what is tested here), the new drive
  // placed by its own odometry, GPS and loops to the held base drive.
  auto r = run(tool("pl-map") + " build --dataset " + d + "/base --poses gt" + kCrop + " --out " + (dir / "v1.pcd"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("v1.drives.json"), std::string::npos) << r.output;
  r = run(tool("pl-map") + " tile --cloud " + (dir / "v1.pcd") + " --db " + db + " --map m");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  r = run(tool("pl-map") + " publish --db " + db + " --map m --version 1");
  ASSERT_EQ(r.exit_code, 0) << r.output;

  r = run(tool("pl-map") + " build --base-map " + (dir / "v1.pcd") + " --dataset " + d + "/new --poses lidar --gps --loops" + kCrop +
          " --report " + (dir / "report.json") + " --traj-out " + (dir / "new.txt") + " --out " + (dir / "v2.pcd"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(r.output.find("lidar odometry, drive 1"), std::string::npos) << "the base drive ran again:\n" << r.output;
  r = run(tool("pl-map") + " tile --cloud " + (dir / "v2.pcd") + " --db " + db + " --map m");
  ASSERT_EQ(r.exit_code, 0) << r.output;

  // The base drive is held: its poses come back to the bit in the new map's record.
  const pl::maps::DriveRecord v1 = pl::maps::read_drive_record(dir / "v1.drives.json");
  const pl::maps::DriveRecord v2 = pl::maps::read_drive_record(dir / "v2.drives.json");
  ASSERT_EQ(v1.drives.size(), 1u);
  ASSERT_EQ(v2.drives.size(), 2u);
  ASSERT_EQ(v1.drives[0].poses.size(), v2.drives[0].poses.size());
  for (std::size_t i = 0; i < v1.drives[0].poses.size(); ++i)
    ASSERT_TRUE(v1.drives[0].poses.poses[i].matrix() == v2.drives[0].poses.poses[i].matrix()) << "pose " << i;
  const auto report = nlohmann::json::parse(pl::test::read_file(dir / "report.json"));
  EXPECT_TRUE(report.at("drives")[0].at("fixed").get<bool>());
  // The new drive lies where it was driven, and the loops tied it to the base drive.
  EXPECT_LT(report.at("drives")[1].at("mean_error_after_m").get<double>(), 0.1) << report.at("drives")[1].dump();
  EXPECT_GE(report.at("drives")[1].at("loops_to")[0].get<int>(), 2) << report.at("drives")[1].dump();

  // Tiles: every tile holding the new drive's points is new or changed; every tile with no such point
  // in it or beside it (the normals look 0.6 m across tile borders) has the bytes it had.
  std::set<std::pair<int, int>> reached;
  for (const auto& t : report.at("tiles"))
    if (t.at("points_by_drive")[1].get<int>() > 0) reached.insert({t.at("tx").get<int>(), t.at("ty").get<int>()});
  const auto before = tile_hashes(db, 1), after = tile_hashes(db, 2);
  std::size_t kept = 0, changed = 0;
  for (const auto& [key, hash] : after) {
    bool near = false;
    for (int dx = -1; dx <= 1; ++dx)
      for (int dy = -1; dy <= 1; ++dy) near = near || reached.count({key.first + dx, key.second + dy});
    const auto old = before.find(key);
    if (reached.count(key)) {
      EXPECT_TRUE(old == before.end() || old->second != hash) << "tile " << key.first << "," << key.second;
      ++changed;
    } else if (!near) {
      ASSERT_NE(old, before.end());
      EXPECT_EQ(old->second, hash) << "tile " << key.first << "," << key.second;
      ++kept;
    }
  }
  EXPECT_GE(kept, 3u);
  EXPECT_GE(changed, 3u);
}

TEST(BaseMap, ABaseMapThatCannotBeRepeatedIsRefusedByName) {
  const std::string d = drives();
  TempDir dir;
  auto r = run(tool("pl-map") + " build --dataset " + d + "/base --poses gt --every 4" + kCrop + " --out " + (dir / "v1.pcd"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const std::string add = tool("pl-map") + " build --base-map " + (dir / "v1.pcd") + " --dataset " + d + "/new --poses gt --out " +
                          (dir / "v2.pcd") + kCrop;
  // Other merge settings would move every voxel.
  r = run(add + " --every 4 --voxel 0.3");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("was merged with --voxel 0.2"), std::string::npos) << r.output;
  r = run(add);
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("--every 4"), std::string::npos) << r.output;
  EXPECT_FALSE(std::filesystem::exists(dir / "v2.pcd"));
  // With the same settings it works.
  r = run(add + " --every 4");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(pl::maps::read_drive_record(dir / "v2.drives.json").drives.size(), 2u);
  // A base drive that is no longer where the record says.
  pl::maps::DriveRecord moved = pl::maps::read_drive_record(dir / "v1.drives.json");
  moved.drives[0].dataset = dir / "gone";
  pl::maps::write_drive_record(dir / "v1.drives.json", moved);
  r = run(add + " --every 4");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("gone: the base map's drive 1 is not there"), std::string::npos) << r.output;
  // A map without its record.
  std::filesystem::remove(dir / "v1.drives.json");
  r = run(add + " --every 4");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("v1.drives.json: cannot read it"), std::string::npos) << r.output;
}

TEST(BaseMap, TheDriveRecordReadsBackToTheBit) {
  pl::maps::DriveRecord rec;
  rec.origin = pl::GeoPoint{49.011212804, 8.422885042, 112.83};
  rec.merge.voxel_m = 0.2;
  rec.merge.every = 3;
  rec.merge.scan.max_range_m = 80;
  pl::maps::RecordedDrive d;
  d.dataset = "/data/drive";
  d.deskew = true;
  for (int i = 0; i < 50; ++i) {
    pl::Pose p = pl::Pose::Identity();
    p.linear() = Eigen::AngleAxisd(0.1 * i + 1e-9, Eigen::Vector3d(0.1, 0.2, 1).normalized()).toRotationMatrix();
    p.translation() = Eigen::Vector3d(1.0 / 3.0 * i, -2.0 / 7.0 * i, 1.73 + 1e-12 * i);
    d.poses.poses.push_back(p);
    d.poses.times.push_back(0.1 * i + 1.0 / 3.0);
  }
  rec.drives.push_back(d);
  const pl::maps::DriveRecord back = pl::maps::decode_drive_record(pl::maps::encode_drive_record(rec), "rec");
  ASSERT_EQ(back.drives.size(), 1u);
  for (std::size_t i = 0; i < d.poses.size(); ++i) {
    EXPECT_TRUE(back.drives[0].poses.poses[i].matrix() == d.poses.poses[i].matrix()) << i;
    EXPECT_EQ(back.drives[0].poses.times[i], d.poses.times[i]);
  }
  EXPECT_EQ(back.merge.every, 3u);
  EXPECT_EQ(back.merge.last, SIZE_MAX);
  EXPECT_EQ(back.origin->lat_deg, rec.origin->lat_deg);
  EXPECT_EQ(pl::maps::drive_record_path("/a/town.pcd"), "/a/town.drives.json");
  // Damaged records are refused with what is wrong.
  auto refused = [](const std::string& bytes, const std::string& says) {
    try {
      pl::maps::decode_drive_record(bytes, "x.drives.json");
      ADD_FAILURE() << "accepted: " << bytes;
    } catch (const pl::Error& e) {
      EXPECT_NE(std::string(e.what()).find(says), std::string::npos) << e.what();
    }
  };
  std::string good = pl::maps::encode_drive_record(rec);
  refused("{", "not a drive record");
  refused(std::string(good).replace(good.find("\"version\":1"), 11, "\"version\":9"), "version 9");
  refused(std::string(good).replace(good.find("\"voxel_m\":0.2"), 13, "\"voxel_m\":-1"), "voxel_m");
  refused(std::string(good).replace(good.find("\"times\":["), 9, "\"times\":[1,"), "51 times for 50 poses");
}
