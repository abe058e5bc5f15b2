// The places (a version's place descriptors) the tile client fetches for its pinned version, and
// those StoreTiles reads straight from a map store.
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cstdint>
#include <map>
#include <optional>
#include <random>
#include <stdexcept>
#include <string>

#include "pl/client/store_tiles.hpp"
#include "pl/client/tile_client.hpp"
#include "pl/schema/store.hpp"
#include "error_of.hpp"
#include "server_process.hpp"
#include "test_util.hpp"
#include "tile_client_fixture.hpp"

namespace {

using pl::client::TileClient;
using pl::client::TileClientConfig;
using pl::test::ServerProcess;
using pl::test::TempDir;
using pl::test::eventually;
using pl::test::tile_client::config;
using pl::test::tile_client::MapFixture;
using pl::test::tile_client::requests_in_log;

// Opens a version of "town" from the current one, gives it `places` and publishes it (works on a
// store a server is serving). Returns its number.
std::int64_t publish_with_places(const std::string& db, const std::string& places) {
  pl::store::Store s = pl::store::Store::open(db, false);
  const auto v = s.create_version("town", std::nullopt, "with places");
  s.put_places("town", v.number, places);
  s.publish("town", v.number);
  return v.number;
}

// Bytes standing in for places (their format is the map builder's), NULs included.
std::string some_places(std::size_t n, unsigned seed) {
  std::mt19937 rng(seed);
  std::string out(n, '\0');
  for (auto& c : out) c = static_cast<char>(rng() & 0xFF);
  return out;
}

// A listening socket on 127.0.0.1 that never accepts: connections open (the kernel's backlog),
// requests go unanswered.
class SilentServer {
 public:
  SilentServer() {
    fd_ = socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    socklen_t len = sizeof(addr);
    if (bind(fd_, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)) != 0 || listen(fd_, 16) != 0 ||
        getsockname(fd_, reinterpret_cast<sockaddr*>(&addr), &len) != 0)
      throw std::runtime_error("cannot listen on 127.0.0.1");
    url_ = "http://127.0.0.1:" + std::to_string(ntohs(addr.sin_port));
  }
  ~SilentServer() { close(fd_); }
  const std::string& url() const { return url_; }

 private:
  int fd_ = -1;
  std::string url_;
};

TEST(TileClient, PlacesOfThePinnedVersionAreFetchedOnceAndKept) {
  MapFixture f;
  ServerProcess server(f.db);
  TileClient client(config(server.url(), 20));
  // Version 1 was tiled without places: nothing, and that answer is kept too.
  EXPECT_FALSE(client.places(30));
  EXPECT_EQ(client.status().version, 1);
  EXPECT_EQ(client.status().last_error, "");
  const std::string places = some_places(200000, 3);
  ASSERT_EQ(publish_with_places(f.db, places), 2);
  EXPECT_FALSE(client.places(30));  // still pinned to version 1
  client.pin_version(2);
  ASSERT_TRUE(eventually([&] { return client.status().version == 2; }));
  auto got = client.places(30);
  ASSERT_TRUE(got) << client.status().last_error;
  EXPECT_TRUE(*got == places);
  got = client.places(0);  // kept: no waiting, no request
  ASSERT_TRUE(got);
  EXPECT_TRUE(*got == places);
  std::map<std::string, int> asked;
  for (const auto& [remote, target] : requests_in_log(server.output()))
    if (target.find("/places") != std::string::npos) ++asked[target];
  EXPECT_EQ(asked, (std::map<std::string, int>{{"/v1/maps/town/versions/1/places", 1}, {"/v1/maps/town/versions/2/places", 1}}))
      << server.output();
  // Kept in memory: with the server gone they are still there.
  server.kill9();
  got = client.places(1);
  ASSERT_TRUE(got);
  EXPECT_TRUE(*got == places);
  EXPECT_TRUE(pl::test::error_of([&] { client.places(-1); }).find("TileClient::places") != std::string::npos);
}

TEST(TileClient, PlacesAreNothingWhenTheServerDoesNotAnswerInTime) {
  MapFixture f;
  const std::string cache = f.dir / "vehicle-cache.sqlite";
  {
    ServerProcess server(f.db);
    TileClientConfig cfg = config(server.url(), 20);
    cfg.cache_path = cache;
    TileClient client(cfg);
    ASSERT_TRUE(client.wait_ready(30));  // the disk cache now knows version 1
  }
  // Not ready (nothing answers, nothing cached): nothing once the timeout is over.
  SilentServer silent;
  TileClientConfig cfg = config(silent.url(), 20);
  cfg.timeout_s = 0.2;
  {
    TileClient client(cfg);
    EXPECT_FALSE(client.places(0.5));
  }
  // Ready from the disk cache, but the server takes the request and never answers.
  cfg.cache_path = cache;
  TileClient client(cfg);
  ASSERT_TRUE(client.wait_ready(30));
  EXPECT_FALSE(client.places(1.0));
  const std::string why = client.status().last_error;
  EXPECT_NE(why.find("cannot reach pl-server for the places of map town version 1"), std::string::npos) << why;
  EXPECT_NE(why.find("timeout"), std::string::npos) << why;
}

TEST(StoreTiles, PlacesOfTheVersionItReads) {
  TempDir dir;
  const std::string db = dir / "maps.sqlite";
  const std::string places = some_places(5000, 9);
  {
    pl::store::Store s = pl::store::Store::open(db);
    s.create_map("town", pl::GeoPoint{49.0, 8.4, 110.0}, 20.0, 0.2);
    s.create_version("town", std::nullopt, "");
    s.put_places("town", 1, places);
    s.publish("town", 1);
    s.create_version("town", std::nullopt, "");  // starts with a copy
    s.create_version("town", std::nullopt, "");
    s.delete_places("town", 3);
  }
  pl::client::StoreTiles current(db, "town");
  EXPECT_EQ(current.version(), 1);
  EXPECT_EQ(current.places(), places);
  EXPECT_EQ(pl::client::StoreTiles(db, "town", 2).places(), places);
  EXPECT_FALSE(pl::client::StoreTiles(db, "town", 3).places());
}

}  // namespace
