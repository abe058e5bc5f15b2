// The disk cache over SQLite, through the SQLite toolkit it shares with the map store
// (pl/schema/detail/sqlite.hpp: the same connection settings, checks at opening, checked reads and
// wording of messages). All values reach SQL through bound parameters.
#include "pl/client/tile_cache.hpp"

#include <cmath>
#include <cstdint>
#include <limits>
#include <utility>

#include "pl/common/error.hpp"
#include "pl/schema/api_rules.hpp"
#include "pl/schema/detail/sqlite.hpp"
#include "pl/schema/store.hpp"

namespace pl::client {

namespace {

using sqlite::Db;
using sqlite::exec;
using sqlite::Row;
using sqlite::Stmt;
using sqlite::WriteScope;

constexpr int kSchemaVersion = 2;

// What messages call a cache file, and the fixes they name. The cache only holds copies of what
// the server has, so deleting it loses nothing; nothing here deletes it on its own (it may still
// serve tiles while the server is unreachable, and the file may be wanted for a look at what went
// wrong).
const sqlite::FileKind kTileCache = {
    "tile cache",
    0x504C5443,  // 'PLTC'
    "delete it (it is only a cache; its tiles are fetched again from the server) or choose another cache_path",
    "choose another cache_path",
    "upgrade the PointLocalization software, or delete the cache (it is only a cache)",
};

constexpr const char* kSchema = R"sql(
CREATE TABLE IF NOT EXISTS blobs (
  hash TEXT PRIMARY KEY NOT NULL,  -- SHA-256 of bytes, lowercase hex
  bytes BLOB NOT NULL
);
CREATE TABLE IF NOT EXISTS manifests (
  map TEXT NOT NULL,
  version INTEGER NOT NULL,
  tile_size REAL NOT NULL,
  voxel_size REAL NOT NULL,
  origin_lat REAL NOT NULL,
  origin_lon REAL NOT NULL,
  origin_alt REAL NOT NULL,
  used INTEGER NOT NULL,  -- larger: used more recently
  PRIMARY KEY (map, version)
);
CREATE TABLE IF NOT EXISTS tiles (
  map TEXT NOT NULL,
  version INTEGER NOT NULL,
  tx INTEGER NOT NULL,
  ty INTEGER NOT NULL,
  hash TEXT,  -- NULL: the version has no tile at this key
  points INTEGER NOT NULL,
  PRIMARY KEY (map, version, tx, ty)
) WITHOUT ROWID;
)sql";

// Schema version 2: the signed manifests of map versions (pl/schema/signed_manifest.hpp), as the
// server sent them: the client verifies one again each time it reads it.
constexpr const char* kSchema2 = R"sql(
CREATE TABLE IF NOT EXISTS signed_manifests (
  map TEXT NOT NULL,
  version INTEGER NOT NULL,
  body BLOB NOT NULL,
  PRIMARY KEY (map, version)
);
)sql";

Db handle(void* db, const std::string& path) { return sqlite::checked(db, path, kTileCache); }

// What put_manifest accepts, and so what manifest() and last_used() may return.
bool valid_manifest(const CachedManifest& m) {
  return m.tile_size > 0 && std::isfinite(m.tile_size) && m.voxel_size >= 0 && std::isfinite(m.voxel_size) &&
         std::isfinite(m.origin.lat_deg) && std::isfinite(m.origin.lon_deg) && std::isfinite(m.origin.alt_m);
}

// Each value checked against what put_manifest writes (Row: a damaged file may hold anything).
CachedManifest read_manifest(const Stmt& st) {
  Row row(st, "manifests");
  CachedManifest m;
  m.map = row.text(0, "map");
  m.version = row.integer(1, "version");
  m.tile_size = row.positive(2, "tile_size");
  m.voxel_size = row.number(3, "voxel_size", 0);
  m.origin = GeoPoint{row.number(4, "origin_lat"), row.number(5, "origin_lon"), row.number(6, "origin_alt")};
  row.integer(7, "used");  // the order of last_used: a value that is not an integer sorts wrongly
  return m;
}

constexpr const char* kManifestColumns =
    "SELECT map, version, tile_size, voxel_size, origin_lat, origin_lon, origin_alt, used FROM manifests ";

// ---- opening -------------------------------------------------------------------------------------

// What the scripts make at each schema version, built once.
const sqlite::Schema& expected_schema(std::int64_t version) {
  static const sqlite::Schema v1 = sqlite::schema_of(kTileCache, {kSchema});
  static const sqlite::Schema v2 = sqlite::schema_of(kTileCache, {kSchema, kSchema2});
  return version == 1 ? v1 : v2;
}

// Checks the file before anything is written to it (the switch to WAL, the tables of a new cache):
// a file that fails a check is left as it was. Returns its schema version (0: a new, empty cache).
std::int64_t check_file(const Db& db) {
  sqlite::ReadSnapshot snapshot(db);
  const sqlite::Header h = sqlite::read_header(db);
  sqlite::check_identity(db, h, kSchemaVersion);
  if (h.user_version >= 1) {
    sqlite::check_schema(db, expected_schema(h.user_version), "its tables are not the ones this software makes");
  } else if (sqlite::query_int(db, "SELECT count(*) FROM sqlite_schema") != 0) {
    // Schema version 0 is a new cache: one that already has tables is something else.
    throw Error(db.path() + ": not a tile cache (schema version 0 but it has tables): delete it or choose another cache_path");
  }
  // The switch to WAL and the tables of a new cache write the file: check the whole of it first
  // (once: WAL is kept).
  if (sqlite::journal_mode(db) != "wal") sqlite::quick_check(db);
  snapshot.end();
  return h.user_version;
}

}  // namespace

TileCache::TileCache(const std::string& path) : path_(path) {
  sqlite3* db = nullptr;
  sqlite::configure_library();
  int rc = sqlite3_open_v2(path.c_str(), &db, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE, nullptr);
  if (rc != SQLITE_OK) {
    std::string msg = db ? sqlite3_errmsg(db) : sqlite3_errstr(rc);
    sqlite3_close(db);
    throw Error(path + ": cannot open the tile cache (" + msg + "): check that its folder exists and is writable, or choose another cache_path");
  }
  db_ = db;
  try {
    const Db conn(db, path_, kTileCache);
    sqlite::prepare_connection(conn);
    const std::int64_t schema = check_file(conn);
    // WAL lets the tests (and tools) read the cache while a client writes it; synchronous NORMAL is
    // durable enough for a cache (a power cut loses at most the last transactions, never the file).
    sqlite::use_wal(conn);
    if (schema < kSchemaVersion) {  // a new cache, or one of schema version 1 (its tables are kept)
      WriteScope tx(conn);
      exec(conn, kSchema);
      exec(conn, kSchema2);
      exec(conn, ("PRAGMA application_id=" + std::to_string(kTileCache.application_id)).c_str());
      exec(conn, ("PRAGMA user_version=" + std::to_string(kSchemaVersion)).c_str());
      tx.commit();
    }
  } catch (...) {
    sqlite3_close(db);
    db_ = nullptr;
    throw;
  }
}

TileCache::~TileCache() {
  if (db_) sqlite3_close(static_cast<sqlite3*>(db_));
}

TileCache::TileCache(TileCache&& o) noexcept : path_(std::move(o.path_)), db_(std::exchange(o.db_, nullptr)) {}

TileCache& TileCache::operator=(TileCache&& o) noexcept {
  if (this != &o) {
    if (db_) sqlite3_close(static_cast<sqlite3*>(db_));
    path_ = std::move(o.path_);
    db_ = std::exchange(o.db_, nullptr);
  }
  return *this;
}

std::optional<std::string> TileCache::blob(const std::string& hash, bool* corrupt) {
  const Db db = handle(db_, path_);
  if (corrupt) *corrupt = false;
  std::string bytes;
  {
    Stmt st(db, "SELECT bytes FROM blobs WHERE hash = ?1");
    st.bind_text(1, hash);
    if (!st.step()) return std::nullopt;
    bytes = st.blob(0);
  }
  if (store::content_hash(bytes) == hash) return bytes;
  Stmt del(db, "DELETE FROM blobs WHERE hash = ?1");
  del.bind_text(1, hash).run();
  if (corrupt) *corrupt = true;
  return std::nullopt;
}

bool TileCache::has_blob(const std::string& hash) const {
  Stmt st(handle(db_, path_), "SELECT 1 FROM blobs WHERE hash = ?1");
  st.bind_text(1, hash);
  return st.step();
}

void TileCache::put_blob(const std::string& hash, std::string_view bytes) {
  const Db db = handle(db_, path_);
  if (!api::is_hash(hash)) throw Error(path_ + ": put_blob: the hash is not a SHA-256 hash (64 lowercase hex digits)");
  Stmt st(db, "INSERT OR REPLACE INTO blobs (hash, bytes) VALUES (?1, ?2)");
  st.bind_text(1, hash).bind_blob_static(2, bytes).run();
}

std::size_t TileCache::blob_count() const {
  return static_cast<std::size_t>(sqlite::query_int(handle(db_, path_), "SELECT count(*) FROM blobs"));
}

void TileCache::put_manifest(const CachedManifest& m) {
  const Db db = handle(db_, path_);
  if (!valid_manifest(m))
    throw Error(path_ + ": manifest of map " + m.map + " version " + std::to_string(m.version) +
                ": the tile size must be a positive number, the voxel size and the origin finite numbers");
  WriteScope tx(db);
  Stmt st(db,
          "INSERT OR REPLACE INTO manifests (map, version, tile_size, voxel_size, origin_lat, origin_lon, origin_alt, used) "
          "VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, (SELECT coalesce(max(used), 0) + 1 FROM manifests))");
  st.bind_text(1, m.map).bind_int64(2, m.version).bind_double(3, m.tile_size).bind_double(4, m.voxel_size);
  st.bind_double(5, m.origin.lat_deg).bind_double(6, m.origin.lon_deg).bind_double(7, m.origin.alt_m).run();
  tx.commit();
}

std::optional<CachedManifest> TileCache::manifest(const std::string& map, long long version) const {
  Stmt st(handle(db_, path_), (std::string(kManifestColumns) + "WHERE map = ?1 AND version = ?2").c_str());
  st.bind_text(1, map).bind_int64(2, version);
  if (!st.step()) return std::nullopt;
  return read_manifest(st);
}

std::optional<CachedManifest> TileCache::last_used(const std::string& map) const {
  Stmt st(handle(db_, path_), (std::string(kManifestColumns) + "WHERE map = ?1 ORDER BY used DESC LIMIT 1").c_str());
  st.bind_text(1, map);
  if (!st.step()) return std::nullopt;
  return read_manifest(st);
}

void TileCache::put_tiles(const std::string& map, long long version, const std::vector<CachedTile>& tiles) {
  const Db db = handle(db_, path_);
  for (const auto& t : tiles)
    if (t.exists() && !api::is_hash(t.hash))
      throw Error(path_ + ": put_tiles: the hash of tile " + std::to_string(t.key.tx) + "/" + std::to_string(t.key.ty) +
                  " is not a SHA-256 hash (64 lowercase hex digits)");
  WriteScope tx(db);
  Stmt st(db, "INSERT OR REPLACE INTO tiles (map, version, tx, ty, hash, points) VALUES (?1, ?2, ?3, ?4, ?5, ?6)");
  for (const auto& t : tiles) {
    st.reset();
    st.bind_text(1, map).bind_int64(2, version).bind_int64(3, t.key.tx).bind_int64(4, t.key.ty);
    if (t.exists())
      st.bind_text(5, t.hash);
    else
      st.bind_null(5);
    st.bind_int64(6, t.points).run();
  }
  tx.commit();
}

void TileCache::put_signed_manifest(const std::string& map, long long version, std::string_view body) {
  Stmt st(handle(db_, path_), "INSERT OR REPLACE INTO signed_manifests (map, version, body) VALUES (?1, ?2, ?3)");
  st.bind_text(1, map).bind_int64(2, version).bind_blob_static(3, body).run();
}

std::optional<std::string> TileCache::signed_manifest(const std::string& map, long long version) const {
  Stmt st(handle(db_, path_), "SELECT body FROM signed_manifests WHERE map = ?1 AND version = ?2");
  st.bind_text(1, map).bind_int64(2, version);
  if (!st.step()) return std::nullopt;
  if (st.is_null(0)) return std::nullopt;
  return st.blob(0);
}

std::optional<long long> TileCache::newest_signed_version(const std::string& map) const {
  Stmt st(handle(db_, path_), "SELECT max(version) FROM signed_manifests WHERE map = ?1");
  st.bind_text(1, map);
  if (!st.step() || st.is_null(0)) return std::nullopt;
  return Row(st, "signed_manifests").integer(0, "version");  // a damaged file may hold anything
}

std::vector<CachedTile> TileCache::tiles(const std::string& map, long long version) const {
  Stmt st(handle(db_, path_), "SELECT tx, ty, hash, points FROM tiles WHERE map = ?1 AND version = ?2 ORDER BY tx, ty");
  st.bind_text(1, map).bind_int64(2, version);
  std::vector<CachedTile> out;
  constexpr std::int64_t kMinKey = std::numeric_limits<std::int32_t>::min(), kMaxKey = std::numeric_limits<std::int32_t>::max();
  while (st.step()) {
    Row row(st, "tiles");
    CachedTile t;
    t.key = TileKey{static_cast<std::int32_t>(row.integer(0, "tx", kMinKey, kMaxKey)),
                    static_cast<std::int32_t>(row.integer(1, "ty", kMinKey, kMaxKey))};
    if (!st.is_null(2)) t.hash = row.hash(2, "hash");
    t.points = row.integer(3, "points");
    out.push_back(std::move(t));
  }
  return out;
}

}  // namespace pl::client
