// The localizer's tile client against real parts: pl-map writes a real SQLite map store, a real
// pl-server serves it on 127.0.0.1. Here: the tiles it fetches, prefetches, evicts and pins, the read
// token, and its configuration. Waits poll with deadlines; nothing asserts on timing.
#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <utility>

#include "pl/client/tile_client.hpp"
#include "pl/common/error.hpp"
#include "pl/common/tile_key.hpp"
#include "pl/schema/http_client.hpp"
#include "pl/schema/store.hpp"
#include "server_process.hpp"
#include "test_util.hpp"
#include "tile_client_fixture.hpp"

namespace {

using nlohmann::json;
using pl::api::HttpClient;
using pl::client::TileClient;
using pl::client::TileClientConfig;
using pl::test::ServerProcess;
using pl::test::TempDir;
using pl::test::eventually;
using Eigen::Vector2d;
using pl::test::tile_client::by_key;
using pl::test::tile_client::config;
using pl::test::tile_client::expect_same_as_server;
using pl::test::tile_client::kReadToken;
using pl::test::tile_client::MapFixture;
using pl::test::tile_client::requests_in_log;
using pl::test::tile_client::server_tiles;

TEST(TileClient, TilesForAFocusEqualTheServersTilesDecoded) {
  MapFixture f;
  ServerProcess server(f.db);
  HttpClient http(server.url());
  TileClient client(config(server.url(), 30));
  ASSERT_TRUE(client.wait_ready(30));
  auto s = client.status();
  EXPECT_EQ(s.version, 1);
  EXPECT_DOUBLE_EQ(s.tile_size, 20.0);
  const auto info = pl::store::Store::open(f.db, false).find_map("town");  // the origin of the map's frame, as stored
  ASSERT_TRUE(info);
  EXPECT_EQ(s.origin.lat_deg, info->origin.lat_deg);
  EXPECT_EQ(s.origin.lon_deg, info->origin.lon_deg);
  EXPECT_EQ(s.origin.alt_m, info->origin.alt_m);
  Vector2d p(5, -12);
  client.set_focus(p, p);
  ASSERT_TRUE(client.wait_for(p, 30, 30)) << client.status().last_error;
  // So far only the client has asked: the manifest, one ROI query, then each tile once, all on one
  // kept-alive connection.
  auto asked = requests_in_log(server.output());
  std::set<std::string> remotes;
  for (const auto& [remote, target] : asked) remotes.insert(remote);
  EXPECT_EQ(remotes.size(), 1u) << server.output();
  ASSERT_GE(asked.size(), 2u);
  EXPECT_EQ(asked[0].second, "/v1/maps/town");
  EXPECT_EQ(asked[1].second.rfind("/v1/maps/town/roi?", 0), 0u);
  auto expected = server_tiles(http, 1, p, 30);
  ASSERT_GT(expected.size(), 4u);
  EXPECT_EQ(asked.size(), 2 + expected.size()) << server.output();
  auto got = client.tiles_near(p, 30);
  EXPECT_EQ(by_key(got), expected);
  std::size_t bytes = 0, tilted = 0;
  for (const auto& t : got) {
    expect_same_as_server(http, t);
    EXPECT_GT(t.cloud->size(), 300u);
    bytes += pl::client::decoded_size(*t.cloud);
    for (const auto& n : t.cloud->normals) tilted += n.z() < 0.999f;
  }
  EXPECT_GT(tilted, 100u) << "the curved ground's normals lean";
  s = client.status();
  EXPECT_TRUE(s.online);
  EXPECT_EQ(s.fetched, expected.size());
  EXPECT_EQ(s.tiles_in_memory, expected.size());
  EXPECT_EQ(s.bytes_in_memory, bytes);
  EXPECT_EQ(s.failures, 0u);
  EXPECT_EQ(s.last_error, "");
  // A little further: the ROI query names the tiles the client knows (have=), and no tile comes twice.
  Vector2d q = p + Vector2d(25, 0);
  client.set_focus(q, q);
  ASSERT_TRUE(client.wait_for(q, 30, 30)) << client.status().last_error;
  EXPECT_EQ(by_key(client.tiles_near(q, 30)), server_tiles(http, 1, q, 30));
  std::size_t roi_with_have = 0;
  std::map<std::string, int> blobs;
  for (const auto& [remote, target] : requests_in_log(server.output())) {
    if (target.find("/roi?") != std::string::npos && target.find("&version=1&have=") != std::string::npos) ++roi_with_have;
    if (target.rfind("/v1/blobs/", 0) == 0 && remote == asked[0].first) ++blobs[target];
  }
  EXPECT_EQ(roi_with_have, 1u) << server.output();
  for (const auto& [target, n] : blobs) EXPECT_EQ(n, 1) << target;
  EXPECT_EQ(client.status().fetched, blobs.size());
}

TEST(TileClient, TilesNearReturnsTheRightSetOnAGrid) {
  MapFixture f;
  ServerProcess server(f.db);
  HttpClient http(server.url());
  TileClient client(config(server.url(), 100));
  client.set_focus({0, 0}, {0, 0});  // the whole map lies within 100 m
  ASSERT_TRUE(client.wait_for({0, 0}, 100, 30)) << client.status().last_error;
  std::map<pl::TileKey, std::string> all;
  json listing = json::parse(http.get("/v1/maps/town/versions/1/tiles").body);
  for (const auto& t : listing["tiles"])
    all[{t["tx"].get<int>(), t["ty"].get<int>()}] = t["hash"].get<std::string>();
  EXPECT_EQ(all.size(), 35u);  // 6 x 6 keys but the lake
  EXPECT_FALSE(all.count({1, 1}));
  EXPECT_EQ(by_key(client.tiles_near({0, 0}, 1000)), all);
  pl::TileGrid grid(20.0);
  for (double x : {-75.0, -45.0, -20.0, -0.5, 0.0, 19.99, 20.0, 33.0, 61.0})
    for (double y : {-61.0, -20.0, 0.0, 10.0, 30.0, 44.0})
      for (double r : {0.0, 3.0, 10.0, 25.0, 50.0}) {
        std::map<pl::TileKey, std::string> expected;
        for (const auto& [k, h] : all) {
          pl::TileBounds b = grid.bounds_of(k);
          double dx = std::max({b.min_x - x, 0.0, x - b.max_x}), dy = std::max({b.min_y - y, 0.0, y - b.max_y});
          if (dx * dx + dy * dy <= r * r) expected[k] = h;
        }
        EXPECT_EQ(by_key(client.tiles_near({x, y}, r)), expected) << "x=" << x << " y=" << y << " r=" << r;
      }
}

TEST(TileClient, PrefetchesAroundTheLookAheadPoint) {
  MapFixture f;
  ServerProcess server(f.db);
  HttpClient http(server.url());
  TileClient client(config(server.url(), 15));
  Vector2d now(-50, -50), ahead(45, 45);
  auto near_now = server_tiles(http, 1, now, 15), near_ahead = server_tiles(http, 1, ahead, 15);
  ASSERT_FALSE(near_ahead.empty());
  client.set_focus(now, ahead);  // once: the client must go for the look-ahead tiles on its own
  ASSERT_TRUE(eventually([&] { return by_key(client.tiles_near(ahead, 15)) == near_ahead; })) << client.status().last_error;
  ASSERT_TRUE(eventually([&] { return by_key(client.tiles_near(now, 15)) == near_now; })) << client.status().last_error;
  // Nothing beyond the two discs was fetched.
  auto both = near_now;
  both.insert(near_ahead.begin(), near_ahead.end());
  EXPECT_EQ(client.status().fetched, both.size());
  EXPECT_EQ(by_key(client.tiles_near({0, 0}, 1000)), both);
}

TEST(TileClient, MemoryBoundIsRespectedWithEviction) {
  MapFixture f;
  ServerProcess server(f.db);
  HttpClient http(server.url());
  TileClientConfig cfg = config(server.url(), 5);
  cfg.memory_mb = 0.045;  // about 3 tiles of this map
  const std::size_t budget = static_cast<std::size_t>(cfg.memory_mb * 1024 * 1024);
  TileClient client(cfg);
  std::size_t peak = 0;
  auto check_bound = [&] {
    auto s = client.status();
    peak = std::max(peak, s.bytes_in_memory);
    EXPECT_LE(s.bytes_in_memory, budget);
    std::size_t held = 0;
    for (const auto& t : client.tiles_near({0, 0}, 1000)) held += pl::client::decoded_size(*t.cloud);
    return held;
  };
  // Drive east along the southern row of tiles, looking one tile ahead.
  for (double x = -50; x <= 50; x += 20) {
    Vector2d now(x, -50), ahead(x + 20, -50);
    client.set_focus(now, ahead);
    ASSERT_TRUE(eventually([&] {
      check_bound();
      return client.tiles_near(now, 5).size() == 1;
    })) << "x=" << x << ": " << client.status().last_error;
    ASSERT_TRUE(client.wait_for(now, 5, 30));
    EXPECT_LE(check_bound(), budget);
  }
  auto s = client.status();
  EXPECT_GT(s.evicted, 0u);
  EXPECT_LE(s.tiles_in_memory, 3u);
  EXPECT_GT(peak, budget / 2);  // the bound was what limited memory, not a lack of tiles
  EXPECT_TRUE(client.tiles_near({-50, -50}, 5).empty());  // where the drive started: evicted
  EXPECT_EQ(client.tiles_near({50, -50}, 5).size(), 1u);  // where it is: kept
  EXPECT_EQ(check_bound(), s.bytes_in_memory);
  // Back to the start: fetched again.
  client.set_focus({-50, -50}, {-50, -50});
  ASSERT_TRUE(client.wait_for({-50, -50}, 5, 30));
  EXPECT_EQ(by_key(client.tiles_near({-50, -50}, 5)), server_tiles(http, 1, {-50, -50}, 5));
}

TEST(TileClient, VersionStaysPinnedWhileANewerOneIsPublished) {
  MapFixture f;
  ServerProcess server(f.db);
  HttpClient http(server.url());
  TileClient client(config(server.url(), 25));
  client.set_focus({0, 0}, {0, 0});
  ASSERT_TRUE(client.wait_for({0, 0}, 25, 30)) << client.status().last_error;
  EXPECT_EQ(client.status().version, 1);
  f.add_version(2);  // into the store the server is serving
  ASSERT_TRUE(eventually([&] { return json::parse(http.get("/v1/maps/town").body)["current_version"] == 2; }));
  Vector2d east(50, 10);
  auto v1 = server_tiles(http, 1, east, 25), v2 = server_tiles(http, 2, east, 25);
  ASSERT_TRUE(v2.count({3, 0}) && !v1.count({3, 0}));  // version 2 has a new tile there
  ASSERT_NE(server_tiles(http, 1, {5, 5}, 0), server_tiles(http, 2, {5, 5}, 0));  // and a changed one at 0/0
  // The drive goes on with version 1, also in areas it had not loaded yet.
  client.set_focus(east, east);
  ASSERT_TRUE(client.wait_for(east, 25, 30)) << client.status().last_error;
  EXPECT_EQ(by_key(client.tiles_near(east, 25)), v1);
  EXPECT_EQ(by_key(client.tiles_near({5, 5}, 0)), server_tiles(http, 1, {5, 5}, 0));
  EXPECT_EQ(client.status().version, 1);
  // Until told.
  client.pin_version(2);
  ASSERT_TRUE(eventually([&] { return client.status().version == 2; }));
  ASSERT_TRUE(client.wait_for(east, 25, 30)) << client.status().last_error;
  EXPECT_EQ(by_key(client.tiles_near(east, 25)), v2);
  for (const auto& t : client.tiles_near(east, 25)) expect_same_as_server(http, t);
  // A client starting now gets the current version.
  TileClient fresh(config(server.url(), 25));
  ASSERT_TRUE(fresh.wait_ready(30));
  EXPECT_EQ(fresh.status().version, 2);
}

TEST(TileClient, SendsTheReadTokenWhenTheServerRequiresOne) {
  MapFixture f;
  ServerProcess server(f.db, f.token_args());
  TileClient without(config(server.url(), 20));
  ASSERT_TRUE(eventually([&] { return without.status().failures >= 1; }));
  EXPECT_NE(without.status().last_error.find("TileClientConfig::token"), std::string::npos) << without.status().last_error;
  TileClientConfig cfg = config(server.url(), 20);
  cfg.token = kReadToken;
  TileClient with(cfg);
  with.set_focus({0, 0}, {0, 0});
  ASSERT_TRUE(with.wait_for({0, 0}, 20, 30)) << with.status().last_error;
  EXPECT_FALSE(with.tiles_near({0, 0}, 20).empty());
}

TEST(TileClient, BadConfigurationFailsAtConstruction) {
  auto message = [](TileClientConfig c) -> std::string {
    try {
      TileClient client(std::move(c));
    } catch (const pl::Error& e) {
      return e.what();
    }
    return "";
  };
  TileClientConfig good = config("http://127.0.0.1:1", 20);
  TileClientConfig c = good;
  c.map = "no spaces";
  EXPECT_NE(message(c).find("TileClientConfig: map"), std::string::npos);
  c = good;
  c.server = "ftp://maps.example";
  EXPECT_NE(message(c).find("expected https://"), std::string::npos);
  c = good;
  c.server = "http://maps.example:8080";  // plain HTTP to another machine: only when told
  EXPECT_NE(message(c).find("--insecure-http"), std::string::npos);
  c = good;
  c.memory_mb = 0;
  EXPECT_NE(message(c).find("memory_mb"), std::string::npos);
  c = good;
  c.retry_min_s = 2, c.retry_max_s = 1;
  EXPECT_NE(message(c).find("retry_max_s"), std::string::npos);
  c = good;
  TempDir dir;
  c.cache_path = dir / "missing-folder/cache.sqlite";
  EXPECT_NE(message(c).find("cannot open the tile cache"), std::string::npos);
}

}  // namespace
