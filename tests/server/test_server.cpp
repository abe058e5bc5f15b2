// The map service end to end: pl-map writes a real SQLite store from a PCD, a real pl-server serves it
// on 127.0.0.1, and the tests talk HTTP to it.
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/time.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <map>
#include <mutex>
#include <nlohmann/json.hpp>
#include <random>
#include <set>
#include <thread>
#include <unordered_map>

#include "pl/schema/http_client.hpp"
#include "pl/common/cloud_io.hpp"
#include "pl/common/text.hpp"
#include "pl/common/tile_codec.hpp"
#include "pl/common/tile_key.hpp"
#include "pl/schema/signed_current.hpp"
#include "pl/schema/signed_manifest.hpp"
#include "pl/schema/store.hpp"
#include "map_fixture.hpp"
#include "server_process.hpp"
#include "test_util.hpp"

using nlohmann::json;
using pl::api::HttpClient;
using pl::test::ServerProcess;
using pl::test::TempDir;

namespace {

using pl::test::kAdminToken;
using pl::test::kReadToken;
using pl::test::kUploadToken;
using pl::test::MapFixture;
using pl::test::street_cloud;

std::map<std::string, std::string> bearer(const std::string& token) { return {{"Authorization", "Bearer " + token}}; }

json body_json(const pl::api::HttpResponse& r) { return json::parse(r.body); }

// An error answer: the status, in the body too, and an error text containing `words`.
void expect_error(const pl::api::HttpResponse& r, int status, const std::string& words) {
  EXPECT_EQ(r.status, status) << r.body;
  json j = json::parse(r.body, nullptr, false);
  ASSERT_FALSE(j.is_discarded()) << r.body;
  EXPECT_EQ(j["status"], status);
  EXPECT_NE(j["error"].get<std::string>().find(words), std::string::npos) << r.body;
}

}  // namespace

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
  // Every served point lies within 5 mm (per axis) of a point of the cloud, and the counts add up.
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
    EXPECT_EQ(c.normals.size(), c.size());
    for (const auto& p : c.points) {
      double best = 1e9;
      for (int dx = -1; dx <= 1; ++dx)
        for (int dy = -1; dy <= 1; ++dy)
          for (int dz = -1; dz <= 1; ++dz) {
            auto it = grid.find(cell(p + Eigen::Vector3d(dx, dy, dz) * 0.2));
            if (it == grid.end()) continue;
            for (const auto& q : it->second) best = std::min(best, (p - q).cwiseAbs().maxCoeff());
          }
      ASSERT_LE(best, 0.005 + 1e-9);
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

TEST(Server, UploadThenPublishSwitchesReadersAtomically) {
  MapFixture f;
  ServerProcess server(f.db, f.token_args());
  HttpClient http(server.url());
  json v1_tiles = body_json(http.get("/v1/maps/town/versions/1/tiles"))["tiles"];
  // A reader polls the ROI of the whole map throughout: it must only ever see v1 or v2, whole.
  std::atomic<bool> done{false};
  std::atomic<int> seen_v1{0}, seen_v2{0}, torn{0};
  std::thread reader([&] {
    HttpClient r(server.url());
    while (!done) {
      json j = body_json(r.get("/v1/maps/town/roi?x=10&y=10&radius=100"));
      int v = j["version"].get<int>();
      std::size_t n = j["tiles"].size();
      if (v == 1 && n == v1_tiles.size()) ++seen_v1;
      else if (v == 2 && n == v1_tiles.size() + 1) ++seen_v2;
      else ++torn;
    }
  });
  auto opened = http.request("POST", "/v1/maps/town/versions", R"({"note": "a new tile"})", bearer(kUploadToken));
  ASSERT_EQ(opened.status, 201) << opened.body;
  EXPECT_EQ(body_json(opened)["version"], 2);
  // A new tile far east, and one changed tile.
  pl::TileCloud extra;
  for (double x = 100.1; x < 119.0; x += 0.5)
    for (double y = 0.1; y < 19.0; y += 0.5) extra.points.emplace_back(x, y, 0.0), extra.normals.emplace_back(0, 0, 1), extra.intensity.push_back(0.3f);
  auto put = http.request("PUT", "/v1/maps/town/versions/2/tiles/5/0", pl::encode_tile(extra), bearer(kUploadToken));
  ASSERT_EQ(put.status, 200) << put.body;
  EXPECT_EQ(http.request("PUT", "/v1/maps/town/versions/2/tiles/5/0", pl::encode_tile(extra), bearer(kUploadToken)).status, 200);  // idempotent
  // Readers do not see the staged version.
  EXPECT_EQ(http.get("/v1/maps/town/versions/2/tiles/5/0").status, 404);
  EXPECT_EQ(body_json(http.get("/v1/maps/town"))["current_version"], 1);
  for (auto until = std::chrono::steady_clock::now() + std::chrono::seconds(30);
       seen_v1.load() < 3 && std::chrono::steady_clock::now() < until;)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  auto pub = http.request("POST", "/v1/maps/town/versions/2/publish", "", bearer(kUploadToken));
  ASSERT_EQ(pub.status, 200) << pub.body;
  // Let the reader see the new version (however slow this build is), then a few more reads.
  auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (seen_v2.load() < 3 && std::chrono::steady_clock::now() < deadline) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  done = true;
  reader.join();
  EXPECT_GT(seen_v1.load(), 0);
  EXPECT_GT(seen_v2.load(), 0);
  EXPECT_EQ(torn.load(), 0);
  EXPECT_EQ(body_json(http.get("/v1/maps/town"))["current_version"], 2);
  EXPECT_EQ(http.get("/v1/maps/town/versions/2/tiles/5/0").status, 200);
  // A published version takes no more writes.
  EXPECT_EQ(http.request("PUT", "/v1/maps/town/versions/2/tiles/5/0", pl::encode_tile(extra), bearer(kUploadToken)).status, 409);
}

// Two uploads opened from the same current version: the first publish wins, the second is 409
// (its version stays staged, unseen); one opened after the win publishes. A signed publish whose
// signature is not of the version's manifest is 422; the manifest of a staged version is the
// uploader's to read (no-cache), of a published one everybody's (immutable).
TEST(Server, SecondPublishFromAnOutdatedParentIs409) {
  MapFixture f;
  ServerProcess server(f.db, f.token_args());
  HttpClient http(server.url());
  auto open = [&] {
    auto r = http.request("POST", "/v1/maps/town/versions", "", bearer(kUploadToken));
    EXPECT_EQ(r.status, 201) << r.body;
    return body_json(r)["version"].get<int>();
  };
  const int a = open(), b = open();
  EXPECT_EQ(http.request("POST", "/v1/maps/town/versions/" + std::to_string(a) + "/publish", "", bearer(kUploadToken)).status, 200);
  auto lost = http.request("POST", "/v1/maps/town/versions/" + std::to_string(b) + "/publish", "", bearer(kUploadToken));
  EXPECT_EQ(lost.status, 409) << lost.body;
  EXPECT_NE(lost.body.find("opened from version 1, and version " + std::to_string(a) + " is current now"), std::string::npos) << lost.body;
  EXPECT_EQ(body_json(http.get("/v1/maps/town"))["current_version"], a);
  EXPECT_EQ(http.get("/v1/maps/town/versions/" + std::to_string(b) + "/tiles").status, 404);
  const int c = open();
  // The staged manifest: the uploader's only, never cached; it names its parent.
  const std::string mt = "/v1/maps/town/versions/" + std::to_string(c) + "/manifest";
  EXPECT_EQ(http.get(mt).status, 404);
  auto staged = http.get(mt, bearer(kUploadToken));
  ASSERT_EQ(staged.status, 200) << staged.body;
  EXPECT_EQ(staged.header("cache-control"), "private, no-cache");
  EXPECT_NE(staged.body.find("\nparent " + std::to_string(a) + "\n"), std::string::npos) << staged.body;
  EXPECT_EQ(pl::signing::parse_manifest_text(staged.body).version, c);
  // A signature by a key, of other bytes: refused, nothing published, nothing stored.
  const auto key = pl::signing::SigningKey::generate();
  const json wrong = {{"public_key", pl::signing::encode_base64(key.public_key())}, {"signature", pl::signing::encode_base64(key.sign("other"))}};
  auto bad = http.request("POST", "/v1/maps/town/versions/" + std::to_string(c) + "/publish", wrong.dump(), bearer(kUploadToken));
  EXPECT_EQ(bad.status, 422) << bad.body;
  EXPECT_NE(bad.body.find("does not verify"), std::string::npos) << bad.body;
  EXPECT_EQ(http.request("POST", "/v1/maps/town/versions/" + std::to_string(c) + "/publish", "{\"public_key\": 1}", bearer(kUploadToken)).status, 400);
  EXPECT_FALSE(pl::store::Store::open(f.db, false).signature("town", c));
  const json right = {{"public_key", pl::signing::encode_base64(key.public_key())}, {"signature", pl::signing::encode_base64(key.sign(staged.body))}};
  EXPECT_EQ(http.request("POST", "/v1/maps/town/versions/" + std::to_string(c) + "/publish", right.dump(), bearer(kUploadToken)).status, 200);
  auto published = http.get(mt);
  ASSERT_EQ(published.status, 200);
  EXPECT_EQ(published.header("cache-control"), "public, max-age=31536000, immutable");
  EXPECT_EQ(pl::signing::verify_signed_manifest(published.body, {key.public_key()}).text, staged.body);
  auto store = pl::store::Store::open(f.db, false);
  std::vector<std::string> actions;
  for (const auto& e : store.upload_log("town"))
    if (e.who.rfind("token ", 0) == 0) actions.push_back(e.action);
  EXPECT_EQ(actions, (std::vector<std::string>{"create_version", "create_version", "publish", "publish_refused", "create_version", "publish"}));
  EXPECT_EQ(store.find_version("town", b)->state, pl::store::VersionState::Staged);
  EXPECT_TRUE(store.integrity_ok());
}

TEST(Server, KillDuringUploadKeepsThePreviousVersion) {
  MapFixture f;
  std::mutex acked_mutex;
  std::vector<std::pair<pl::TileKey, std::string>> acked;  // the tiles answered 200, with their hashes
  {
    ServerProcess server(f.db, f.token_args());
    HttpClient http(server.url());
    ASSERT_EQ(http.request("POST", "/v1/maps/town/versions", "", bearer(kUploadToken)).status, 201);
    std::atomic<bool> stop{false};
    std::atomic<int> answered{0};
    std::thread uploader([&] {
      HttpClient up(server.url(), 2.0);
      for (int k = 0; k < 2500 && !stop; ++k) {  // each PUT a tile of its own
        const int tx = k % 50, ty = k / 50;
        pl::TileCloud t;
        for (int i = 0; i < 400; ++i) t.points.emplace_back(20.0 * tx + 0.04 * i + 0.1, 20.0 * ty + 0.1 + 0.04 * i, 0.01 * k);
        const std::string bytes = pl::encode_tile(t);
        try {
          const auto r = up.request("PUT", "/v1/maps/town/versions/2/tiles/" + std::to_string(tx) + "/" + std::to_string(ty),
                                    bytes, bearer(kUploadToken));
          if (r.status != 200) return;
          std::lock_guard<std::mutex> lock(acked_mutex);
          acked.emplace_back(pl::TileKey{tx, ty}, pl::store::content_hash(bytes));
          ++answered;
        } catch (...) {
          return;  // the server is gone
        }
      }
    });
    // Killed mid-upload: once some tiles are answered, with more on their way.
    EXPECT_TRUE(pl::test::eventually([&] { return answered >= 5; }, 120.0))
        << "no tile was answered (a hang guard, not a time bound)";
    server.kill9();
    stop = true;
    uploader.join();
  }
  pl::store::Store store = pl::store::Store::open(f.db, false);
  EXPECT_TRUE(store.integrity_ok());
  // Every tile the server answered was in the store before the kill, with the bytes sent.
  ASSERT_GE(acked.size(), 5u);
  for (const auto& [key, hash] : acked) {
    const auto stored = store.find_tile("town", 2, key);
    ASSERT_TRUE(stored) << "tile " << key.tx << "/" << key.ty << " was answered 200 and is not in the store";
    EXPECT_EQ(stored->hash, hash);
  }
  auto m = store.find_map("town");
  ASSERT_TRUE(m && m->current);
  EXPECT_EQ(*m->current, 1);
  ServerProcess again(f.db);
  HttpClient http(again.url());
  EXPECT_EQ(body_json(http.get("/v1/maps/town"))["current_version"], 1);
  EXPECT_EQ(http.get("/v1/maps/town/versions/2/tiles/0/0").status, 404);
}

TEST(Server, BadInputGetsTheRightStatusAndAJsonError) {
  MapFixture f;
  ServerProcess server(f.db, f.token_args());
  HttpClient http(server.url());
  const auto expect = expect_error;
  expect(http.get("/v1/maps/town/roi?x=abc&y=0&radius=5"), 400, "x must be a number");
  expect(http.get("/v1/maps/town/roi?y=0&radius=5"), 400, "missing query parameter x");
  expect(http.get("/v1/maps/town/versions/zero/tiles/0/0"), 400, "version");
  expect(http.get("/v1/maps/town/versions/1/tiles/0/x"), 400, "tile index");
  expect(http.get("/v1/maps/nowhere"), 404, "no map named");
  expect(http.get("/v1/maps/town/versions/9/tiles/0/0"), 404, "no version 9");
  expect(http.get("/v1/maps/town/versions/1/tiles/300/300"), 404, "no tile 300/300");
  expect(http.get("/v1/nothing"), 404, "no such resource");
  expect(http.request("DELETE", "/v1/maps/town"), 405, "not allowed");
  expect(http.request("POST", "/v1/maps/town/versions"), 401, "upload role");
  expect(http.request("POST", "/v1/maps/town/versions", "", bearer("wrong")), 401, "unknown or revoked token");
  expect(http.request("POST", "/v1/maps/town/versions", "", bearer(kReadToken)), 403, "needs the upload role");
  expect(http.request("POST", "/v1/maps", R"({"name":"x","origin":{"lat":1,"lon":2}})", bearer(kUploadToken)), 403, "admin");
  expect(http.request("POST", "/v1/maps", "{not json", bearer(kAdminToken)), 400, "expected JSON");
  ASSERT_EQ(http.request("POST", "/v1/maps/town/versions", "", bearer(kUploadToken)).status, 201);
  expect(http.request("PUT", "/v1/maps/town/versions/2/tiles/0/0", "this is not draco", bearer(kUploadToken)), 422, "not a valid tile");
  pl::TileCloud off;
  off.points.emplace_back(55.0, 5.0, 0.0);  // belongs to tile 2/0
  expect(http.request("PUT", "/v1/maps/town/versions/2/tiles/0/0", pl::encode_tile(off), bearer(kUploadToken)), 422, "outside tile");
  std::string huge((64u << 20) + 1, 'x');
  auto big = http.request("PUT", "/v1/maps/town/versions/2/tiles/0/0", huge, bearer(kUploadToken));
  EXPECT_EQ(big.status, 413);
  // Admin creates a map; the name is taken the second time.
  std::string make = R"({"name":"depot","origin":{"lat":49.1,"lon":8.5,"alt":100},"tile_size":25,"voxel_size":0.2})";
  HttpClient admin(server.url());
  EXPECT_EQ(admin.request("POST", "/v1/maps", make, bearer(kAdminToken)).status, 201);
  expect(admin.request("POST", "/v1/maps", make, bearer(kAdminToken)), 409, "exists already");
  // Nothing crashed: the server still answers.
  EXPECT_EQ(HttpClient(server.url()).get("/healthz").status, 200);
}

TEST(Server, PlacesAreUploadedWhileStagedAndServedUnderTheirHash) {
  MapFixture f;
  ServerProcess server(f.db, f.token_args());
  HttpClient http(server.url());
  const auto expect = expect_error;
  const std::string at = "/v1/maps/town/versions/";
  // pl-map tile found no places beside the cloud: version 1 has none.
  expect(http.get(at + "1/places"), 404, "map town version 1 has no places: rebuild it with pl-map build and pl-map tile");
  expect(http.get("/v1/maps/nowhere/versions/1/places"), 404, "no map named");
  expect(http.get(at + "9/places"), 404, "no version 9");
  expect(http.get(at + "zero/places"), 400, "version must be a positive whole number");

  std::mt19937 rng(11);
  std::string first(300000, '\0'), second(1000, '\0');
  for (auto& c : first) c = static_cast<char>(rng());
  for (auto& c : second) c = static_cast<char>(rng());
  const std::string first_hash = pl::store::content_hash(first), second_hash = pl::store::content_hash(second);
  // Uploads need the upload role and a staged version.
  expect(http.request("PUT", at + "1/places", first), 401, "upload role");
  expect(http.request("PUT", at + "1/places", first, bearer(kReadToken)), 403, "needs the upload role");
  expect(http.request("PUT", at + "1/places", first, bearer(kUploadToken)), 409, "version 1 is published");
  ASSERT_EQ(http.request("POST", "/v1/maps/town/versions", "", bearer(kUploadToken)).status, 201);
  expect(http.request("PUT", at + "2/places", "", bearer(kUploadToken)), 422, "the body is empty");
  auto put = http.request("PUT", at + "2/places", first, bearer(kUploadToken));
  ASSERT_EQ(put.status, 200) << put.body;
  EXPECT_EQ(body_json(put), json({{"version", 2}, {"hash", first_hash}, {"bytes", first.size()}}));

  // A staged version's places: uploaders only, and revalidated (they may still change).
  expect(http.get(at + "2/places"), 404, "no version 2");
  auto staged = http.get(at + "2/places", bearer(kUploadToken));
  ASSERT_EQ(staged.status, 200) << staged.body;
  EXPECT_TRUE(staged.body == first);
  EXPECT_EQ(staged.header("content-type"), "application/octet-stream");
  EXPECT_EQ(staged.header("etag"), "\"" + first_hash + "\"");
  EXPECT_EQ(staged.header("cache-control"), "private, no-cache");
  auto same = http.get(at + "2/places", {{"Authorization", "Bearer " + kUploadToken}, {"If-None-Match", staged.header("etag")}});
  EXPECT_EQ(same.status, 304);
  EXPECT_TRUE(same.body.empty());
  ASSERT_EQ(http.request("PUT", at + "2/places", second, bearer(kUploadToken)).status, 200);  // replaced
  auto changed = http.get(at + "2/places", {{"Authorization", "Bearer " + kUploadToken}, {"If-None-Match", staged.header("etag")}});
  ASSERT_EQ(changed.status, 200);
  EXPECT_TRUE(changed.body == second);
  EXPECT_EQ(changed.header("etag"), "\"" + second_hash + "\"");

  // Published: read-only, and cached for good like tiles.
  ASSERT_EQ(http.request("POST", at + "2/publish", "", bearer(kUploadToken)).status, 200);
  expect(http.request("PUT", at + "2/places", first, bearer(kUploadToken)), 409, "version 2 is published");
  for (int i = 0; i < 2; ++i) {  // the second from the server's memory
    auto published = http.get(at + "2/places");
    ASSERT_EQ(published.status, 200) << published.body;
    EXPECT_TRUE(published.body == second);
    EXPECT_EQ(published.header("etag"), "\"" + second_hash + "\"");
    EXPECT_EQ(published.header("cache-control"), "public, max-age=31536000, immutable");
  }
  EXPECT_EQ(http.get(at + "2/places", {{"If-None-Match", "\"" + second_hash + "\""}}).status, 304);
  EXPECT_EQ(http.get(at + "2/places", {{"If-None-Match", "*"}}).status, 304);
  EXPECT_EQ(http.get(at + "2/places", {{"If-None-Match", "\"" + first_hash + "\""}}).status, 200);
  auto head = http.request("HEAD", at + "2/places");
  EXPECT_EQ(head.status, 200);
  EXPECT_EQ(head.header("content-length"), std::to_string(second.size()));
  EXPECT_TRUE(head.body.empty());
  // Places are not tile blobs.
  EXPECT_EQ(http.get("/v1/blobs/" + second_hash).status, 404);

  // A new version starts with a copy of its parent's places.
  ASSERT_EQ(http.request("POST", "/v1/maps/town/versions", "", bearer(kUploadToken)).status, 201);
  auto copied = http.get(at + "3/places", bearer(kUploadToken));
  ASSERT_EQ(copied.status, 200);
  EXPECT_TRUE(copied.body == second);

  // The methods of the resource, and the body limit (64 MiB).
  auto options = http.request("OPTIONS", at + "3/places");
  EXPECT_EQ(options.status, 204);
  EXPECT_EQ(options.header("allow"), "GET, HEAD, PUT, DELETE, OPTIONS");
  auto post = http.request("POST", at + "3/places", "", bearer(kUploadToken));
  expect(post, 405, "not allowed");
  EXPECT_EQ(post.header("allow"), "GET, HEAD, PUT, DELETE, OPTIONS");
  EXPECT_EQ(http.request("PUT", at + "3/places", std::string((64u << 20) + 1, 'p'), bearer(kUploadToken)).status, 413);
  EXPECT_TRUE(http.get(at + "3/places", bearer(kUploadToken)).body == second);
  // An upload of a map without places removes the copy (staged versions only).
  expect(http.request("DELETE", at + "2/places", "", bearer(kUploadToken)), 409, "version 2 is published");
  expect(http.request("DELETE", at + "3/places", "", bearer(kReadToken)), 403, "needs the upload role");
  auto deleted = http.request("DELETE", at + "3/places", "", bearer(kUploadToken));
  EXPECT_EQ(deleted.status, 200) << deleted.body;
  expect(http.get(at + "3/places", bearer(kUploadToken)), 404, "map town version 3 has no places");
  expect(http.request("DELETE", at + "3/places", "", bearer(kUploadToken)), 404, "map town version 3 has no places");
  EXPECT_TRUE(http.get(at + "2/places").body == second);

  auto metrics = http.get("/metrics");
  EXPECT_NE(metrics.body.find("pl_requests_total{route=\"/v1/maps/{map}/versions/{v}/places\",status=\"200\"}"), std::string::npos)
      << metrics.body;
  EXPECT_NE(metrics.body.find("pl_requests_total{route=\"/v1/maps/{map}/versions/{v}/places\",status=\"409\"} 3"), std::string::npos)
      << metrics.body;
  EXPECT_EQ(server.terminate(), 0);
  // Each upload is in the upload log, with the hash and size of what was stored.
  pl::store::Store store = pl::store::Store::open(f.db, false);
  std::vector<std::string> uploads;
  for (const auto& e : store.upload_log("town"))
    if (e.action.find("places") != std::string::npos)
      uploads.push_back(e.action + " " + std::to_string(*e.version) + " " + e.detail + " " + e.who);
  // Each names its token by id (the fixture's upload token is the second the server registered).
  const std::string by = "token " + std::to_string(store.find_token(kUploadToken)->id);
  EXPECT_EQ(uploads, (std::vector<std::string>{"put_places 2 " + first_hash + " 300000 bytes " + by,
                                               "put_places 2 " + second_hash + " 1000 bytes " + by, "delete_places 3  " + by}));
  EXPECT_EQ(store.places("town", 2), second);
  EXPECT_FALSE(store.places("town", 3));
  EXPECT_TRUE(store.integrity_ok());
}

TEST(Server, ReadTokenRequired) {
  MapFixture f;
  std::vector<std::string> args = f.token_args();
  args.push_back("--read-token-required");
  ServerProcess server(f.db, args);
  HttpClient http(server.url());
  EXPECT_EQ(http.get("/v1/maps/town").status, 401);
  EXPECT_EQ(http.get("/v1/maps/town", bearer(kReadToken)).status, 200);
  EXPECT_EQ(http.get("/healthz").status, 200);
}

TEST(Server, HealthReadinessMetricsAndAccessLog) {
  MapFixture f;
  ServerProcess server(f.db);
  HttpClient http(server.url());
  EXPECT_EQ(http.get("/healthz").body, "ok\n");
  EXPECT_EQ(http.get("/readyz").status, 200);
  http.get("/v1/maps/town/roi?x=0&y=0&radius=30");
  http.get("/v1/maps/nowhere");
  auto metrics = http.get("/metrics");
  ASSERT_EQ(metrics.status, 200);
  EXPECT_NE(metrics.body.find("pl_requests_total{route=\"/v1/maps/{map}/roi\",status=\"200\"} 1"), std::string::npos) << metrics.body;
  EXPECT_NE(metrics.body.find("pl_requests_total{route=\"/v1/maps/{map}\",status=\"404\"} 1"), std::string::npos) << metrics.body;
  EXPECT_NE(metrics.body.find("pl_request_duration_seconds_bucket{le=\"+Inf\"}"), std::string::npos);
  EXPECT_NE(metrics.body.find("pl_open_connections 1"), std::string::npos);
  EXPECT_NE(metrics.body.find("\npl_requests_in_progress 1\n"), std::string::npos) << metrics.body;  // the /metrics request
  EXPECT_NE(metrics.body.find("pl_database_bytes "), std::string::npos);
  EXPECT_EQ(server.terminate(), 0);
  const std::string& log = server.output();
  EXPECT_NE(log.find("\"GET /v1/maps/town/roi?x=0&y=0&radius=30\" 200"), std::string::npos) << log;
  EXPECT_NE(log.find("\"GET /v1/maps/nowhere\" 404"), std::string::npos) << log;
  EXPECT_NE(log.find("pl-server: stopped"), std::string::npos) << log;
}

TEST(Server, GracefulStopFinishesTheRequestInFlight) {
  MapFixture f;
  ServerProcess server(f.db, f.token_args());
  const auto connected = [&] {
    const int fd = socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_port = htons(static_cast<std::uint16_t>(server.port()));
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    EXPECT_EQ(connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)), 0);
    const timeval hang_guard{120, 0};  // a read that never ends fails the test instead of hanging it
    setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &hang_guard, sizeof hang_guard);
    return fd;
  };
  // A kept-alive connection, answered and now idle.
  const int idle = connected();
  const std::string healthz = "GET /healthz HTTP/1.1\r\nHost: t\r\n\r\n";
  ASSERT_EQ(write(idle, healthz.data(), healthz.size()), static_cast<ssize_t>(healthz.size()));
  char buf[4096];
  ssize_t n = read(idle, buf, sizeof(buf));
  ASSERT_GT(n, 0);
  ASSERT_EQ(std::string(buf, static_cast<std::size_t>(n)).rfind("HTTP/1.1 200", 0), 0u);
  // A request half sent when SIGTERM arrives.
  const int fd = connected();
  std::string body = R"({"note": "in flight"})";
  std::string head = "POST /v1/maps/town/versions HTTP/1.1\r\nHost: t\r\nAuthorization: Bearer " + kUploadToken +
                     "\r\nContent-Length: " + std::to_string(body.size()) + "\r\n\r\n" + body.substr(0, 5);
  ASSERT_EQ(write(fd, head.data(), head.size()), static_cast<ssize_t>(head.size()));
  // SIGTERM once the server has begun that request (its header read): two in progress with /metrics.
  HttpClient metrics(server.url());
  ASSERT_TRUE(pl::test::eventually(
      [&] { return metrics.get("/metrics").body.find("\npl_requests_in_progress 2\n") != std::string::npos; }, 120.0))
      << "the server never began the request (a hang guard, not a time bound)";
  std::thread stopper([&] { EXPECT_EQ(server.terminate(), 0); });
  // The stop lets the idle connection go at once, while the request in flight is still unanswered:
  // an idle connection does not hold the stop up.
  EXPECT_EQ(read(idle, buf, sizeof(buf)), 0) << "the idle connection was not closed by the stop";
  close(idle);
  std::string rest = body.substr(5);
  EXPECT_EQ(write(fd, rest.data(), rest.size()), static_cast<ssize_t>(rest.size()));  // not ASSERT: the stopper is to be joined
  std::string answer;
  while ((n = read(fd, buf, sizeof(buf))) > 0) answer.append(buf, static_cast<std::size_t>(n));
  close(fd);
  stopper.join();
  EXPECT_EQ(answer.rfind("HTTP/1.1 201", 0), 0u) << answer;
  EXPECT_NE(answer.find("Connection: close"), std::string::npos) << answer;
  pl::store::Store store = pl::store::Store::open(f.db, false);
  EXPECT_TRUE(store.find_version("town", 2).has_value());
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
  std::string bytes = pl::encode_tile(big);
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

// Each token's uploads are limited (429 with Retry-After beyond); pl-map push waits as told and
// gets its version through all the same.
TEST(Server, UploadsAreRateLimitedPerTokenAndPushWaitsItOut) {
  MapFixture f;
  TempDir dir;
  const std::string remote = dir / "remote.sqlite";
  pl::store::Store::open(remote, true);
  ServerProcess server(remote, {"--tokens", f.dir / "tokens.txt", "--upload-rate", "4", "--upload-burst", "2"});
  HttpClient http(server.url());
  int limited = 0;
  std::string retry_after, message;
  for (int i = 0; i < 6; ++i) {
    auto r = http.request("POST", "/v1/maps/town/versions", "", bearer(kUploadToken));  // 404: no such map, yet counted
    if (r.status == 429) ++limited, retry_after = r.header("retry-after"), message = r.body;
  }
  EXPECT_GE(limited, 3);
  EXPECT_EQ(retry_after, "1");
  EXPECT_NE(message.find("--upload-rate"), std::string::npos) << message;
  // Another token has its own allowance; reads are not limited.
  EXPECT_NE(http.request("POST", "/v1/maps/town/versions", "", bearer(kAdminToken)).status, 429);
  for (int i = 0; i < 10; ++i) EXPECT_EQ(http.get("/v1/maps").status, 200);
  auto r = pl::test::run(pl::test::tool("pl-map") + " push --db " + f.db + " --map town --version 1 --server " + server.url() +
                         " --token " + kAdminToken + " 2>&1");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(body_json(http.get("/v1/maps/town"))["current_version"], 1);
}

// Rotation as an operator does it, with the server running throughout: a new token made with
// pl-map token-add works at once, the old one revoked with pl-map token-revoke stops at once, and
// the upload log names each upload's token by id.
TEST(Server, TokensAreRotatedAndRevokedWithoutARestart) {
  MapFixture f;
  ServerProcess server(f.db, f.token_args());
  HttpClient http(server.url());
  const std::string pl_map = pl::test::tool("pl-map");
  ASSERT_EQ(http.request("POST", "/v1/maps/town/versions", "", bearer(kUploadToken)).status, 201);
  // The token alone on stdout (what to do with it goes to stderr).
  auto made = pl::test::run("{ " + pl_map + " token-add --db " + f.db + " --role upload --note 'survey car 2' 2>/dev/null; }");
  ASSERT_EQ(made.exit_code, 0) << made.output;
  const std::string fresh = made.output.substr(0, made.output.find('\n'));
  ASSERT_EQ(fresh.size(), 43u) << made.output;
  ASSERT_EQ(http.request("POST", "/v1/maps/town/versions", "", bearer(fresh)).status, 201);
  // The old token's id, from the list (which never shows a token).
  auto list = pl::test::run(pl_map + " token-list --db " + f.db + " 2>&1");
  ASSERT_EQ(list.exit_code, 0) << list.output;
  EXPECT_EQ(list.output.find(kUploadToken), std::string::npos);
  EXPECT_EQ(list.output.find(fresh), std::string::npos);
  auto store = pl::store::Store::open(f.db, false);
  const auto old_id = store.find_token(kUploadToken)->id, fresh_id = store.find_token(fresh)->id;
  auto revoked = pl::test::run(pl_map + " token-revoke --db " + f.db + " --id " + std::to_string(old_id) + " 2>&1");
  ASSERT_EQ(revoked.exit_code, 0) << revoked.output;
  auto refused = http.request("POST", "/v1/maps/town/versions", "", bearer(kUploadToken));
  EXPECT_EQ(refused.status, 401);
  EXPECT_NE(refused.body.find("revoked"), std::string::npos) << refused.body;
  EXPECT_EQ(http.request("POST", "/v1/maps/town/versions", "", bearer(fresh)).status, 201);
  // Revoking twice says so.
  auto again = pl::test::run(pl_map + " token-revoke --db " + f.db + " --id " + std::to_string(old_id) + " 2>&1");
  EXPECT_NE(again.exit_code, 0);
  EXPECT_NE(again.output.find("revoked already"), std::string::npos) << again.output;
  // Who made each version: by token id.
  std::vector<std::string> who;
  for (const auto& e : store.upload_log("town"))
    if (e.action == "create_version") who.push_back(e.who);
  EXPECT_EQ(who, (std::vector<std::string>{"token " + std::to_string(old_id), "token " + std::to_string(fresh_id),
                                           "token " + std::to_string(fresh_id)}));
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
