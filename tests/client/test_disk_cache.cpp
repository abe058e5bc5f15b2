// The tile client's disk cache (TileCache) on its own: blobs, manifests and rows kept across
// reopening, and damaged or crafted cache files refused. The SQLite toolkit it shares with the map
// store has its own executable (test_tile_cache.cpp).
#include <gtest/gtest.h>
#include <sqlite3.h>

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <functional>
#include <string>
#include <vector>

#include "pl/client/tile_cache.hpp"
#include "pl/common/error.hpp"
#include "pl/schema/store.hpp"
#include "error_of.hpp"
#include "raw_sql.hpp"
#include "test_util.hpp"
#include "tile_client_fixture.hpp"

namespace {

using pl::client::TileCache;
using pl::test::TempDir;
using pl::test::raw_sql;
using pl::test::tile_client::damage_blob;
using pl::test::tile_client::MapFixture;

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

}  // namespace
