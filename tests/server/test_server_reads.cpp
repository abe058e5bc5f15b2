// Reading maps from a real pl-server: tiles within the quantization bound, ETags and caching, ROI
// queries and how they follow publishes, large tiles to slow readers, Debian's Draco decoder, and the
// signed current version.
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <random>
#include <set>
#include <string>
#include <thread>
#include <unordered_map>
#include <utility>
#include <vector>

#include "pl/common/text.hpp"
#include "pl/common/tile_codec.hpp"
#include "pl/common/tile_key.hpp"
#include "pl/schema/http_client.hpp"
#include "pl/schema/signed_current.hpp"
#include "pl/schema/signed_manifest.hpp"
#include "pl/schema/store.hpp"
#include "http_helpers.hpp"
#include "map_fixture.hpp"
#include "server_process.hpp"
#include "test_util.hpp"

namespace {

using nlohmann::json;
using pl::api::HttpClient;
using pl::test::ServerProcess;
using pl::test::kReadToken;
using pl::test::kUploadToken;
using pl::test::MapFixture;
using pl::test::bearer;
using pl::test::body_json;
using pl::test::expect_error;

TEST(Server, TilesDecodeToTheCloudWithinTheQuantizationBound) {
  MapFixture f;
  ServerProcess server(f.db, f.token_args());
  HttpClient http(server.url());
  auto manifest = http.get("/v1/maps/town");
  ASSERT_EQ(manifest.status, 200) << manifest.body;
  json m = body_json(manifest);
  EXPECT_EQ(m["current_version"], 1);
  EXPECT_DOUBLE_EQ(m["tile_size"].get<double>(), 20.0);
  EXPECT_GT(m["tile_count"].get<int>(), 8);

  auto roi = http.get("/v1/maps/town/roi?x=10&y=10&radius=100");
  ASSERT_EQ(roi.status, 200) << roi.body;
  json tiles = body_json(roi)["tiles"];
  ASSERT_EQ(tiles.size(), m["tile_count"].get<std::size_t>());
  // Every served point lies within the codec's bound (per axis) of a point of the cloud, and the counts add up.
  std::unordered_map<std::int64_t, std::vector<Eigen::Vector3d>> grid;
  auto cell = [](const Eigen::Vector3d& p) {
    return (static_cast<std::int64_t>(std::floor(p.x() * 5)) * 73856093) ^ (static_cast<std::int64_t>(std::floor(p.y() * 5)) * 19349663) ^
           (static_cast<std::int64_t>(std::floor(p.z() * 5)) * 83492791);
  };
  for (const auto& p : f.cloud) grid[cell(p)].push_back(p);
  std::size_t served = 0;
  for (const auto& t : tiles) {
    auto res = http.get(t["url"].get<std::string>());
    ASSERT_EQ(res.status, 200);
    EXPECT_EQ(res.header("content-type"), "application/vnd.google.draco");
    pl::TileCloud c = pl::decode_tile(res.body);
    EXPECT_EQ(c.size(), t["points"].get<std::size_t>());
    EXPECT_TRUE(c.normals.empty());  // pl-map tile's default: positions only (vehicles estimate normals)
    for (const auto& p : c.points) {
      double best = 1e9;
      for (int dx = -1; dx <= 1; ++dx)
        for (int dy = -1; dy <= 1; ++dy)
          for (int dz = -1; dz <= 1; ++dz) {
            auto it = grid.find(cell(p + Eigen::Vector3d(dx, dy, dz) * 0.2));
            if (it == grid.end()) continue;
            for (const auto& q : it->second) best = std::min(best, (p - q).cwiseAbs().maxCoeff());
          }
      ASSERT_LE(best, pl::TileCodecConfig{}.max_error_m + 1e-9);
    }
    served += c.size();
  }
  EXPECT_EQ(served, f.cloud.size());  // the cloud sits on a 0.2 m grid: voxelizing keeps every point
  EXPECT_EQ(server.terminate(), 0);
}

TEST(Server, EtagAndNotModified) {
  MapFixture f;
  ServerProcess server(f.db);
  HttpClient http(server.url());
  auto t = body_json(http.get("/v1/maps/town/roi?x=0&y=0&radius=1"))["tiles"][0];
  auto first = http.get(t["url"].get<std::string>());
  ASSERT_EQ(first.status, 200);
  EXPECT_EQ(first.header("etag"), "\"" + t["hash"].get<std::string>() + "\"");
  EXPECT_EQ(first.header("cache-control"), "public, max-age=31536000, immutable");
  auto again = http.get(t["url"].get<std::string>(), {{"If-None-Match", first.header("etag")}});
  EXPECT_EQ(again.status, 304);
  EXPECT_TRUE(again.body.empty());
  auto blob = http.get("/v1/blobs/" + t["hash"].get<std::string>());
  EXPECT_EQ(blob.status, 200);
  EXPECT_EQ(blob.body, first.body);
  EXPECT_EQ(http.get("/v1/blobs/" + t["hash"].get<std::string>(), {{"If-None-Match", first.header("etag")}}).status, 304);

  // Map answers change as versions are published: a cache keeps them a second, then revalidates
  // them by their weak ETag (with or without gzip, the same tag); a token's answers are private.
  for (const std::string target : {"/v1/maps", "/v1/maps/town", "/v1/maps/town/roi?x=0&y=0&radius=30", "/v1/maps/town/versions/1/tiles"}) {
    auto a = http.get(target), gz = http.get(target, {{"Accept-Encoding", "gzip"}});
    ASSERT_EQ(a.status, 200) << target;
    EXPECT_EQ(a.header("cache-control"), "public, max-age=1") << target;
    EXPECT_EQ(a.header("etag").rfind("W/\"", 0), 0u) << target << " " << a.header("etag");
    EXPECT_EQ(gz.header("etag"), a.header("etag")) << target;
    auto not_modified = http.get(target, {{"If-None-Match", a.header("etag")}});
    EXPECT_EQ(not_modified.status, 304) << target;
    EXPECT_TRUE(not_modified.body.empty());
    EXPECT_EQ(not_modified.header("vary"), "Accept-Encoding") << target;
    EXPECT_EQ(http.get(target, {{"If-None-Match", "W/\"0123\""}}).status, 200) << target;
  }
  MapFixture g;
  ServerProcess with_tokens(g.db, g.token_args());
  HttpClient h2(with_tokens.url());
  EXPECT_EQ(h2.get("/v1/maps/town", {{"Authorization", "Bearer " + kReadToken}}).header("cache-control"), "private, no-cache");
  // An ROI answer's tag names the version and the map, not the body's bytes: a store made afresh
  // under the same names (g holds the same map, built again) answers the same URL with another tag,
  // so a cache holding the first store's answer does not get a 304 from the second.
  const std::string roi = "/v1/maps/town/roi?x=0&y=0&radius=30";
  EXPECT_EQ(h2.get(roi).body, http.get(roi).body);
  EXPECT_NE(h2.get(roi).header("etag"), http.get(roi).header("etag"));
  EXPECT_EQ(h2.get(roi, {{"If-None-Match", http.get(roi).header("etag")}}).status, 200);
}

TEST(Server, RoiMatchesTheTilesThatTouchTheDisc) {
  MapFixture f;
  ServerProcess server(f.db);
  HttpClient http(server.url());
  json all = body_json(http.get("/v1/maps/town/versions/1/tiles"))["tiles"];
  ASSERT_GT(all.size(), 8u);
  pl::TileGrid grid(20.0);
  for (double x : {-35.0, -10.0, 0.0, 19.99, 20.0, 47.0})
    for (double y : {-15.0, 0.0, 10.0, 31.0})
      for (double r : {0.0, 5.0, 19.0, 40.0}) {
        std::set<std::pair<int, int>> expected, got;
        for (const auto& t : all) {
          pl::TileBounds b = grid.bounds_of({t["tx"].get<int>(), t["ty"].get<int>()});
          double dx = std::max({b.min_x - x, 0.0, x - b.max_x}), dy = std::max({b.min_y - y, 0.0, y - b.max_y});
          if (dx * dx + dy * dy <= r * r) expected.insert({t["tx"].get<int>(), t["ty"].get<int>()});
        }
        auto res = http.get("/v1/maps/town/roi?x=" + std::to_string(x) + "&y=" + std::to_string(y) + "&radius=" + std::to_string(r));
        ASSERT_EQ(res.status, 200) << res.body;
        json answer = body_json(res);
        for (const auto& t : answer["tiles"]) got.insert({t["tx"].get<int>(), t["ty"].get<int>()});
        EXPECT_EQ(got, expected) << "x=" << x << " y=" << y << " r=" << r;
      }
  // have=: only what the client lacks, and what it may drop.
  json near = body_json(http.get("/v1/maps/town/roi?x=0&y=0&radius=5"))["tiles"];
  json far = body_json(http.get("/v1/maps/town/roi?x=45&y=25&radius=1"))["tiles"];
  std::string have = near[0]["hash"].get<std::string>() + "," + far[0]["hash"].get<std::string>();
  json j = body_json(http.get("/v1/maps/town/roi?x=0&y=0&radius=5&have=" + have));
  EXPECT_EQ(j["tiles"].size(), near.size() - 1);
  ASSERT_EQ(j["drop"].size(), 1u);
  EXPECT_EQ(j["drop"][0], far[0]["hash"]);
}

TEST(Server, ServedTilesDecodeWithDebiansDracoDecoder) {
  ASSERT_TRUE(pl::file_exists("/usr/bin/draco_decoder"))
      << "draco_decoder is missing: apt-get install draco (./pl test installs it)";
  MapFixture f;
  ServerProcess server(f.db);
  HttpClient http(server.url());
  json t = body_json(http.get("/v1/maps/town/roi?x=5&y=5&radius=1"))["tiles"][0];
  auto res = http.get(t["url"].get<std::string>());
  ASSERT_EQ(res.status, 200);
  pl::test::write_file(f.dir / "tile.drc", res.body);
  auto r = pl::test::run("draco_decoder -i " + (f.dir / "tile.drc") + " -o " + (f.dir / "tile.ply"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  std::string ply = pl::test::read_file(f.dir / "tile.ply");
  EXPECT_NE(ply.find("element vertex " + std::to_string(t["points"].get<int>())), std::string::npos) << ply.substr(0, 300);
}

TEST(Server, LargeTileToASlowReaderArrivesWhole) {
  MapFixture f;
  ServerProcess server(f.db, f.token_args());
  HttpClient http(server.url());
  ASSERT_EQ(http.request("POST", "/v1/maps/town/versions", "", bearer(kUploadToken)).status, 201);
  // ~250k points of noise: a tile of megabytes that cannot sit in the socket buffers at once.
  pl::TileCloud big;
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> u(0.0, 19.99);
  for (int i = 0; i < 250000; ++i) {
    big.points.emplace_back(200.0 + u(rng), 200.0 + u(rng), u(rng));
    big.normals.push_back(Eigen::Vector3f(static_cast<float>(u(rng)) - 10.f, 1.f, 2.f).normalized());
    big.intensity.push_back(static_cast<float>(u(rng) / 20.0));
  }
  pl::TileCodecConfig fine;  // 1 mm and 10-bit normals keep the noise megabytes
  fine.max_error_m = 0.001;
  fine.normal_bits = fine.intensity_bits = 10;
  std::string bytes = pl::encode_tile(big, fine);
  ASSERT_GT(bytes.size(), 1u << 20);
  ASSERT_EQ(http.request("PUT", "/v1/maps/town/versions/2/tiles/10/10", bytes, bearer(kUploadToken)).status, 200);
  ASSERT_EQ(http.request("POST", "/v1/maps/town/versions/2/publish", "", bearer(kUploadToken)).status, 200);
  int fd = socket(AF_INET, SOCK_STREAM, 0);
  int small = 4096;
  setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &small, sizeof(small));
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(static_cast<std::uint16_t>(server.port()));
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  ASSERT_EQ(connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)), 0);
  std::string req = "GET /v1/maps/town/versions/2/tiles/10/10 HTTP/1.1\r\nHost: t\r\nConnection: close\r\n\r\n";
  ASSERT_EQ(write(fd, req.data(), req.size()), static_cast<ssize_t>(req.size()));
  std::this_thread::sleep_for(std::chrono::milliseconds(500));  // the server fills what it can, then waits
  std::string answer;
  char buf[8192];
  ssize_t n;
  while ((n = read(fd, buf, sizeof(buf))) > 0) {
    answer.append(buf, static_cast<std::size_t>(n));
    if (answer.size() % (256 * 1024) < sizeof(buf)) std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  close(fd);
  auto split = answer.find("\r\n\r\n");
  ASSERT_NE(split, std::string::npos);
  EXPECT_EQ(answer.rfind("HTTP/1.1 200", 0), 0u);
  EXPECT_NE(answer.find("Content-Length: " + std::to_string(bytes.size())), std::string::npos) << answer.substr(0, split);
  EXPECT_TRUE(answer.substr(split + 4) == bytes);
  // The server carries on.
  EXPECT_EQ(HttpClient(server.url()).get("/healthz").status, 200);
}

// ROI queries read the map's row from a short-lived cache: the server's own publish shows at the
// very next query, another writer's (here pl-map's Store on the same file) shortly after.
TEST(Server, RoiAnswersFollowPublishesByTheServerAndByAnotherWriter) {
  MapFixture f;
  ServerProcess server(f.db, f.token_args());
  HttpClient http(server.url());
  const std::string roi = "/v1/maps/town/roi?x=10&y=10&radius=30";
  const auto at_1 = http.get(roi);
  ASSERT_EQ(body_json(at_1)["version"], 1);  // the row is cached from here on
  // Replicas of one store give one answer one tag (a cache in front revalidates with either).
  {
    ServerProcess replica(f.db, f.token_args());
    EXPECT_EQ(HttpClient(replica.url()).get(roi).header("etag"), at_1.header("etag"));
  }
  ASSERT_EQ(http.request("POST", "/v1/maps/town/versions", "", bearer(kUploadToken)).status, 201);
  // A staged version's answer is tagged by its bytes: writing a tile changes its tag.
  const std::string staged_roi = roi + "&version=2";
  const auto staged = http.get(staged_roi, bearer(kUploadToken));
  ASSERT_EQ(staged.status, 200);
  ASSERT_EQ(body_json(staged)["tiles"].size(), body_json(at_1)["tiles"].size());
  const json gone = body_json(staged)["tiles"][0];
  ASSERT_EQ(http.request("DELETE", "/v1/maps/town/versions/2/tiles/" + std::to_string(gone["tx"].get<int>()) + "/" +
                                       std::to_string(gone["ty"].get<int>()), "", bearer(kUploadToken)).status, 200);
  EXPECT_NE(http.get(staged_roi, bearer(kUploadToken)).header("etag"), staged.header("etag"));
  ASSERT_EQ(http.request("POST", "/v1/maps/town/versions/2/publish", "", bearer(kUploadToken)).status, 200);
  const auto at_2 = http.get(roi, {{"If-None-Match", at_1.header("etag")}});  // the same URL: a new answer, not a 304
  EXPECT_EQ(at_2.status, 200);
  EXPECT_NE(at_2.header("etag"), at_1.header("etag"));
  EXPECT_EQ(body_json(at_2)["version"], 2);  // at once: the publish dropped the cached row
  EXPECT_EQ(body_json(at_2)["tiles"].size() + 1, body_json(at_1)["tiles"].size());
  {
    auto store = pl::store::Store::open(f.db, false);
    auto v = store.create_version("town", std::nullopt, "from another process");
    store.publish("town", v.number);
  }
  long long seen = 0;
  for (auto until = std::chrono::steady_clock::now() + std::chrono::seconds(30);
       seen != 3 && std::chrono::steady_clock::now() < until;
       std::this_thread::sleep_for(std::chrono::milliseconds(20)))
    seen = body_json(http.get(roi))["version"].get<long long>();
  EXPECT_EQ(seen, 3);
  // An unknown map is never cached as missing: once made, its next query knows it.
  const std::string nowhere = "/v1/maps/nowhere/roi?x=0&y=0&radius=1";
  EXPECT_NE(http.get(nowhere).body.find("no map named"), std::string::npos);
  ASSERT_EQ(http.request("POST", "/v1/maps", R"({"name": "nowhere", "origin": {"lat": 49, "lon": 8.4}})", bearer(pl::test::kAdminToken)).status, 201);
  EXPECT_NE(http.get(nowhere).body.find("no published version"), std::string::npos);
}

// GET /v1/maps/{map}/current: the map's current version signed with the timestamp key at each
// request, following publishes, valid for --timestamp-lifetime; 404 naming the fix without a key.
TEST(Server, CurrentVersionIsSignedFreshWithTheTimestampKey) {
  MapFixture f;
  const auto key = pl::signing::SigningKey::from_seed("pointlocalization timestamp test");
  key.save(f.dir / "timestamp.key");
  ServerProcess server(f.db, {"--timestamp-key", f.dir / "timestamp.key", "--timestamp-lifetime", "120", "--tokens", f.dir / "tokens.txt"});
  HttpClient http(server.url());
  auto now = [] { return pl::signing::unix_now(); };
  auto current = [&] {
    const std::int64_t before = now();
    auto r = http.get("/v1/maps/town/current");
    EXPECT_EQ(r.status, 200) << r.body;
    EXPECT_EQ(r.header("cache-control"), "public, max-age=1");
    EXPECT_EQ(r.header("content-type").rfind("text/plain", 0), 0u);
    const auto c = pl::signing::verify_signed_current(r.body, {key.public_key()}).current;
    EXPECT_EQ(c.map, "town");
    EXPECT_GE(c.issued, before);
    EXPECT_LE(c.issued, now());
    EXPECT_EQ(c.expires - c.issued, 120);
    return c.version;
  };
  EXPECT_EQ(current(), 1);
  auto v = http.request("POST", "/v1/maps/town/versions", "", bearer(kUploadToken));
  ASSERT_EQ(v.status, 201) << v.body;
  ASSERT_EQ(http.request("POST", "/v1/maps/town/versions/2/publish", "", bearer(kUploadToken)).status, 200);
  EXPECT_EQ(current(), 2);
  expect_error(http.get("/v1/maps/nowhere/current"), 404, "no map");
  EXPECT_EQ(http.request("POST", "/v1/maps/town/current", "", bearer(kUploadToken)).status, 405);

  // Without a key: 404 saying how to get one.
  ServerProcess plain(f.db);
  HttpClient http2(plain.url());
  expect_error(http2.get("/v1/maps/town/current"), 404, "start pl-server with --timestamp-key");
  // A key file that is no key: pl-server does not start, naming the file.
  pl::test::write_file(f.dir / "bad.key", "not a key\n");
  auto r = pl::test::run(pl::test::tool("pl-server") + " --db " + f.db + " --listen 127.0.0.1:0 --timestamp-key " + (f.dir / "bad.key"));
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find(f.dir / "bad.key"), std::string::npos) << r.output;
}

}  // namespace
