// The disk cache through the SQLite toolkit it shares with the map store
// (pl/schema/detail/sqlite.hpp): on real SQLite files, the cache and the store each give their own
// name and fix in the same checks, and the cache now takes what the store takes (ANALYZE's tables).
// The cache's own behaviour is tested in test_disk_cache.cpp.
#include <gtest/gtest.h>
#include <sqlite3.h>

#include <filesystem>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "pl/client/tile_cache.hpp"
#include "pl/common/error.hpp"
#include "pl/schema/store.hpp"
#include "raw_sql.hpp"
#include "error_of.hpp"
#include "test_util.hpp"

using pl::client::TileCache;
using pl::test::TempDir;

namespace {

using pl::test::error_of;

bool has(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

using pl::test::raw_sql;

// A cache with 40 blobs of 2 KB, a manifest and a version's rows (40 tiles and one key without a
// tile); returns the hash of the first blob.
std::string make_cache(const std::string& path) {
  TileCache cache(path);
  std::vector<pl::client::CachedTile> rows = {{{-1, -1}, "", 0}};
  for (int i = 0; i < 40; ++i) {
    std::string bytes(2000, static_cast<char>('a' + i % 26));
    bytes += std::to_string(i);
    cache.put_blob(pl::store::content_hash(bytes), bytes);
    rows.push_back({{i % 8, i / 8}, pl::store::content_hash(bytes), i});
  }
  cache.put_manifest({"town", 1, 20.0, 0.2, pl::GeoPoint{49.0, 8.4, 110.0}});
  cache.put_tiles("town", 1, rows);
  return rows[1].hash;
}

}  // namespace

TEST(TileCacheToolkit, CacheAfterAnalyzeStillOpensAndReads) {
  // ANALYZE adds sqlite_stat1 (and, with some builds, sqlite_stat4); they only steer query plans,
  // so the exact-schema check lets them pass for the cache as for the map store.
  TempDir dir;
  const std::string path = dir / "cache.sqlite";
  const std::string hash = make_cache(path);
  raw_sql(path, "ANALYZE");
  TileCache cache(path);
  EXPECT_EQ(cache.blob_count(), 40u);
  EXPECT_EQ(cache.tiles("town", 1).size(), 41u);
  EXPECT_TRUE(cache.blob(hash).has_value());
  ASSERT_TRUE(cache.last_used("town"));
  EXPECT_EQ(cache.last_used("town")->version, 1);
}

TEST(TileCacheToolkit, CraftedSchemaNamesWhatDiffers) {
  TempDir dir;
  const std::string path = dir / "cache.sqlite";
  const std::pair<const char*, const char*> cases[] = {
      {"CREATE TRIGGER wipe AFTER INSERT ON blobs BEGIN DELETE FROM manifests; END", "it has an unknown trigger wipe"},
      {"DROP TABLE tiles", "table tiles is missing"},
      // The same table without NOT NULL on bytes.
      {"DROP TABLE blobs; CREATE TABLE blobs (hash TEXT PRIMARY KEY NOT NULL, bytes BLOB)",
       "table blobs is not defined as this software defines it"},
  };
  for (const auto& [sql, detail] : cases) {
    std::filesystem::remove(path);
    make_cache(path);
    raw_sql(path, sql);
    const std::string crafted = pl::test::read_file(path);
    const std::string msg = error_of([&] { TileCache cache(path); });
    EXPECT_TRUE(has(msg, path + ": the tile cache is damaged (its tables are not the ones this software makes: ")) << msg;
    EXPECT_TRUE(has(msg, detail)) << msg;
    EXPECT_TRUE(has(msg, "delete it (it is only a cache")) << msg;
    EXPECT_EQ(pl::test::read_file(path), crafted) << sql;
  }
}

TEST(TileCacheToolkit, CacheAndStoreNameTheirOwnFileAndFix) {
  // The same damage (half of the file gone) through the same checks: each message names its own
  // kind of file and what to do about it, never the other's.
  TempDir dir;
  const std::string cache_path = dir / "cache.sqlite";
  const std::string store_path = dir / "maps.sqlite";
  make_cache(cache_path);
  {
    pl::store::Store s = pl::store::Store::open(store_path);
    s.create_map("town", pl::GeoPoint{49.0, 8.4, 110.0}, 20, 0.2);
    s.create_version("town", std::nullopt, "");
    for (int i = 0; i < 30; ++i) {
      std::string bytes(2000, static_cast<char>('a' + i % 26));
      bytes += std::to_string(i);
      s.put_tile("town", 1, {i % 6, i / 6}, bytes, 10, 0, 0, 0, 1, 1, 1);
    }
  }
  for (const std::string& path : {cache_path, store_path}) {
    raw_sql(path, "PRAGMA wal_checkpoint(TRUNCATE)");
    std::filesystem::resize_file(path, std::filesystem::file_size(path) / 2);
  }
  const std::string cache_msg = error_of([&] {
    TileCache cache(cache_path);
    for (const auto& t : cache.tiles("town", 1))
      if (t.exists()) cache.blob(t.hash);
    cache.blob_count();
  });
  const std::string store_msg = error_of([&] {
    pl::store::Store s = pl::store::Store::open(store_path, false);
    for (const auto& t : s.list_tiles("town", 1)) s.blob(t.hash);
  });
  EXPECT_TRUE(has(cache_msg, cache_path + ": the tile cache is damaged (")) << cache_msg;
  EXPECT_TRUE(has(cache_msg, "): delete it (it is only a cache; its tiles are fetched again from the server)")) << cache_msg;
  EXPECT_FALSE(has(cache_msg, "map store")) << cache_msg;
  EXPECT_TRUE(has(store_msg, store_path + ": the map store is damaged (")) << store_msg;
  EXPECT_TRUE(has(store_msg, "): restore it from a backup, or rebuild it with pl-map")) << store_msg;
  EXPECT_FALSE(has(store_msg, "tile cache")) << store_msg;
}

// A cache of schema version 1 (before signed manifests) is migrated in place: what it held stays.
TEST(TileCacheToolkit, CacheOfSchemaVersionOneGainsSignedManifestsAndKeepsItsTiles) {
  TempDir dir;
  const std::string path = dir / "cache.sqlite";
  const std::string hash = make_cache(path);
  raw_sql(path, "DROP TABLE signed_manifests; PRAGMA user_version = 1");
  {
    TileCache cache(path);
    EXPECT_TRUE(cache.blob(hash));
    EXPECT_EQ(cache.tiles("town", 1).size(), 41u);
    EXPECT_FALSE(cache.signed_manifest("town", 1));
    cache.put_signed_manifest("town", 1, "signed bytes");
  }
  TileCache again(path);
  EXPECT_EQ(again.signed_manifest("town", 1).value_or(""), "signed bytes");
  // A version-1 cache whose tables are not version 1's is refused as before.
  const std::string other = dir / "other.sqlite";
  make_cache(other);
  raw_sql(other, "PRAGMA user_version = 1");  // claims 1 but has version 2's table
  EXPECT_TRUE(has(error_of([&] { TileCache c(other); }), "not the ones this software makes"));
}

TEST(TileCacheToolkit, NewerCacheIsRefusedAndLeftAlone) {
  TempDir dir;
  const std::string path = dir / "cache.sqlite";
  make_cache(path);
  raw_sql(path, "PRAGMA user_version = 3");
  const std::string before = pl::test::read_file(path);
  const std::string msg = error_of([&] { TileCache cache(path); });
  EXPECT_TRUE(has(msg, path + ": the tile cache has schema version 3, newer than this build knows (2): upgrade")) << msg;
  EXPECT_TRUE(has(msg, "or delete the cache")) << msg;
  EXPECT_EQ(pl::test::read_file(path), before);
}

TEST(TileCacheToolkit, FilesOfOtherKindsSayWhatTheyAre) {
  TempDir dir;
  pl::test::write_file(dir / "notes.txt", std::string(5000, 'n'));
  std::string msg = error_of([&] { TileCache cache(dir / "notes.txt"); });
  EXPECT_TRUE(has(msg, "not a tile cache (not a SQLite database")) << msg;
  EXPECT_TRUE(has(msg, "choose another cache_path")) << msg;
  const std::string other = dir / "other.sqlite";
  raw_sql(other, "PRAGMA application_id = 7; CREATE TABLE notes (body TEXT)");
  msg = error_of([&] { TileCache cache(other); });
  EXPECT_TRUE(has(msg, other + ": not a tile cache (a SQLite database of another application, application_id 7)")) << msg;
  // A store is an SQLite file of this project, but not a cache.
  { pl::store::Store::open(dir / "maps.sqlite"); }
  msg = error_of([&] { TileCache cache(dir / "maps.sqlite"); });
  EXPECT_TRUE(has(msg, "not a tile cache (a SQLite database of another application, application_id " +
                           std::to_string(0x504C4D53) + ")")) << msg;
}

TEST(TileCacheToolkit, MovedFromCacheSaysSo) {
  TempDir dir;
  TileCache cache(dir / "cache.sqlite");
  TileCache moved(std::move(cache));
  EXPECT_EQ(moved.blob_count(), 0u);
  EXPECT_EQ(error_of([&] { cache.blob_count(); }), "tile cache: used after it was moved from");
}
