// The disk cache over SQLite. All values reach SQL through bound parameters.
#include "pl/client/tile_cache.hpp"

#include <sqlite3.h>

#include <cmath>
#include <limits>
#include <map>
#include <mutex>
#include <utility>

#include "pl/common/error.hpp"
#include "pl/schema/store.hpp"

namespace pl::client {

namespace {

constexpr int kApplicationId = 0x504C5443;  // 'PLTC'
constexpr int kSchemaVersion = 1;
constexpr int kBusyTimeoutMs = 5000;
// The largest string or blob the cache holds or SQLite builds for it (SQLITE_LIMIT_LENGTH): that of
// the map store, whose tiles are the ones cached.
constexpr std::size_t kMaxValueBytes = std::size_t{256} << 20;

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

// "PATH: the tile cache is damaged (WHAT): ...". The cache only holds copies of what the server
// has, so deleting it loses nothing; nothing here deletes it on its own (it may still serve tiles
// while the server is unreachable, and the file may be wanted for a look at what went wrong).
[[noreturn]] void damaged(const std::string& path, const std::string& what) {
  throw Error(path + ": the tile cache is damaged (" + what +
              "): delete it (it is only a cache; its tiles are fetched again from the server) or choose another cache_path");
}

// SQLite's errors for a file that breaks the file format, or has no database header.
bool says_damaged(int rc) { return (rc & 0xFF) == SQLITE_CORRUPT || (rc & 0xFF) == SQLITE_NOTADB; }

[[noreturn]] void fail(sqlite3* db, const std::string& path, const std::string& what) {
  int rc = sqlite3_extended_errcode(db);
  // Values written are checked against the length limit first (check_size), so SQLITE_TOOBIG can
  // only come from a value the file declares.
  if (says_damaged(rc) || (rc & 0xFF) == SQLITE_TOOBIG) damaged(path, sqlite3_errmsg(db));
  throw Error(path + ": " + what + ": " + sqlite3_errmsg(db));
}

void exec(sqlite3* db, const std::string& path, const char* sql) {
  char* msg = nullptr;
  int rc = sqlite3_exec(db, sql, nullptr, nullptr, &msg);
  if (rc != SQLITE_OK) {
    std::string text = msg ? msg : sqlite3_errstr(rc);
    sqlite3_free(msg);
    if (says_damaged(rc)) damaged(path, text);
    throw Error(path + ": " + text);
  }
}

void config(sqlite3* db, const std::string& path, int option, int value, const char* name) {
  int now = -1;
  if (sqlite3_db_config(db, option, value, &now) != SQLITE_OK || now != value)
    throw Error(path + ": this SQLite (" + sqlite3_libversion() + ") cannot set " + name + ": install SQLite 3.35 or newer");
}

// The cache is a file on the vehicle that may be damaged (power cuts, a failing card) or replaced.
// The same settings as the map store's connections (schema/src/sqlite_util.cpp says why each).
void harden(sqlite3* db, const std::string& path) {
  config(db, path, SQLITE_DBCONFIG_DEFENSIVE, 1, "SQLITE_DBCONFIG_DEFENSIVE");  // SQL cannot corrupt the file
  // No function or virtual table that is not innocuous in the file's SQL (the cache's own schema uses none).
  config(db, path, SQLITE_DBCONFIG_TRUSTED_SCHEMA, 0, "SQLITE_DBCONFIG_TRUSTED_SCHEMA");
  config(db, path, SQLITE_DBCONFIG_ENABLE_VIEW, 0, "SQLITE_DBCONFIG_ENABLE_VIEW");  // the cache has no views
  config(db, path, SQLITE_DBCONFIG_ENABLE_FTS3_TOKENIZER, 0, "SQLITE_DBCONFIG_ENABLE_FTS3_TOKENIZER");
  config(db, path, SQLITE_DBCONFIG_ENABLE_LOAD_EXTENSION, 0, "SQLITE_DBCONFIG_ENABLE_LOAD_EXTENSION");
  sqlite3_limit(db, SQLITE_LIMIT_LENGTH, static_cast<int>(kMaxValueBytes));  // no blob of gigabytes from a damaged record
  sqlite3_limit(db, SQLITE_LIMIT_ATTACHED, 0);
  sqlite3_limit(db, SQLITE_LIMIT_TRIGGER_DEPTH, 16);  // the cache has no triggers
  exec(db, path, "PRAGMA cell_size_check = ON");  // damage reported where it is, not read past or spread
  exec(db, path, "PRAGMA mmap_size = 0");         // a truncated file gives an error, not SIGBUS
}

bool is_hash(const std::string& s) {
  if (s.size() != 64) return false;
  for (char c : s)
    if (!((c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'))) return false;
  return true;
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
    check_size(v.size());
    check(sqlite3_bind_text(stmt_, i, v.data(), static_cast<int>(v.size()), SQLITE_TRANSIENT));
    return *this;
  }
  Stmt& bind_blob(int i, std::string_view v) {  // not copied: v must outlive the steps
    check_size(v.size());
    // An empty view's data() may be null, which SQLite would bind as NULL; zeroblob(0) is an empty blob.
    check(v.empty() ? sqlite3_bind_zeroblob(stmt_, i, 0) : sqlite3_bind_blob64(stmt_, i, v.data(), v.size(), SQLITE_STATIC));
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
  int type(int col) const { return sqlite3_column_type(stmt_, col); }
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
  void check_size(std::size_t n) const {
    if (n > kMaxValueBytes)
      throw Error(path_ + ": a value of " + std::to_string(n) + " bytes is larger than the tile cache's limit of " +
                  std::to_string(kMaxValueBytes >> 20) + " MiB");
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

// Values read from the file, checked against what the cache writes: SQLite checks neither types nor
// NOT NULL on rows it reads, and a damaged file may hold anything. A value that breaks the promise
// is a damaged() error naming the table and column.
class Row {
 public:
  Row(const Stmt& st, const std::string& path, const char* table) : st_(st), path_(path), table_(table) {}
  long long integer(int col, const char* column, long long min = std::numeric_limits<long long>::min(),
                    long long max = std::numeric_limits<long long>::max()) const {
    if (st_.type(col) != SQLITE_INTEGER) bad(column, "is not an integer");
    long long v = st_.int64(col);
    if (v < min || v > max) bad(column, "is out of range (" + std::to_string(v) + ")");
    return v;
  }
  double number(int col, const char* column) const {  // finite (a REAL column reads integers as reals)
    if (st_.type(col) != SQLITE_FLOAT && st_.type(col) != SQLITE_INTEGER) bad(column, "is not a number");
    double v = st_.real(col);
    if (!std::isfinite(v)) bad(column, "is not finite");
    return v;
  }
  std::string text(int col, const char* column) const {
    if (st_.type(col) != SQLITE_TEXT) bad(column, "is not text");
    return st_.text(col);
  }
  std::string hash(int col, const char* column) const {
    std::string s = text(col, column);
    if (!is_hash(s)) bad(column, "is not a SHA-256 hash (64 lowercase hex digits)");
    return s;
  }
  [[noreturn]] void bad(const char* column, const std::string& why) const {
    damaged(path_, std::string(table_) + "." + column + " " + why);
  }

 private:
  const Stmt& st_;
  const std::string& path_;
  const char* table_;
};

// What put_manifest accepts, and so what manifest() and last_used() may return.
bool valid_manifest(const CachedManifest& m) {
  return m.tile_size > 0 && std::isfinite(m.tile_size) && m.voxel_size >= 0 && std::isfinite(m.voxel_size) &&
         std::isfinite(m.origin.lat_deg) && std::isfinite(m.origin.lon_deg) && std::isfinite(m.origin.alt_m);
}

CachedManifest read_manifest(const Stmt& st, const std::string& path) {
  Row row(st, path, "manifests");
  CachedManifest m;
  m.map = row.text(0, "map");
  m.version = row.integer(1, "version");
  m.tile_size = row.number(2, "tile_size");
  m.voxel_size = row.number(3, "voxel_size");
  m.origin = GeoPoint{row.number(4, "origin_lat"), row.number(5, "origin_lon"), row.number(6, "origin_alt")};
  row.integer(7, "used");  // the order of last_used: a value that is not an integer sorts wrongly
  if (!(m.tile_size > 0)) row.bad("tile_size", "is not a positive number");
  if (!(m.voxel_size >= 0)) row.bad("voxel_size", "is negative");
  return m;
}

constexpr const char* kManifestColumns =
    "SELECT map, version, tile_size, voxel_size, origin_lat, origin_lon, origin_alt, used FROM manifests ";

// ---- opening -------------------------------------------------------------------------------------

// The schema objects of a database: (type, name) -> SQL text ("" for SQLite's own objects, whose
// text may differ between SQLite versions).
using Schema = std::map<std::pair<std::string, std::string>, std::string>;

Schema read_schema(sqlite3* db, const std::string& path) {
  Schema out;
  Stmt st(db, path, "SELECT type, name, sql FROM sqlite_schema");
  while (st.step()) {
    std::string name = st.text(1);
    out[{st.text(0), name}] = name.rfind("sqlite_", 0) == 0 ? "" : st.text(2);
  }
  return out;
}

// What kSchema makes, built once in a private in-memory database.
const Schema& expected_schema() {
  static std::once_flag once;
  static Schema schema;
  std::call_once(once, [] {
    sqlite3* db = nullptr;
    if (sqlite3_open(":memory:", &db) != SQLITE_OK) {
      sqlite3_close(db);
      throw Error("tile cache: cannot open an in-memory SQLite database (out of memory?)");
    }
    try {
      exec(db, "(the tile cache schema)", kSchema);
      schema = read_schema(db, "(the tile cache schema)");
    } catch (...) {
      sqlite3_close(db);
      throw;
    }
    sqlite3_close(db);
  });
  return schema;
}

// Refuses a file whose schema is not exactly kSchema's: a crafted one could keep a trigger that
// runs on the cache's writes, or a view or virtual table in place of a table.
void check_schema(sqlite3* db, const std::string& path) {
  const Schema& want = expected_schema();
  const Schema have = read_schema(db, path);
  if (have != want) damaged(path, "its tables are not the ones this software makes");
}

// One read transaction, so the values the constructor checks come from one snapshot.
class ReadSnapshot {
 public:
  ReadSnapshot(sqlite3* db, const std::string& path) : db_(db), path_(path) { exec(db_, path_, "BEGIN"); }
  ~ReadSnapshot() {
    if (open_) sqlite3_exec(db_, "ROLLBACK", nullptr, nullptr, nullptr);
  }
  ReadSnapshot(const ReadSnapshot&) = delete;
  ReadSnapshot& operator=(const ReadSnapshot&) = delete;
  void end() {
    open_ = false;
    exec(db_, path_, "COMMIT");
  }

 private:
  sqlite3* db_;
  const std::string& path_;
  bool open_ = true;
};

// Checks the file before anything is written to it (the switch to WAL, the tables of a new cache):
// a file that fails a check is left as it was. Returns its schema version (0: a new, empty cache).
long long check_file(sqlite3* db, const std::string& path) {
  ReadSnapshot snapshot(db, path);
  long long app = 0, schema = 0, objects = 0;
  {
    // The first read of the file: where a file that is not SQLite shows.
    sqlite3_stmt* st = nullptr;
    int rc = sqlite3_prepare_v2(db,
                                "SELECT a.application_id, u.user_version, (SELECT count(*) FROM sqlite_schema) "
                                "FROM pragma_application_id AS a, pragma_user_version AS u",
                                -1, &st, nullptr);
    if (rc == SQLITE_OK) rc = sqlite3_step(st);
    if (rc == SQLITE_ROW) {
      app = sqlite3_column_int64(st, 0);
      schema = sqlite3_column_int64(st, 1);
      objects = sqlite3_column_int64(st, 2);
    }
    sqlite3_finalize(st);
    if ((rc & 0xFF) == SQLITE_NOTADB)
      throw Error(path + ": not a tile cache (not an SQLite database): delete it (it is only a cache) or choose another cache_path");
    // A header or schema SQLite cannot use ("unsupported file format", a schema that does not
    // parse: plain SQLITE_ERRORs; some damaged schemas: SQLITE_NOMEM). Not: BUSY, LOCKED, IOERR.
    int primary = rc & 0xFF;
    if (primary == SQLITE_ERROR || primary == SQLITE_NOMEM || primary == SQLITE_CORRUPT || primary == SQLITE_TOOBIG ||
        primary == SQLITE_FORMAT || primary == SQLITE_RANGE || primary == SQLITE_MISMATCH)
      damaged(path, std::string(sqlite3_errmsg(db)) + (primary == SQLITE_NOMEM ? ", which SQLite also reports for some damaged files" : ""));
    if (rc != SQLITE_ROW) fail(db, path, "reading the file's header");
  }
  // SQLite opens a file whose header has a write version above 2 read-only (the cache was opened
  // for writing, so the file itself is writable).
  if (sqlite3_db_readonly(db, "main") == 1)
    damaged(path, "its header says SQLite may only read it (a file format write version other than 1 or 2)");
  if (app != kApplicationId && (app != 0 || objects != 0))
    throw Error(path + ": not a tile cache (another SQLite database): choose another cache_path");
  if (schema > kSchemaVersion)
    throw Error(path + ": this tile cache was written by a newer build (schema " + std::to_string(schema) + ", this build knows " +
                std::to_string(kSchemaVersion) + "): upgrade, or delete the cache");
  if (schema < 0) damaged(path, "negative schema version " + std::to_string(schema));
  if (schema == 0 && objects != 0) damaged(path, "it has tables but no schema version");
  if (schema == kSchemaVersion) {
    check_schema(db, path);
    // The switch to WAL below writes the header: check the whole file first (once: WAL is kept).
    Stmt mode(db, path, "PRAGMA journal_mode");
    if (!mode.step() || mode.text(0) != "wal") {
      Stmt check(db, path, "PRAGMA quick_check");
      std::string answer = check.step() ? check.text(0) : "no answer";
      if (answer != "ok") {
        for (char& c : answer) c = (c >= 0x20 && c < 0x7F) ? c : ' ';  // one line of plain text
        damaged(path, "quick_check: " + answer.substr(0, 160));
      }
    }
  }
  snapshot.end();
  return schema;
}

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
    sqlite3_extended_result_codes(db, 1);
    harden(db, path);
    if (sqlite3_db_readonly(db, "main") == 1)
      throw Error(path + ": the tile cache is read-only (check the permissions of the file and its folder), or choose another cache_path");
    const long long schema = check_file(db, path);
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
  if (!is_hash(hash)) throw Error(path_ + ": put_blob: the hash is not a SHA-256 hash (64 lowercase hex digits)");
  Stmt st(handle(db_, path_), path_, "INSERT OR REPLACE INTO blobs (hash, bytes) VALUES (?1, ?2)");
  st.bind(1, hash).bind_blob(2, bytes).run();
}

std::size_t TileCache::blob_count() const {
  return static_cast<std::size_t>(pragma_int(handle(db_, path_), path_, "SELECT count(*) FROM blobs"));
}

void TileCache::put_manifest(const CachedManifest& m) {
  sqlite3* db = handle(db_, path_);
  if (!valid_manifest(m))
    throw Error(path_ + ": manifest of map " + m.map + " version " + std::to_string(m.version) +
                ": the tile size must be a positive number, the voxel size and the origin finite numbers");
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
  return read_manifest(st, path_);
}

std::optional<CachedManifest> TileCache::last_used(const std::string& map) const {
  Stmt st(handle(db_, path_), path_, (std::string(kManifestColumns) + "WHERE map = ?1 ORDER BY used DESC LIMIT 1").c_str());
  st.bind(1, map);
  if (!st.step()) return std::nullopt;
  return read_manifest(st, path_);
}

void TileCache::put_tiles(const std::string& map, long long version, const std::vector<CachedTile>& tiles) {
  sqlite3* db = handle(db_, path_);
  for (const auto& t : tiles)
    if (t.exists() && !is_hash(t.hash))
      throw Error(path_ + ": put_tiles: the hash of tile " + std::to_string(t.key.tx) + "/" + std::to_string(t.key.ty) +
                  " is not a SHA-256 hash (64 lowercase hex digits)");
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
  constexpr long long kMinKey = std::numeric_limits<std::int32_t>::min(), kMaxKey = std::numeric_limits<std::int32_t>::max();
  while (st.step()) {
    Row row(st, path_, "tiles");
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
