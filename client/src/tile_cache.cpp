// The disk cache over SQLite. All values reach SQL through bound parameters.
#include "pl/client/tile_cache.hpp"

#include <sqlite3.h>

#include <utility>

#include "pl/common/error.hpp"
#include "pl/schema/store.hpp"

namespace pl::client {

namespace {

constexpr int kApplicationId = 0x504C5443;  // 'PLTC'
constexpr int kSchemaVersion = 1;
constexpr int kBusyTimeoutMs = 5000;

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

sqlite3* handle(void* db, const std::string& path) {
  if (!db) throw Error(path.empty() ? std::string("tile cache: used after it was moved from") : path + ": tile cache is closed");
  return static_cast<sqlite3*>(db);
}

[[noreturn]] void fail(sqlite3* db, const std::string& path, const std::string& what) {
  throw Error(path + ": " + what + ": " + sqlite3_errmsg(db));
}

void exec(sqlite3* db, const std::string& path, const char* sql) {
  char* msg = nullptr;
  if (sqlite3_exec(db, sql, nullptr, nullptr, &msg) != SQLITE_OK) {
    std::string text = msg ? msg : "unknown error";
    sqlite3_free(msg);
    throw Error(path + ": " + text);
  }
}

class Stmt {
 public:
  Stmt(sqlite3* db, const std::string& path, const char* sql) : db_(db), path_(path) {
    if (sqlite3_prepare_v2(db, sql, -1, &stmt_, nullptr) != SQLITE_OK) fail(db, path, "cannot prepare a query");
  }
  ~Stmt() { sqlite3_finalize(stmt_); }
  Stmt(const Stmt&) = delete;
  Stmt& operator=(const Stmt&) = delete;

  Stmt& bind(int i, long long v) {
    check(sqlite3_bind_int64(stmt_, i, v));
    return *this;
  }
  Stmt& bind(int i, double v) {
    check(sqlite3_bind_double(stmt_, i, v));
    return *this;
  }
  Stmt& bind(int i, const std::string& v) {
    check(sqlite3_bind_text(stmt_, i, v.data(), static_cast<int>(v.size()), SQLITE_TRANSIENT));
    return *this;
  }
  Stmt& bind_blob(int i, std::string_view v) {  // not copied: v must outlive the steps
    check(sqlite3_bind_blob64(stmt_, i, v.data(), v.size(), SQLITE_STATIC));
    return *this;
  }
  Stmt& bind_null(int i) {
    check(sqlite3_bind_null(stmt_, i));
    return *this;
  }
  bool step() {
    int rc = sqlite3_step(stmt_);
    if (rc == SQLITE_ROW) return true;
    if (rc == SQLITE_DONE) return false;
    fail(db_, path_, "query failed");
  }
  void run() {
    while (step()) {
    }
  }
  void reset() {
    sqlite3_reset(stmt_);
    sqlite3_clear_bindings(stmt_);
  }
  long long int64(int col) const { return sqlite3_column_int64(stmt_, col); }
  double real(int col) const { return sqlite3_column_double(stmt_, col); }
  bool is_null(int col) const { return sqlite3_column_type(stmt_, col) == SQLITE_NULL; }
  std::string text(int col) const {
    const auto* p = sqlite3_column_text(stmt_, col);
    return p ? std::string(reinterpret_cast<const char*>(p), static_cast<std::size_t>(sqlite3_column_bytes(stmt_, col))) : std::string();
  }
  std::string blob(int col) const {
    const auto* p = static_cast<const char*>(sqlite3_column_blob(stmt_, col));
    return p ? std::string(p, static_cast<std::size_t>(sqlite3_column_bytes(stmt_, col))) : std::string();
  }

 private:
  void check(int rc) {
    if (rc != SQLITE_OK) fail(db_, path_, "cannot bind a query parameter");
  }
  sqlite3* db_;
  const std::string& path_;
  sqlite3_stmt* stmt_ = nullptr;
};

long long pragma_int(sqlite3* db, const std::string& path, const char* sql) {
  Stmt st(db, path, sql);
  return st.step() ? st.int64(0) : 0;
}

// One transaction taking the write lock at once (so the busy timeout applies); rolls back unless committed.
class WriteTransaction {
 public:
  WriteTransaction(sqlite3* db, const std::string& path) : db_(db), path_(path) { exec(db, path, "BEGIN IMMEDIATE"); }
  ~WriteTransaction() {
    if (!done_) sqlite3_exec(db_, "ROLLBACK", nullptr, nullptr, nullptr);
  }
  WriteTransaction(const WriteTransaction&) = delete;
  WriteTransaction& operator=(const WriteTransaction&) = delete;
  void commit() {
    exec(db_, path_, "COMMIT");
    done_ = true;
  }

 private:
  sqlite3* db_;
  const std::string& path_;
  bool done_ = false;
};

CachedManifest read_manifest(const Stmt& st) {
  CachedManifest m;
  m.map = st.text(0);
  m.version = st.int64(1);
  m.tile_size = st.real(2);
  m.voxel_size = st.real(3);
  m.origin = GeoPoint{st.real(4), st.real(5), st.real(6)};
  return m;
}

constexpr const char* kManifestColumns = "SELECT map, version, tile_size, voxel_size, origin_lat, origin_lon, origin_alt FROM manifests ";

}  // namespace

TileCache::TileCache(const std::string& path) : path_(path) {
  sqlite3* db = nullptr;
  int rc = sqlite3_open_v2(path.c_str(), &db, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE, nullptr);
  if (rc != SQLITE_OK) {
    std::string msg = db ? sqlite3_errmsg(db) : sqlite3_errstr(rc);
    sqlite3_close(db);
    throw Error(path + ": cannot open the tile cache (" + msg + "): check that its folder exists and is writable, or choose another cache_path");
  }
  db_ = db;
  try {
    sqlite3_busy_timeout(db, kBusyTimeoutMs);
    long long app = 0;
    try {
      app = pragma_int(db, path, "PRAGMA application_id");
    } catch (const Error&) {
      throw Error(path + ": not a tile cache (not an SQLite database): delete it (it is only a cache) or choose another cache_path");
    }
    long long tables = pragma_int(db, path, "SELECT count(*) FROM sqlite_master");
    if (app != kApplicationId && (app != 0 || tables != 0))
      throw Error(path + ": not a tile cache (another SQLite database): choose another cache_path");
    long long schema = pragma_int(db, path, "PRAGMA user_version");
    if (schema > kSchemaVersion)
      throw Error(path + ": this tile cache was written by a newer build (schema " + std::to_string(schema) + ", this build knows " +
                  std::to_string(kSchemaVersion) + "): upgrade, or delete the cache");
    // WAL lets the tests (and tools) read the cache while a client writes it; NORMAL is durable
    // enough for a cache (a power cut loses at most the last transactions, never the file).
    {
      Stmt wal(db, path, "PRAGMA journal_mode=WAL");
      if (!wal.step() || wal.text(0) != "wal") throw Error(path + ": cannot switch the tile cache to WAL mode (is the file on a network share?)");
    }
    exec(db, path, "PRAGMA synchronous=NORMAL");
    if (schema < kSchemaVersion) {
      WriteTransaction tx(db, path);
      exec(db, path, kSchema);
      exec(db, path, ("PRAGMA application_id=" + std::to_string(kApplicationId)).c_str());
      exec(db, path, ("PRAGMA user_version=" + std::to_string(kSchemaVersion)).c_str());
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
  sqlite3* db = handle(db_, path_);
  if (corrupt) *corrupt = false;
  std::string bytes;
  {
    Stmt st(db, path_, "SELECT bytes FROM blobs WHERE hash = ?1");
    st.bind(1, hash);
    if (!st.step()) return std::nullopt;
    bytes = st.blob(0);
  }
  if (store::content_hash(bytes) == hash) return bytes;
  Stmt del(db, path_, "DELETE FROM blobs WHERE hash = ?1");
  del.bind(1, hash).run();
  if (corrupt) *corrupt = true;
  return std::nullopt;
}

bool TileCache::has_blob(const std::string& hash) const {
  Stmt st(handle(db_, path_), path_, "SELECT 1 FROM blobs WHERE hash = ?1");
  st.bind(1, hash);
  return st.step();
}

void TileCache::put_blob(const std::string& hash, std::string_view bytes) {
  Stmt st(handle(db_, path_), path_, "INSERT OR REPLACE INTO blobs (hash, bytes) VALUES (?1, ?2)");
  st.bind(1, hash).bind_blob(2, bytes).run();
}

std::size_t TileCache::blob_count() const {
  return static_cast<std::size_t>(pragma_int(handle(db_, path_), path_, "SELECT count(*) FROM blobs"));
}

void TileCache::put_manifest(const CachedManifest& m) {
  sqlite3* db = handle(db_, path_);
  WriteTransaction tx(db, path_);
  Stmt st(db, path_,
          "INSERT OR REPLACE INTO manifests (map, version, tile_size, voxel_size, origin_lat, origin_lon, origin_alt, used) "
          "VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, (SELECT coalesce(max(used), 0) + 1 FROM manifests))");
  st.bind(1, m.map).bind(2, m.version).bind(3, m.tile_size).bind(4, m.voxel_size);
  st.bind(5, m.origin.lat_deg).bind(6, m.origin.lon_deg).bind(7, m.origin.alt_m).run();
  tx.commit();
}

std::optional<CachedManifest> TileCache::manifest(const std::string& map, long long version) const {
  Stmt st(handle(db_, path_), path_, (std::string(kManifestColumns) + "WHERE map = ?1 AND version = ?2").c_str());
  st.bind(1, map).bind(2, version);
  if (!st.step()) return std::nullopt;
  return read_manifest(st);
}

std::optional<CachedManifest> TileCache::last_used(const std::string& map) const {
  Stmt st(handle(db_, path_), path_, (std::string(kManifestColumns) + "WHERE map = ?1 ORDER BY used DESC LIMIT 1").c_str());
  st.bind(1, map);
  if (!st.step()) return std::nullopt;
  return read_manifest(st);
}

void TileCache::put_tiles(const std::string& map, long long version, const std::vector<CachedTile>& tiles) {
  sqlite3* db = handle(db_, path_);
  WriteTransaction tx(db, path_);
  Stmt st(db, path_, "INSERT OR REPLACE INTO tiles (map, version, tx, ty, hash, points) VALUES (?1, ?2, ?3, ?4, ?5, ?6)");
  for (const auto& t : tiles) {
    st.reset();
    st.bind(1, map).bind(2, version).bind(3, static_cast<long long>(t.key.tx)).bind(4, static_cast<long long>(t.key.ty));
    if (t.exists())
      st.bind(5, t.hash);
    else
      st.bind_null(5);
    st.bind(6, t.points).run();
  }
  tx.commit();
}

std::vector<CachedTile> TileCache::tiles(const std::string& map, long long version) const {
  Stmt st(handle(db_, path_), path_, "SELECT tx, ty, hash, points FROM tiles WHERE map = ?1 AND version = ?2 ORDER BY tx, ty");
  st.bind(1, map).bind(2, version);
  std::vector<CachedTile> out;
  while (st.step()) {
    CachedTile t;
    t.key = TileKey{static_cast<std::int32_t>(st.int64(0)), static_cast<std::int32_t>(st.int64(1))};
    if (!st.is_null(2)) t.hash = st.text(2);
    t.points = st.int64(3);
    out.push_back(std::move(t));
  }
  return out;
}

}  // namespace pl::client
