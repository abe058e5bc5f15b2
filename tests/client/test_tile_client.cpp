// The localizer's tile client against real parts: pl-map writes a real SQLite map store, a real
// pl-server serves it on 127.0.0.1, and the client keeps a real SQLite disk cache. Waits poll with
// deadlines; nothing asserts on timing.
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sqlite3.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <nlohmann/json.hpp>
#include <random>
#include <set>
#include <sstream>
#include <thread>

#include "pl/schema/http_client.hpp"
#include "pl/client/store_tiles.hpp"
#include "pl/client/tile_cache.hpp"
#include "pl/client/tile_client.hpp"
#include "pl/common/cloud_io.hpp"
#include "pl/common/error.hpp"
#include "pl/common/tile_codec.hpp"
#include "pl/common/tile_key.hpp"
#include "pl/schema/store.hpp"
#include "server_process.hpp"
#include "raw_sql.hpp"
#include "error_of.hpp"
#include "test_util.hpp"

using nlohmann::json;
using pl::api::HttpClient;
using pl::client::MapTile;
using pl::client::TileCache;
using pl::client::TileClient;
using pl::client::TileClientConfig;
using pl::test::ServerProcess;
using pl::test::TempDir;
using pl::test::eventually;
using Eigen::Vector2d;

namespace pl {
// Readable keys in gtest's messages.
inline void PrintTo(const TileKey& k, std::ostream* os) { *os << k.tx << "/" << k.ty; }
}  // namespace pl

namespace {

const std::string kReadToken = "read-3c1e";

// 120 m x 120 m of ground on a 1 m lattice around the origin, 20 m tiles (keys -3..2 each way), with a
// curved surface and one pole per tile so that no two tiles look alike, and a "lake" where tile 1/1
// would be: no points, so that key holds no tile. Version 2 adds a wall in tile 0/0 and a new tile
// 3/0 east of the old edge.
pl::Points3d ground(int version) {
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
    auto r = pl::test::run(pl::test::tool("pl-map") + " tile --cloud " + pcd + " --db " + db + " --map town --normal-radius 2.5");
    if (r.exit_code != 0) throw std::runtime_error(r.output);
    r = pl::test::run(pl::test::tool("pl-map") + " publish --db " + db + " --map town --version " + std::to_string(n));
    if (r.exit_code != 0) throw std::runtime_error(r.output);
  }
  std::vector<std::string> token_args() {
    pl::test::write_file(dir / "tokens.txt", "read " + kReadToken + "\n");
    return {"--tokens", dir / "tokens.txt", "--read-token-required"};
  }
};

TileClientConfig config(const std::string& server, double radius_m) {
  TileClientConfig c;
  c.server = server;
  c.map = "town";
  c.radius_m = radius_m;
  c.retry_min_s = 0.05;
  c.retry_max_s = 0.5;
  return c;
}

// What the server says: key -> hash of the tiles of a version that touch a disc.
std::map<pl::TileKey, std::string> server_tiles(HttpClient& http, int version, const Vector2d& c, double r) {
  auto res = http.get("/v1/maps/town/roi?x=" + std::to_string(c.x()) + "&y=" + std::to_string(c.y()) + "&radius=" + std::to_string(r) +
                      "&version=" + std::to_string(version));
  if (res.status != 200) throw std::runtime_error(res.body);
  std::map<pl::TileKey, std::string> out;
  json answer = json::parse(res.body);
  for (const auto& t : answer["tiles"]) out[{t["tx"].get<int>(), t["ty"].get<int>()}] = t["hash"].get<std::string>();
  return out;
}

std::map<pl::TileKey, std::string> by_key(const std::vector<MapTile>& tiles) {
  std::map<pl::TileKey, std::string> out;
  for (const auto& t : tiles) out[t.key] = t.hash;
  return out;
}

// The tile the client holds equals the server's bytes decoded, point for point.
void expect_same_as_server(HttpClient& http, const MapTile& t) {
  auto res = http.get("/v1/blobs/" + t.hash);
  ASSERT_EQ(res.status, 200) << res.body;
  pl::TileCloud ref = pl::decode_tile(res.body);
  ASSERT_TRUE(t.cloud);
  EXPECT_EQ(t.bytes, res.body.size());
  EXPECT_EQ(t.cloud->points, ref.points);
  EXPECT_EQ(t.cloud->normals, ref.normals);
  EXPECT_EQ(t.cloud->intensity, ref.intensity);
}

// The requests in a pl-server access log ("TIME REMOTE [REQUEST-ID] \"GET TARGET\" STATUS ..."):
// (remote, target). The remote is the second field, whether or not the server logs request ids.
std::vector<std::pair<std::string, std::string>> requests_in_log(const std::string& log) {
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

// Flips one byte in the middle of a cached blob, as a failing disk would.
void damage_blob(const std::string& cache_path, const std::string& hash) {
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

}  // namespace

// ---------------------------------------------------------------------------------------------
// The disk cache on its own

TEST(TileCache, KeepsBlobsManifestsAndRowsAcrossReopening) {
  TempDir dir;
  std::string path = dir / "cache.sqlite";
  std::string bytes = "not really draco, but bytes all the same";
  std::string hash = pl::store::content_hash(bytes);
  {
    TileCache cache(path);
    EXPECT_FALSE(cache.blob(hash).has_value());
    cache.put_blob(hash, bytes);
    cache.put_blob(hash, bytes);  // idempotent
    EXPECT_EQ(cache.blob_count(), 1u);
    cache.put_manifest({"town", 1, 20.0, 0.2, pl::GeoPoint{49.0, 8.4, 110.0}});
    cache.put_manifest({"town", 2, 20.0, 0.2, pl::GeoPoint{49.0, 8.4, 110.0}});
    cache.put_manifest({"depot", 7, 25.0, 0.2, pl::GeoPoint{}});
    cache.put_tiles("town", 1, {{{0, 0}, hash, 12}, {{-1, 3}, "", 0}});
    cache.put_tiles("town", 1, {{{0, 0}, hash, 13}});  // replaces the key's row
  }
  TileCache cache(path);
  EXPECT_EQ(cache.blob(hash), bytes);
  auto last = cache.last_used("town");
  ASSERT_TRUE(last);
  EXPECT_EQ(last->version, 2);
  cache.put_manifest(*cache.manifest("town", 1));  // using version 1 again
  EXPECT_EQ(cache.last_used("town")->version, 1);
  EXPECT_DOUBLE_EQ(cache.manifest("depot", 7)->tile_size, 25.0);
  EXPECT_DOUBLE_EQ(cache.manifest("town", 1)->origin.lat_deg, 49.0);
  EXPECT_FALSE(cache.manifest("town", 3));
  EXPECT_FALSE(cache.last_used("nowhere"));
  auto rows = cache.tiles("town", 1);
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_EQ(rows[0].key, (pl::TileKey{-1, 3}));
  EXPECT_FALSE(rows[0].exists());
  EXPECT_EQ(rows[1].key, (pl::TileKey{0, 0}));
  EXPECT_EQ(rows[1].hash, hash);
  EXPECT_EQ(rows[1].points, 13);
  EXPECT_TRUE(cache.tiles("town", 2).empty());
}

TEST(TileCache, DamagedBlobIsDroppedNotReturned) {
  TempDir dir;
  std::string path = dir / "cache.sqlite";
  std::string bytes(4000, 'x');
  std::string hash = pl::store::content_hash(bytes);
  {
    TileCache cache(path);
    cache.put_blob(hash, bytes);
  }
  damage_blob(path, hash);
  TileCache cache(path);
  bool corrupt = false;
  EXPECT_FALSE(cache.blob(hash, &corrupt).has_value());
  EXPECT_TRUE(corrupt);
  EXPECT_FALSE(cache.has_blob(hash));
  EXPECT_FALSE(cache.blob(hash, &corrupt).has_value());
  EXPECT_FALSE(corrupt);  // gone, not damaged again
}

TEST(TileCache, RefusesFilesThatAreNotATileCache) {
  TempDir dir;
  pl::test::write_file(dir / "notes.txt", std::string(5000, 'n'));
  try {
    TileCache cache(dir / "notes.txt");
    FAIL() << "opened a text file";
  } catch (const pl::Error& e) {
    EXPECT_NE(std::string(e.what()).find("not a tile cache"), std::string::npos) << e.what();
  }
  MapFixture f;  // a map store is an SQLite file, but not a tile cache
  try {
    TileCache cache(f.db);
    FAIL() << "opened a map store";
  } catch (const pl::Error& e) {
    EXPECT_NE(std::string(e.what()).find("not a tile cache"), std::string::npos) << e.what();
  }
  EXPECT_THROW(TileCache(dir / "no/such/folder/cache.sqlite"), pl::Error);
}

// ---- a damaged or crafted cache file (the classes tests/fuzz/fuzz_tile_cache.cpp covers) ----------

namespace {

const char* kCacheDamaged = "the tile cache is damaged";

// A cache with 40 blobs of 2 KB, two manifests and a version's rows.
void make_sample_cache(const std::string& path) {
  TileCache cache(path);
  std::vector<pl::client::CachedTile> rows;
  for (int i = 0; i < 40; ++i) {
    std::string bytes(2000, static_cast<char>('a' + i % 26));
    bytes += std::to_string(i);
    cache.put_blob(pl::store::content_hash(bytes), bytes);
    rows.push_back({{i % 8, i / 8}, pl::store::content_hash(bytes), i});
  }
  cache.put_manifest({"town", 1, 20.0, 0.2, pl::GeoPoint{49.0, 8.4, 110.0}});
  cache.put_manifest({"town", 2, 20.0, 0.2, pl::GeoPoint{49.0, 8.4, 110.0}});
  cache.put_tiles("town", 1, rows);
}

// What the tile client reads from its cache; throws what the cache throws.
void read_like_the_client(const std::string& path) {
  TileCache cache(path);
  cache.last_used("town");
  cache.manifest("town", 1);
  for (const auto& t : cache.tiles("town", 1))
    if (t.exists()) cache.blob(t.hash);
  cache.blob_count();
}


void expect_cache_damaged(const std::string& msg, const std::string& path, const std::string& detail) {
  EXPECT_NE(msg.find(path), std::string::npos) << msg;
  EXPECT_NE(msg.find(kCacheDamaged), std::string::npos) << msg;
  EXPECT_NE(msg.find("delete it (it is only a cache"), std::string::npos) << msg;
  EXPECT_NE(msg.find(detail), std::string::npos) << msg;
}

using pl::test::raw_sql;

}  // namespace

TEST(TileCache, TruncatedFileIsRefusedAsDamagedAndLeftAsItWas) {
  TempDir dir;
  std::string path = dir / "cache.sqlite";
  make_sample_cache(path);
  const std::string whole = pl::test::read_file(path);
  std::filesystem::resize_file(path, whole.size() / 2);
  const std::string cut = pl::test::read_file(path);
  expect_cache_damaged(pl::test::error_of([&] { read_like_the_client(path); }), path, "malformed");
  EXPECT_EQ(pl::test::read_file(path), cut);  // not written, not "repaired"
}

TEST(TileCache, HeaderThatOnlyLetsSqliteReadIsRefusedAsDamaged) {
  TempDir dir;
  std::string path = dir / "cache.sqlite";
  make_sample_cache(path);
  {
    std::fstream f(path, std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(18);
    f << '\x42';  // the file format write version: SQLite writes 1 (legacy) or 2 (WAL)
  }
  const std::string damaged = pl::test::read_file(path);
  expect_cache_damaged(pl::test::error_of([&] { TileCache cache(path); }), path, "may only read it");
  EXPECT_EQ(pl::test::read_file(path), damaged);
}

TEST(TileCache, CacheToSwitchToWalIsCheckedWholeFirst) {
  TempDir dir;
  std::string path = dir / "cache.sqlite";
  make_sample_cache(path);
  raw_sql(path, "PRAGMA journal_mode = DELETE");
  std::int64_t offset = 0;
  {
    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
    sqlite3_stmt* st = nullptr;
    ASSERT_EQ(sqlite3_prepare_v2(db, "SELECT (rootpage - 1) * (SELECT page_size FROM pragma_page_size) FROM sqlite_schema "
                                     "WHERE name = 'manifests'", -1, &st, nullptr), SQLITE_OK);
    ASSERT_EQ(sqlite3_step(st), SQLITE_ROW);
    offset = sqlite3_column_int64(st, 0);
    sqlite3_finalize(st);
    sqlite3_close(db);
  }
  {
    std::fstream f(path, std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(offset);
    f << std::string(8, '\xee');  // the manifests' page is no b-tree page any more
  }
  const std::string damaged = pl::test::read_file(path);
  expect_cache_damaged(pl::test::error_of([&] { TileCache cache(path); }), path, "quick_check");
  EXPECT_EQ(pl::test::read_file(path), damaged);  // not switched to WAL
}

TEST(TileCache, CraftedSchemaIsRefusedBeforeAnyOfItRuns) {
  TempDir dir;
  std::string path = dir / "cache.sqlite";
  for (const char* sql : {"CREATE TRIGGER wipe AFTER INSERT ON blobs BEGIN DELETE FROM manifests; END",
                          "CREATE INDEX tiles_hash ON tiles (hash)",
                          "DROP TABLE manifests; CREATE VIEW manifests AS WITH RECURSIVE c(x) AS (SELECT 1 UNION ALL "
                          "SELECT x + 1 FROM c) SELECT 'town', x, 20.0, 0.2, 0, 0, 0, x FROM c"}) {
    std::filesystem::remove(path);
    make_sample_cache(path);
    raw_sql(path, sql);
    const std::string crafted = pl::test::read_file(path);
    expect_cache_damaged(pl::test::error_of([&] { TileCache cache(path); }), path, "its tables are not the ones this software makes");
    EXPECT_EQ(pl::test::read_file(path), crafted) << sql;
  }
}

TEST(TileCache, ValuesOfTheWrongKindAreRefused) {
  struct Case {
    const char* sql;
    std::function<void(TileCache&)> read;
    const char* detail;
  };
  auto rows = [](TileCache& c) { c.tiles("town", 1); };
  const Case cases[] = {
      {"UPDATE tiles SET hash = 'zz' WHERE tx = 0 AND ty = 0", rows, "tiles.hash is not a SHA-256 hash"},
      {"UPDATE tiles SET tx = 1099511627776 WHERE tx = 0 AND ty = 0", rows, "tiles.tx is out of range"},
      {"UPDATE tiles SET points = 'many'", rows, "tiles.points is not an integer"},
      {"UPDATE manifests SET tile_size = 'twenty'", [](TileCache& c) { c.manifest("town", 1); }, "manifests.tile_size is not a number"},
      {"UPDATE manifests SET tile_size = -20", [](TileCache& c) { c.manifest("town", 1); }, "manifests.tile_size"},
      {"UPDATE manifests SET origin_alt = 9e999", [](TileCache& c) { c.last_used("town"); }, "manifests.origin_alt is not finite"},
      // Text sorts after every number: without the check this row would be "last used" for ever.
      {"UPDATE manifests SET used = 'always' WHERE version = 1", [](TileCache& c) { c.last_used("town"); },
       "manifests.used is not an integer"},
  };
  TempDir dir;
  std::string path = dir / "cache.sqlite";
  for (const Case& c : cases) {
    std::filesystem::remove(path);
    make_sample_cache(path);
    raw_sql(path, c.sql);
    TileCache cache(path);
    expect_cache_damaged(pl::test::error_of([&] { c.read(cache); }), path, c.detail);
  }
}

TEST(TileCache, WritesRefuseWhatReadsWouldRefuse) {
  TempDir dir;
  TileCache cache(dir / "cache.sqlite");
  const std::string hash = pl::store::content_hash("bytes");
  EXPECT_THROW(cache.put_blob("not-a-hash", "bytes"), pl::Error);
  EXPECT_THROW(cache.put_blob(std::string(64, 'A'), "bytes"), pl::Error);  // upper case is not how hashes are written
  EXPECT_THROW(cache.put_tiles("town", 1, {{{0, 0}, "../../etc", 1}}), pl::Error);
  EXPECT_THROW(cache.put_manifest({"town", 1, 0.0, 0.2, pl::GeoPoint{}}), pl::Error);
  EXPECT_THROW(cache.put_manifest({"town", 1, 20.0, -0.2, pl::GeoPoint{}}), pl::Error);
  EXPECT_THROW(cache.put_manifest({"town", 1, 20.0, 0.2, pl::GeoPoint{std::nan(""), 0, 0}}), pl::Error);
  cache.put_blob(hash, "bytes");
  cache.put_blob(pl::store::content_hash(""), "");  // an empty blob is a blob
  EXPECT_EQ(cache.blob(pl::store::content_hash("")), std::string());
  cache.put_tiles("town", 1, {{{0, 0}, hash, 1}, {{0, 1}, "", 0}});
  cache.put_manifest({"town", 1, 20.0, 0.0, pl::GeoPoint{}});  // a server that gave no voxel size
  EXPECT_EQ(cache.tiles("town", 1).size(), 2u);
  EXPECT_EQ(cache.blob_count(), 2u);
  EXPECT_DOUBLE_EQ(cache.last_used("town")->voxel_size, 0.0);
}

// ---------------------------------------------------------------------------------------------
// The client against a real server

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
  std::size_t bytes = 0;
  for (const auto& t : got) {
    expect_same_as_server(http, t);
    EXPECT_GT(t.cloud->size(), 300u);
    bytes += pl::client::decoded_size(*t.cloud);
  }
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
  cfg.memory_mb = 0.06;  // about 3 tiles of this map
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
