// Uploads to a real pl-server: a version staged, filled and published while readers see one version
// whole, a second publish from an outdated parent, signed publishes, and a kill mid-upload.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <mutex>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "pl/common/tile_codec.hpp"
#include "pl/common/tile_key.hpp"
#include "pl/schema/http_client.hpp"
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
using pl::test::kUploadToken;
using pl::test::MapFixture;
using pl::test::bearer;
using pl::test::body_json;

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

}  // namespace
