// The tile client when things go wrong: offline from its disk cache after a restart, a server that
// comes back, a damaged cache entry, server errors, and a server that never answers. A real
// pl-server on 127.0.0.1 serves a real map store; waits poll with deadlines.
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <map>
#include <memory>
#include <string>
#include <vector>

#include "pl/client/tile_cache.hpp"
#include "pl/client/tile_client.hpp"
#include "pl/common/tile_key.hpp"
#include "pl/schema/http_client.hpp"
#include "server_process.hpp"
#include "test_util.hpp"
#include "tile_client_fixture.hpp"

namespace {

using pl::api::HttpClient;
using pl::client::TileCache;
using pl::client::TileClient;
using pl::client::TileClientConfig;
using pl::test::ServerProcess;
using pl::test::eventually;
using Eigen::Vector2d;
using pl::test::tile_client::by_key;
using pl::test::tile_client::config;
using pl::test::tile_client::damage_blob;
using pl::test::tile_client::expect_same_as_server;
using pl::test::tile_client::MapFixture;
using pl::test::tile_client::server_tiles;

TEST(TileClient, DiskCacheServesTilesOfflineAfterARestart) {
  MapFixture f;
  ServerProcess server(f.db);
  std::string url = server.url(), cache = f.dir / "vehicle-cache.sqlite";
  Vector2d p(-22, 13);
  std::map<pl::TileKey, std::string> first;
  std::map<pl::TileKey, std::size_t> points;
  {
    TileClientConfig cfg = config(url, 30);
    cfg.cache_path = cache;
    TileClient client(cfg);
    client.set_focus(p, p);
    ASSERT_TRUE(client.wait_for(p, 30, 30)) << client.status().last_error;
    for (const auto& t : client.tiles_near(p, 30)) first[t.key] = t.hash, points[t.key] = t.cloud->size();
    EXPECT_EQ(client.status().fetched, first.size());
  }
  server.kill9();
  TileClientConfig cfg = config(url, 30);
  cfg.cache_path = cache;
  TileClient client(cfg);  // no version given: the one last used, from the cache
  ASSERT_TRUE(client.wait_ready(30));
  EXPECT_EQ(client.status().version, 1);
  EXPECT_DOUBLE_EQ(client.status().tile_size, 20.0);
  client.set_focus(p, p);
  ASSERT_TRUE(client.wait_for(p, 30, 30)) << client.status().last_error;
  auto got = client.tiles_near(p, 30);
  EXPECT_EQ(by_key(got), first);
  for (const auto& t : got) EXPECT_EQ(t.cloud->size(), points[t.key]);
  ASSERT_TRUE(eventually([&] { return client.status().failures > 0; }));
  auto s = client.status();
  EXPECT_FALSE(s.online);
  EXPECT_EQ(s.fetched, 0u);
  EXPECT_EQ(s.from_disk, first.size());
  EXPECT_NE(s.last_error.find("cannot reach pl-server"), std::string::npos) << s.last_error;
  // Where the cache knows nothing, nothing is made up.
  EXPECT_FALSE(client.wait_for({50, -50}, 5, 0.2));
  EXPECT_TRUE(client.tiles_near({50, -50}, 5).empty());
}

TEST(TileClient, ReconnectsWhenTheServerComesBackOnTheSamePort) {
  MapFixture f;
  auto server = std::make_unique<ServerProcess>(f.db);
  std::string url = server->url();
  int port = server->port();
  HttpClient http(url);
  TileClient client(config(url, 20));
  Vector2d a(-45, -45), b(45, -5);
  client.set_focus(a, a);
  ASSERT_TRUE(client.wait_for(a, 20, 30)) << client.status().last_error;
  auto loaded_a = server_tiles(http, 1, a, 20);
  ASSERT_EQ(by_key(client.tiles_near(a, 20)), loaded_a);
  server->kill9();
  client.set_focus(b, b);  // a new area while the server is down
  ASSERT_TRUE(eventually([&] { return client.status().failures >= 2; }));
  EXPECT_FALSE(client.status().online);
  EXPECT_EQ(by_key(client.tiles_near(a, 20)), loaded_a);  // still serving what it has
  server = std::make_unique<ServerProcess>(f.db, std::vector<std::string>{"--listen", "127.0.0.1:" + std::to_string(port)});
  ASSERT_EQ(server->port(), port);
  ASSERT_TRUE(client.wait_for(b, 20, 30)) << client.status().last_error;
  HttpClient again(url);
  EXPECT_EQ(by_key(client.tiles_near(b, 20)), server_tiles(again, 1, b, 20));
  auto s = client.status();
  EXPECT_TRUE(s.online);
  EXPECT_GT(s.retries, 0u);
  EXPECT_EQ(s.last_error, "");
}

TEST(TileClient, DamagedCacheEntryIsDroppedAndFetchedAgain) {
  MapFixture f;
  auto server = std::make_unique<ServerProcess>(f.db);
  std::string url = server->url(), cache = f.dir / "vehicle-cache.sqlite";
  int port = server->port();
  Vector2d p(10, -30);
  TileClientConfig cfg = config(url, 20);
  cfg.cache_path = cache;
  std::map<pl::TileKey, std::string> all;
  {
    TileClient client(cfg);
    client.set_focus(p, p);
    ASSERT_TRUE(client.wait_for(p, 20, 30)) << client.status().last_error;
    all = by_key(client.tiles_near(p, 20));
  }
  ASSERT_GT(all.size(), 2u);
  const pl::TileKey bad = pl::TileGrid(20.0).key_of(p.x(), p.y());
  const std::string bad_hash = all.at(bad);
  damage_blob(cache, bad_hash);
  server->kill9();
  // Offline: every other tile comes from the cache; the damaged one is dropped, never decoded.
  TileClient client(cfg);
  client.set_focus(p, p);
  auto others = all;
  others.erase(bad);
  ASSERT_TRUE(eventually([&] { return by_key(client.tiles_near(p, 20)) == others && client.status().corrupt == 1; }))
      << client.status().last_error;
  EXPECT_FALSE(TileCache(cache).has_blob(bad_hash));
  EXPECT_FALSE(client.wait_for(p, 20, 0.2));
  // The server is back: the tile is fetched again, checked, cached and kept.
  server = std::make_unique<ServerProcess>(f.db, std::vector<std::string>{"--listen", "127.0.0.1:" + std::to_string(port)});
  ASSERT_TRUE(client.wait_for(p, 20, 30)) << client.status().last_error;
  EXPECT_EQ(by_key(client.tiles_near(p, 20)), all);
  HttpClient http(url);
  for (const auto& t : client.tiles_near(p, 20))
    if (t.key == bad) expect_same_as_server(http, t);
  auto s = client.status();
  EXPECT_EQ(s.fetched, 1u);
  EXPECT_EQ(s.from_disk, all.size() - 1);
  EXPECT_EQ(s.corrupt, 1u);
  EXPECT_TRUE(TileCache(cache).has_blob(bad_hash));
}

TEST(TileClient, ServerErrorsGiveAClearStatus) {
  MapFixture f;
  ServerProcess server(f.db);
  // An unknown map: not ready, and the status says what to check.
  TileClientConfig cfg = config(server.url(), 20);
  cfg.map = "nowhere";
  TileClient unknown(cfg);
  ASSERT_TRUE(eventually([&] { return unknown.status().failures >= 2; }));
  auto s = unknown.status();
  EXPECT_FALSE(s.ready);
  EXPECT_FALSE(s.online);
  EXPECT_NE(s.last_error.find("HTTP 404"), std::string::npos) << s.last_error;
  EXPECT_NE(s.last_error.find("no map named"), std::string::npos) << s.last_error;
  EXPECT_NE(s.last_error.find("the server has map town"), std::string::npos) << s.last_error;  // the names it has, for a typo
  EXPECT_GT(s.retries, 0u);
  // A version the server does not have.
  cfg = config(server.url(), 20);
  cfg.version = 9;
  TileClient missing(cfg);
  missing.set_focus({0, 0}, {0, 0});
  ASSERT_TRUE(eventually([&] { return missing.status().failures >= 1; }));
  s = missing.status();
  EXPECT_NE(s.last_error.find("no version 9"), std::string::npos) << s.last_error;
  EXPECT_TRUE(missing.tiles_near({0, 0}, 20).empty());
  // Nothing listening at all.
  cfg = config("http://127.0.0.1:1", 20);
  TileClient nobody(cfg);
  ASSERT_TRUE(eventually([&] { return nobody.status().failures >= 1; }));
  EXPECT_NE(nobody.status().last_error.find("cannot reach pl-server"), std::string::npos) << nobody.status().last_error;
  EXPECT_FALSE(nobody.wait_ready(0.1));
}

// HttpClient's timeout applies to a server that accepts and then stays silent (connect, write and
// read run as asynchronous operations so Beast's stream timer fires).
TEST(TileClient, ServerThatNeverAnswersTimesOutAndIsRetried) {
  // A listening socket that never accepts: connections open (the kernel's backlog), requests go
  // unanswered.
  int fd = socket(AF_INET, SOCK_STREAM, 0);
  ASSERT_GE(fd, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  ASSERT_EQ(bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)), 0);
  ASSERT_EQ(listen(fd, 16), 0);
  socklen_t len = sizeof(addr);
  ASSERT_EQ(getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len), 0);
  TileClientConfig cfg = config("http://127.0.0.1:" + std::to_string(ntohs(addr.sin_port)), 20);
  cfg.timeout_s = 0.2;
  {
    TileClient client(cfg);
    client.set_focus({0, 0}, {0, 0});
    ASSERT_TRUE(eventually([&] { return client.status().failures >= 2; }));
    auto s = client.status();
    EXPECT_FALSE(s.ready);
    EXPECT_FALSE(s.online);
    EXPECT_GE(s.retries, 1u);
    EXPECT_NE(s.last_error.find("cannot reach pl-server for the manifest of map town"), std::string::npos) << s.last_error;
    EXPECT_NE(s.last_error.find("timeout"), std::string::npos) << s.last_error;
    EXPECT_TRUE(client.tiles_near({0, 0}, 20).empty());
  }
  close(fd);
}

}  // namespace
