// What the tile client's tests (test_tile_client*.cpp, test_disk_cache.cpp) share: a map "town" that
// pl-map tiles from generated ground, the client's configuration for it, what the server says about
// its tiles, the requests in a pl-server access log, and a cached blob damaged as a disk would.
#pragma once

#include <gtest/gtest.h>
#include <sqlite3.h>

#include <cmath>
#include <map>
#include <nlohmann/json.hpp>
#include <ostream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "pl/client/map_tile.hpp"
#include "pl/client/tile_client.hpp"
#include "pl/common/cloud_io.hpp"
#include "pl/common/tile_codec.hpp"
#include "pl/common/tile_key.hpp"
#include "pl/registration/normals.hpp"
#include "pl/schema/http_client.hpp"
#include "test_util.hpp"

namespace pl {
// Readable keys in gtest's messages.
inline void PrintTo(const TileKey& k, std::ostream* os) { *os << k.tx << "/" << k.ty; }
}  // namespace pl

// Its own namespace: tests/server/map_fixture.hpp, also on this folder's include path, has a
// MapFixture and a kReadToken of its own in pl::test.
namespace pl::test::tile_client {

inline const std::string kReadToken = "read-3c1e";
// The map's voxel: the client estimates a tile's normals within 3 x 0.5 m, some ten lattice points.
constexpr double kVoxel = 0.5;

// 120 m x 120 m of ground on a 1 m lattice around the origin, 20 m tiles (keys -3..2 each way), with a
// curved surface and one pole per tile so that no two tiles look alike, and a "lake" where tile 1/1
// would be: no points, so that key holds no tile. Version 2 adds a wall in tile 0/0 and a new tile
// 3/0 east of the old edge.
inline pl::Points3d ground(int version) {
  pl::Points3d pts;
  for (double x = -60.0; x < 60.0; x += 1.0)
    for (double y = -60.0; y < 60.0; y += 1.0) {
      if (x >= 20 && x < 40 && y >= 20 && y < 40) continue;
      double px = x + 0.5, py = y + 0.5;
      pts.emplace_back(px, py, 0.002 * px * px + 0.3 * std::sin(0.21 * py));
    }
  for (int tx = -3; tx < 3; ++tx)
    for (int ty = -3; ty < 3; ++ty)
      for (double z = 0.2; z < 4.0 && !(tx == 1 && ty == 1); z += 0.4) pts.emplace_back(tx * 20 + 3.1 + 0.7 * ((tx * 7 + ty * 3) & 7), ty * 20 + 5.1 + ((tx + 2 * ty) & 3), z);
  if (version >= 2) {
    for (double x = 2.0; x < 12.0; x += 0.4)
      for (double z = 0.2; z < 3.0; z += 0.4) pts.emplace_back(x + 0.1, 15.1, z);
    for (double x = 60.0; x < 80.0; x += 1.0)
      for (double y = 0.0; y < 20.0; y += 1.0) pts.emplace_back(x + 0.5, y + 0.5, 0.002 * (x + 0.5) * (x + 0.5));
  }
  return pts;
}

struct MapFixture {
  TempDir dir;
  std::string db = dir / "maps.sqlite";

  MapFixture() { add_version(1); }
  // Tiles version N (staged, from the current one) and publishes it; works on a store a server is serving.
  void add_version(int n) {
    pl::Points3d cloud = ground(n);
    std::string pcd = dir / ("ground" + std::to_string(n) + ".pcd");
    pl::write_pcd(pcd, cloud, std::vector<float>(cloud.size(), 0.4f), pl::GeoPoint{49.0, 8.4, 110.0});
    auto r = pl::test::run(pl::test::tool("pl-map") + " tile --cloud " + pcd + " --db " + db + " --map town --voxel " + std::to_string(kVoxel));
    if (r.exit_code != 0) throw std::runtime_error(r.output);
    r = pl::test::run(pl::test::tool("pl-map") + " publish --db " + db + " --map town --version " + std::to_string(n));
    if (r.exit_code != 0) throw std::runtime_error(r.output);
  }
  std::vector<std::string> token_args() {
    pl::test::write_file(dir / "tokens.txt", "read " + kReadToken + "\n");
    return {"--tokens", dir / "tokens.txt", "--read-token-required"};
  }
};

inline pl::client::TileClientConfig config(const std::string& server, double radius_m) {
  pl::client::TileClientConfig c;
  c.server = server;
  c.map = "town";
  c.radius_m = radius_m;
  c.retry_min_s = 0.05;
  c.retry_max_s = 0.5;
  return c;
}

// What the server says: key -> hash of the tiles of a version that touch a disc.
inline std::map<pl::TileKey, std::string> server_tiles(pl::api::HttpClient& http, int version, const Eigen::Vector2d& c, double r) {
  auto res = http.get("/v1/maps/town/roi?x=" + std::to_string(c.x()) + "&y=" + std::to_string(c.y()) + "&radius=" + std::to_string(r) +
                      "&version=" + std::to_string(version));
  if (res.status != 200) throw std::runtime_error(res.body);
  std::map<pl::TileKey, std::string> out;
  nlohmann::json answer = nlohmann::json::parse(res.body);
  for (const auto& t : answer["tiles"]) out[{t["tx"].get<int>(), t["ty"].get<int>()}] = t["hash"].get<std::string>();
  return out;
}

inline std::map<pl::TileKey, std::string> by_key(const std::vector<pl::client::MapTile>& tiles) {
  std::map<pl::TileKey, std::string> out;
  for (const auto& t : tiles) out[t.key] = t.hash;
  return out;
}

// The tile the client holds equals the server's bytes decoded, point for point.
// The tile as the server's bytes decode, with the normals the client estimates from its points (the
// tiles store none) within 3 x the map's voxel.
inline void expect_same_as_server(pl::api::HttpClient& http, const pl::client::MapTile& t) {
  auto res = http.get("/v1/blobs/" + t.hash);
  ASSERT_EQ(res.status, 200) << res.body;
  pl::TileCloud ref = pl::decode_tile(res.body);
  ASSERT_TRUE(t.cloud);
  EXPECT_EQ(t.bytes, res.body.size());
  EXPECT_EQ(t.cloud->points, ref.points);
  EXPECT_TRUE(ref.normals.empty());
  EXPECT_EQ(t.cloud->normals, pl::registration::estimate_normals(ref.points, 3 * kVoxel));
  EXPECT_EQ(t.cloud->intensity, ref.intensity);
}

// The requests in a pl-server access log ("TIME REMOTE [REQUEST-ID] \"GET TARGET\" STATUS ..."):
// (remote, target). The remote is the second field, whether or not the server logs request ids.
inline std::vector<std::pair<std::string, std::string>> requests_in_log(const std::string& log) {
  std::vector<std::pair<std::string, std::string>> out;
  std::istringstream in(log);
  std::string line;
  while (std::getline(in, line)) {
    auto q = line.find(" \"GET ");
    if (q == std::string::npos) continue;
    std::istringstream fields(line);
    std::string time, remote;
    fields >> time >> remote;
    auto end = line.find('"', q + 6);
    out.emplace_back(remote, line.substr(q + 6, end - q - 6));
  }
  return out;
}

// Flips one byte in the middle of a cached blob, as a failing disk would.
inline void damage_blob(const std::string& cache_path, const std::string& hash) {
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(cache_path.c_str(), &db), SQLITE_OK);
  sqlite3_stmt* st = nullptr;
  ASSERT_EQ(sqlite3_prepare_v2(db, "SELECT bytes FROM blobs WHERE hash = ?1", -1, &st, nullptr), SQLITE_OK);
  sqlite3_bind_text(st, 1, hash.c_str(), -1, SQLITE_TRANSIENT);
  ASSERT_EQ(sqlite3_step(st), SQLITE_ROW);
  std::string bytes(static_cast<const char*>(sqlite3_column_blob(st, 0)), static_cast<std::size_t>(sqlite3_column_bytes(st, 0)));
  sqlite3_finalize(st);
  bytes[bytes.size() / 2] = static_cast<char>(bytes[bytes.size() / 2] ^ 0x5a);
  ASSERT_EQ(sqlite3_prepare_v2(db, "UPDATE blobs SET bytes = ?1 WHERE hash = ?2", -1, &st, nullptr), SQLITE_OK);
  sqlite3_bind_blob(st, 1, bytes.data(), static_cast<int>(bytes.size()), SQLITE_TRANSIENT);
  sqlite3_bind_text(st, 2, hash.c_str(), -1, SQLITE_TRANSIENT);
  ASSERT_EQ(sqlite3_step(st), SQLITE_DONE);
  sqlite3_finalize(st);
  EXPECT_EQ(sqlite3_changes(db), 1);
  sqlite3_close(db);
}

}  // namespace pl::test::tile_client
