// The map store over SQLite. See store.hpp for the semantics and schema/001_initial.sql for the
// tables. All values reach SQL through bound parameters; the only SQL built from strings are
// PRAGMAs and savepoints whose text comes from this file (integers and fixed identifiers).
#include "pl/schema/store.hpp"

#include <openssl/evp.h>

#include <cmath>
#include <iterator>
#include <utility>

#include "pl/common/error.hpp"
#include "sqlite_util.hpp"

namespace pl::store {

using detail::exec;
using detail::fail;
using detail::Stmt;
using detail::WriteScope;

namespace {

struct Migration {
  int number;
  const char* name;
  const char* sql;
};

// Generated at build time from schema/NNN_*.sql (see schema/CMakeLists.txt), in order 1, 2, ...
const Migration kMigrations[] = {
#include "pl_schema_migrations.inc"
};

constexpr std::int64_t kApplicationId = 0x504C4D53;  // 'PLMS', set by migration 1
constexpr int kBusyTimeoutMs = 5000;

sqlite3* handle(void* db, const std::string& path) {
  if (!db)
    throw Error(path.empty() ? std::string("map store: used after it was moved from") : path + ": map store is closed");
  return static_cast<sqlite3*>(db);
}

std::int64_t pragma_int(sqlite3* db, const std::string& path, const char* sql) {
  Stmt st(db, path, sql);
  return st.step() ? st.int64(0) : 0;
}

bool valid_map_name(const std::string& name) {
  if (name.empty() || name.size() > 64) return false;
  for (char c : name) {
    bool ok =
        (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_' || c == '.' || c == '-';
    if (!ok) return false;
  }
  return true;
}

VersionState parse_state(const std::string& s, const std::string& path) {
  if (s == "staged") return VersionState::Staged;
  if (s == "published") return VersionState::Published;
  if (s == "retired") return VersionState::Retired;
  throw Error(path + ": unexpected version state \"" + s + "\" in the database");
}

std::string num(std::int64_t v) { return std::to_string(v); }

// ---- maps ----------------------------------------------------------------------------------------

constexpr const char* kMapColumns =
    "SELECT id, name, origin_lat, origin_lon, origin_alt, tile_size, voxel_size, current_version, created FROM maps ";

MapInfo read_map(const Stmt& st) {
  MapInfo m;
  m.id = st.int64(0);
  m.name = st.text(1);
  m.origin = GeoPoint{st.real(2), st.real(3), st.real(4)};
  m.tile_size = st.real(5);
  m.voxel_size = st.real(6);
  m.current = st.opt_int64(7);
  m.created = st.text(8);
  return m;
}

std::optional<MapInfo> find_map_row(sqlite3* db, const std::string& path, const std::string& name) {
  if (!valid_map_name(name)) return std::nullopt;
  Stmt st(db, path, (std::string(kMapColumns) + "WHERE name = ?1").c_str());
  st.bind_text(1, name);
  if (!st.step()) return std::nullopt;
  return read_map(st);
}

std::optional<std::int64_t> find_map_id(sqlite3* db, const std::string& path, const std::string& name) {
  if (!valid_map_name(name)) return std::nullopt;
  Stmt st(db, path, "SELECT id FROM maps WHERE name = ?1");
  st.bind_text(1, name);
  if (!st.step()) return std::nullopt;
  return st.int64(0);
}

std::int64_t require_map(sqlite3* db, const std::string& path, const std::string& name) {
  auto id = find_map_id(db, path, name);
  if (!id) throw Error(path + ": unknown map " + name);
  return *id;
}

std::optional<std::int64_t> current_version(sqlite3* db, const std::string& path, std::int64_t map_id) {
  Stmt st(db, path, "SELECT current_version FROM maps WHERE id = ?1");
  st.bind_int64(1, map_id);
  return st.step() ? st.opt_int64(0) : std::nullopt;
}

// ---- versions ------------------------------------------------------------------------------------

// Versions with their tile totals; append "WHERE ..." and the grouping is added by the callers.
constexpr const char* kVersionQuery =
    "SELECT v.number, v.parent, v.state, v.created, v.note, count(t.id), coalesce(sum(t.points), 0), "
    "coalesce(sum(t.bytes), 0) FROM versions AS v LEFT JOIN tiles AS t ON t.map_id = v.map_id AND t.version = "
    "v.number ";

VersionInfo read_version(const Stmt& st, const std::string& path) {
  VersionInfo v;
  v.number = st.int64(0);
  v.parent = st.opt_int64(1);
  v.state = parse_state(st.text(2), path);
  v.created = st.text(3);
  v.note = st.text(4);
  v.tiles = st.int64(5);
  v.points = st.int64(6);
  v.bytes = st.int64(7);
  return v;
}

std::optional<VersionInfo> find_version_row(sqlite3* db, const std::string& path, std::int64_t map_id,
                                            std::int64_t number) {
  Stmt st(db, path, (std::string(kVersionQuery) + "WHERE v.map_id = ?1 AND v.number = ?2 GROUP BY v.id").c_str());
  st.bind_int64(1, map_id).bind_int64(2, number);
  if (!st.step()) return std::nullopt;
  return read_version(st, path);
}

std::optional<VersionState> version_state(sqlite3* db, const std::string& path, std::int64_t map_id,
                                          std::int64_t number) {
  Stmt st(db, path, "SELECT state FROM versions WHERE map_id = ?1 AND number = ?2");
  st.bind_int64(1, map_id).bind_int64(2, number);
  if (!st.step()) return std::nullopt;
  return parse_state(st.text(0), path);
}

VersionState require_version(sqlite3* db, const std::string& path, const std::string& map, std::int64_t map_id,
                             std::int64_t number) {
  auto state = version_state(db, path, map_id, number);
  if (!state) throw Error(path + ": map " + map + " has no version " + num(number));
  return *state;
}

// Tile writes go to staged versions only.
void require_staged(sqlite3* db, const std::string& path, const std::string& map, std::int64_t map_id,
                    std::int64_t number) {
  VersionState state = require_version(db, path, map, map_id, number);
  if (state != VersionState::Staged)
    throw Error(path + ": map " + map + " version " + num(number) + " is " + state_name(state) +
                ": tiles can only be changed in a staged version (create a new version)");
}

// ---- tiles ---------------------------------------------------------------------------------------

constexpr const char* kTileColumns =
    "SELECT t.tx, t.ty, t.hash, t.points, t.bytes, t.min_x, t.min_y, t.min_z, t.max_x, t.max_y, t.max_z "
    "FROM tiles AS t ";

TileRecord read_tile(const Stmt& st) {
  TileRecord r;
  r.key = TileKey{static_cast<std::int32_t>(st.int64(0)), static_cast<std::int32_t>(st.int64(1))};
  r.hash = st.text(2);
  r.points = st.int64(3);
  r.bytes = st.int64(4);
  r.min_x = st.real(5);
  r.min_y = st.real(6);
  r.min_z = st.real(7);
  r.max_x = st.real(8);
  r.max_y = st.real(9);
  r.max_z = st.real(10);
  return r;
}

std::optional<std::string> tile_hash(sqlite3* db, const std::string& path, std::int64_t map_id, std::int64_t version,
                                     const TileKey& key) {
  Stmt st(db, path, "SELECT hash FROM tiles WHERE map_id = ?1 AND version = ?2 AND tx = ?3 AND ty = ?4");
  st.bind_int64(1, map_id).bind_int64(2, version).bind_int64(3, key.tx).bind_int64(4, key.ty);
  if (!st.step()) return std::nullopt;
  return st.text(0);
}

// Deletes a blob that no tile uses any more.
void drop_blob_if_unused(sqlite3* db, const std::string& path, const std::string& hash) {
  Stmt st(db, path, "DELETE FROM blobs WHERE hash = ?1 AND NOT EXISTS (SELECT 1 FROM tiles WHERE hash = ?1)");
  st.bind_text(1, hash).run();
}

std::string hex(const unsigned char* p, std::size_t n) {
  static const char digits[] = "0123456789abcdef";
  std::string out(2 * n, '0');
  for (std::size_t i = 0; i < n; ++i) {
    out[2 * i] = digits[p[i] >> 4];
    out[2 * i + 1] = digits[p[i] & 0xF];
  }
  return out;
}

// ---- opening and migrating -----------------------------------------------------------------------

void migrate(sqlite3* db, const std::string& path) {
  const int latest = Store::latest_schema_version();
  // Foreign keys stay off while migrating (a later migration may rebuild a table, which the
  // enforcement would block); each migration checks them before it commits.
  exec(db, path, "PRAGMA foreign_keys = OFF");
  for (const Migration& m : kMigrations) {
    if (pragma_int(db, path, "PRAGMA user_version") >= m.number) continue;
    WriteScope tx(db, path);
    // Another connection may have migrated while this one waited for the write lock.
    std::int64_t now = pragma_int(db, path, "PRAGMA user_version");
    if (now > latest)
      throw Error(path + ": the map store has schema version " + num(now) + ", newer than this build knows (" +
                  num(latest) + "): upgrade the PointLocalization software");
    if (now >= m.number) continue;
    char* err = nullptr;
    if (sqlite3_exec(db, m.sql, nullptr, nullptr, &err) != SQLITE_OK) {
      std::string msg = err ? err : sqlite3_errmsg(db);
      sqlite3_free(err);
      throw Error(path + ": schema migration " + m.name + " failed: " + msg);
    }
    {
      Stmt fk(db, path, "PRAGMA foreign_key_check");
      if (fk.step())
        throw Error(path + ": schema migration " + m.name + " left a foreign key violation in table " + fk.text(0));
    }
    // PRAGMA takes no bound parameters; the number is this build's own integer.
    exec(db, path, ("PRAGMA user_version = " + num(m.number)).c_str());
    tx.commit();
  }
  exec(db, path, "PRAGMA foreign_keys = ON");
}

}  // namespace

const char* state_name(VersionState s) {
  switch (s) {
    case VersionState::Staged:
      return "staged";
    case VersionState::Published:
      return "published";
    case VersionState::Retired:
      return "retired";
  }
  return "unknown";
}

const char* role_name(Role r) {
  switch (r) {
    case Role::Read:
      return "read";
    case Role::Upload:
      return "upload";
    case Role::Admin:
      return "admin";
  }
  return "unknown";
}

std::optional<Role> parse_role(std::string_view name) {
  if (name == "read") return Role::Read;
  if (name == "upload") return Role::Upload;
  if (name == "admin") return Role::Admin;
  return std::nullopt;
}

std::string content_hash(std::string_view bytes) {
  unsigned char md[EVP_MAX_MD_SIZE];
  unsigned int n = 0;
  if (EVP_Digest(bytes.data(), bytes.size(), md, &n, EVP_sha256(), nullptr) != 1)
    throw Error("SHA-256 failed (OpenSSL EVP_Digest)");
  return hex(md, n);
}

int Store::latest_schema_version() { return kMigrations[std::size(kMigrations) - 1].number; }

Store::Store(std::string path) : path_(std::move(path)) {}

Store::Store(Store&& o) noexcept : path_(std::move(o.path_)), db_(std::exchange(o.db_, nullptr)) {}

Store& Store::operator=(Store&& o) noexcept {
  if (this != &o) {
    if (db_) sqlite3_close_v2(static_cast<sqlite3*>(db_));
    path_ = std::move(o.path_);
    db_ = std::exchange(o.db_, nullptr);
  }
  return *this;
}

Store::~Store() {
  if (db_) sqlite3_close_v2(static_cast<sqlite3*>(db_));
}

Store Store::open(const std::string& path, bool create) {
  if (path.empty()) throw Error("map store: empty database path");
  Store store(path);
  sqlite3* db = nullptr;
  int flags = SQLITE_OPEN_READWRITE | (create ? SQLITE_OPEN_CREATE : 0);
  int rc = sqlite3_open_v2(path.c_str(), &db, flags, nullptr);
  store.db_ = db;  // closed by ~Store even when opening failed
  if (rc != SQLITE_OK) {
    std::string msg = db ? sqlite3_errmsg(db) : sqlite3_errstr(rc);
    throw Error(path + ": cannot open the map store: " + msg + (create ? "" : " (does the file exist?)"));
  }
  sqlite3_extended_result_codes(db, 1);
  sqlite3_busy_timeout(db, kBusyTimeoutMs);
  if (sqlite3_db_readonly(db, "main") == 1)
    throw Error(path + ": the map store is read-only (check the permissions of the file and its folder)");

  // The first read of the file: this is where a file that is not SQLite shows. One statement, so
  // the three values come from one snapshot (another connection may be migrating right now).
  std::int64_t app_id = 0, user_version = 0, tables = 0;
  {
    sqlite3_stmt* st = nullptr;
    rc = sqlite3_prepare_v2(db,
                            "SELECT a.application_id, u.user_version, "
                            "(SELECT count(*) FROM sqlite_schema WHERE type = 'table') "
                            "FROM pragma_application_id AS a, pragma_user_version AS u",
                            -1, &st, nullptr);
    if (rc == SQLITE_OK) rc = sqlite3_step(st);
    if (rc == SQLITE_ROW) {
      app_id = sqlite3_column_int64(st, 0);
      user_version = sqlite3_column_int64(st, 1);
      tables = sqlite3_column_int64(st, 2);
    }
    sqlite3_finalize(st);
    if ((rc & 0xFF) == SQLITE_NOTADB)
      throw Error(path + ": not a SQLite database (" + sqlite3_errmsg(db) + "); is this the right file?");
    if (rc != SQLITE_ROW) fail(db, path, "reading the database header");
  }
  if (app_id != 0 && app_id != kApplicationId)
    throw Error(path + ": a SQLite database of another application (application_id " + num(app_id) +
                "), not a map store");
  if (user_version > latest_schema_version())
    throw Error(path + ": the map store has schema version " + num(user_version) + ", newer than this build knows (" +
                num(latest_schema_version()) + "): upgrade the PointLocalization software");
  if (user_version == 0 && tables > 0)
    throw Error(path + ": a SQLite database that is not a map store (it has tables but no schema version)");
  if (user_version > 0 && app_id != kApplicationId)
    throw Error(path + ": a SQLite database that is not a map store (application_id " + num(app_id) + ")");

  // WAL: readers and one writer at a time, across threads and processes. Persistent in the file.
  {
    Stmt st(db, path, "PRAGMA journal_mode = WAL");
    std::string mode = st.step() ? st.text(0) : "";
    if (mode != "wal" && path != ":memory:")
      throw Error(path + ": cannot switch the map store to WAL journal mode (journal_mode is \"" + mode +
                  "\"; WAL needs a local file system)");
  }
  exec(db, path, "PRAGMA synchronous = NORMAL");
  migrate(db, path);  // ends with foreign_keys = ON
  return store;
}

int Store::schema_version() const {
  return static_cast<int>(pragma_int(handle(db_, path_), path_, "PRAGMA user_version"));
}

// ---- maps ----------------------------------------------------------------------------------------

MapInfo Store::create_map(const std::string& name, const GeoPoint& origin, double tile_size, double voxel_size) {
  sqlite3* db = handle(db_, path_);
  if (!valid_map_name(name))
    throw Error(path_ + ": invalid map name \"" + name + "\": use 1 to 64 of A-Z a-z 0-9 _ . -");
  if (!(origin.lat_deg >= -90 && origin.lat_deg <= 90) || !(origin.lon_deg >= -180 && origin.lon_deg <= 180) ||
      !std::isfinite(origin.alt_m))
    throw Error(path_ + ": map " + name +
                ": the origin must be a latitude in [-90, 90], a longitude in [-180, 180] "
                "and a finite altitude (degrees, metres)");
  if (!(tile_size > 0) || !std::isfinite(tile_size) || !(voxel_size > 0) || !std::isfinite(voxel_size))
    throw Error(path_ + ": map " + name + ": tile and voxel sizes must be positive numbers of metres");
  WriteScope tx(db, path_);
  if (find_map_id(db, path_, name)) throw Error(path_ + ": map " + name + " already exists");
  Stmt ins(db, path_,
           "INSERT INTO maps (name, origin_lat, origin_lon, origin_alt, tile_size, voxel_size) "
           "VALUES (?1, ?2, ?3, ?4, ?5, ?6)");
  ins.bind_text(1, name)
      .bind_double(2, origin.lat_deg)
      .bind_double(3, origin.lon_deg)
      .bind_double(4, origin.alt_m)
      .bind_double(5, tile_size)
      .bind_double(6, voxel_size)
      .run();
  auto info = find_map_row(db, path_, name);
  if (!info) throw Error(path_ + ": map " + name + " vanished after it was created");
  tx.commit();
  return *info;
}

std::optional<MapInfo> Store::find_map(const std::string& name) const {
  return find_map_row(handle(db_, path_), path_, name);
}

std::vector<MapInfo> Store::list_maps() const {
  Stmt st(handle(db_, path_), path_, (std::string(kMapColumns) + "ORDER BY name").c_str());
  std::vector<MapInfo> out;
  while (st.step()) out.push_back(read_map(st));
  return out;
}

// ---- versions ------------------------------------------------------------------------------------

VersionInfo Store::create_version(const std::string& map, std::optional<std::int64_t> parent, const std::string& note) {
  sqlite3* db = handle(db_, path_);
  WriteScope tx(db, path_);
  std::int64_t map_id = require_map(db, path_, map);
  if (parent) {
    require_version(db, path_, map, map_id, *parent);
  } else {
    parent = current_version(db, path_, map_id);  // none before the first publish: an empty version
  }
  std::int64_t number = 1;
  {
    Stmt st(db, path_, "SELECT coalesce(max(number), 0) + 1 FROM versions WHERE map_id = ?1");
    st.bind_int64(1, map_id);
    if (st.step()) number = st.int64(0);
  }
  Stmt(db, path_, "INSERT INTO versions (map_id, number, parent, note) VALUES (?1, ?2, ?3, ?4)")
      .bind_int64(1, map_id)
      .bind_int64(2, number)
      .bind_opt_int64(3, parent)
      .bind_text(4, note)
      .run();
  if (parent) {
    // Rows only: the copies point at the same blobs. The R*Tree entries come from the insert trigger.
    Stmt(db, path_,
         "INSERT INTO tiles (map_id, version, tx, ty, hash, points, bytes, min_x, min_y, min_z, max_x, max_y, max_z) "
         "SELECT map_id, ?3, tx, ty, hash, points, bytes, min_x, min_y, min_z, max_x, max_y, max_z FROM tiles "
         "WHERE map_id = ?1 AND version = ?2 ORDER BY tx, ty")
        .bind_int64(1, map_id)
        .bind_int64(2, *parent)
        .bind_int64(3, number)
        .run();
  }
  auto info = find_version_row(db, path_, map_id, number);
  if (!info) throw Error(path_ + ": map " + map + " version " + num(number) + " vanished after it was created");
  tx.commit();
  return *info;
}

std::optional<VersionInfo> Store::find_version(const std::string& map, std::int64_t number) const {
  sqlite3* db = handle(db_, path_);
  auto map_id = find_map_id(db, path_, map);
  if (!map_id) return std::nullopt;
  return find_version_row(db, path_, *map_id, number);
}

std::vector<VersionInfo> Store::list_versions(const std::string& map) const {
  sqlite3* db = handle(db_, path_);
  std::vector<VersionInfo> out;
  auto map_id = find_map_id(db, path_, map);
  if (!map_id) return out;
  Stmt st(db, path_, (std::string(kVersionQuery) + "WHERE v.map_id = ?1 GROUP BY v.id ORDER BY v.number").c_str());
  st.bind_int64(1, *map_id);
  while (st.step()) out.push_back(read_version(st, path_));
  return out;
}

void Store::publish(const std::string& map, std::int64_t number) {
  sqlite3* db = handle(db_, path_);
  WriteScope tx(db, path_);  // one IMMEDIATE transaction (a savepoint inside a Transaction)
  std::int64_t map_id = require_map(db, path_, map);
  VersionState state = require_version(db, path_, map, map_id, number);
  if (state != VersionState::Staged)
    throw Error(path_ + ": map " + map + " version " + num(number) + " is " + state_name(state) +
                ": only a staged version can be published");
  auto old = current_version(db, path_, map_id);
  // Retire the old one first: the schema allows one published version per map.
  if (old) {
    Stmt(db, path_, "UPDATE versions SET state = 'retired' WHERE map_id = ?1 AND number = ?2")
        .bind_int64(1, map_id)
        .bind_int64(2, *old)
        .run();
  }
  Stmt(db, path_,
       "UPDATE versions SET state = 'published', published = strftime('%Y-%m-%dT%H:%M:%fZ', 'now'), replaces = ?3 "
       "WHERE map_id = ?1 AND number = ?2")
      .bind_int64(1, map_id)
      .bind_int64(2, number)
      .bind_opt_int64(3, old)
      .run();
  Stmt(db, path_, "UPDATE maps SET current_version = ?2 WHERE id = ?1")
      .bind_int64(1, map_id)
      .bind_int64(2, number)
      .run();
  tx.commit();
}

std::int64_t Store::rollback(const std::string& map) {
  sqlite3* db = handle(db_, path_);
  WriteScope tx(db, path_);
  std::int64_t map_id = require_map(db, path_, map);
  auto cur = current_version(db, path_, map_id);
  if (!cur) throw Error(path_ + ": map " + map + " has no published version to roll back");
  std::optional<std::int64_t> prev;
  {
    Stmt st(db, path_, "SELECT replaces FROM versions WHERE map_id = ?1 AND number = ?2");
    st.bind_int64(1, map_id).bind_int64(2, *cur);
    if (st.step()) prev = st.opt_int64(0);
  }
  if (!prev)
    throw Error(path_ + ": map " + map + ": version " + num(*cur) +
                " was the first version published; there is no earlier one to roll back to");
  VersionState prev_state = require_version(db, path_, map, map_id, *prev);
  if (prev_state != VersionState::Retired)
    throw Error(path_ + ": map " + map + ": cannot roll back to version " + num(*prev) + ", it is " +
                state_name(prev_state));
  Stmt(db, path_, "UPDATE versions SET state = 'retired' WHERE map_id = ?1 AND number = ?2")
      .bind_int64(1, map_id)
      .bind_int64(2, *cur)
      .run();
  Stmt(db, path_, "UPDATE versions SET state = 'published' WHERE map_id = ?1 AND number = ?2")
      .bind_int64(1, map_id)
      .bind_int64(2, *prev)
      .run();
  Stmt(db, path_, "UPDATE maps SET current_version = ?2 WHERE id = ?1")
      .bind_int64(1, map_id)
      .bind_int64(2, *prev)
      .run();
  tx.commit();
  return *prev;
}

// ---- tiles ---------------------------------------------------------------------------------------

TileRecord Store::put_tile(const std::string& map, std::int64_t version, const TileKey& key,
                           std::string_view draco_bytes, std::int64_t points, double min_x, double min_y, double min_z,
                           double max_x, double max_y, double max_z) {
  sqlite3* db = handle(db_, path_);
  const std::string where =
      path_ + ": map " + map + " version " + num(version) + " tile (" + num(key.tx) + ", " + num(key.ty) + ")";
  if (draco_bytes.empty()) throw Error(where + ": empty tile data");
  if (points < 0) throw Error(where + ": negative point count");
  for (double v : {min_x, min_y, min_z, max_x, max_y, max_z})
    if (!std::isfinite(v)) throw Error(where + ": bounds must be finite numbers");
  if (!(min_x <= max_x && min_y <= max_y && min_z <= max_z)) throw Error(where + ": bounds have min > max");

  TileRecord rec;
  rec.key = key;
  rec.hash = content_hash(draco_bytes);
  rec.points = points;
  rec.bytes = static_cast<std::int64_t>(draco_bytes.size());
  rec.min_x = min_x, rec.min_y = min_y, rec.min_z = min_z;
  rec.max_x = max_x, rec.max_y = max_y, rec.max_z = max_z;

  WriteScope tx(db, path_);
  std::int64_t map_id = require_map(db, path_, map);
  require_staged(db, path_, map, map_id, version);
  auto old_hash = tile_hash(db, path_, map_id, version, key);
  // The blob once per content: a second tile with the same bytes only adds a row.
  Stmt(db, path_, "INSERT INTO blobs (hash, bytes, size) VALUES (?1, ?2, ?3) ON CONFLICT (hash) DO NOTHING")
      .bind_text(1, rec.hash)
      .bind_blob_static(2, draco_bytes)
      .bind_int64(3, rec.bytes)
      .run();
  // Same key: update the row in place (same id), and not at all when nothing changed.
  Stmt(db, path_,
       "INSERT INTO tiles (map_id, version, tx, ty, hash, points, bytes, min_x, min_y, min_z, max_x, max_y, max_z) "
       "VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12, ?13) "
       "ON CONFLICT (map_id, version, tx, ty) DO UPDATE SET hash = excluded.hash, points = excluded.points, "
       "bytes = excluded.bytes, min_x = excluded.min_x, min_y = excluded.min_y, min_z = excluded.min_z, "
       "max_x = excluded.max_x, max_y = excluded.max_y, max_z = excluded.max_z "
       "WHERE (hash, points, bytes, min_x, min_y, min_z, max_x, max_y, max_z) IS NOT "
       "(excluded.hash, excluded.points, excluded.bytes, excluded.min_x, excluded.min_y, excluded.min_z, "
       "excluded.max_x, excluded.max_y, excluded.max_z)")
      .bind_int64(1, map_id)
      .bind_int64(2, version)
      .bind_int64(3, key.tx)
      .bind_int64(4, key.ty)
      .bind_text(5, rec.hash)
      .bind_int64(6, rec.points)
      .bind_int64(7, rec.bytes)
      .bind_double(8, min_x)
      .bind_double(9, min_y)
      .bind_double(10, min_z)
      .bind_double(11, max_x)
      .bind_double(12, max_y)
      .bind_double(13, max_z)
      .run();
  if (old_hash && *old_hash != rec.hash) drop_blob_if_unused(db, path_, *old_hash);
  tx.commit();
  return rec;
}

bool Store::delete_tile(const std::string& map, std::int64_t version, const TileKey& key) {
  sqlite3* db = handle(db_, path_);
  WriteScope tx(db, path_);
  std::int64_t map_id = require_map(db, path_, map);
  require_staged(db, path_, map, map_id, version);
  auto hash = tile_hash(db, path_, map_id, version, key);
  if (!hash) return false;
  Stmt(db, path_, "DELETE FROM tiles WHERE map_id = ?1 AND version = ?2 AND tx = ?3 AND ty = ?4")
      .bind_int64(1, map_id)
      .bind_int64(2, version)
      .bind_int64(3, key.tx)
      .bind_int64(4, key.ty)
      .run();
  drop_blob_if_unused(db, path_, *hash);
  tx.commit();
  return true;
}

std::optional<TileRecord> Store::find_tile(const std::string& map, std::int64_t version, const TileKey& key) const {
  sqlite3* db = handle(db_, path_);
  auto map_id = find_map_id(db, path_, map);
  if (!map_id) return std::nullopt;
  Stmt st(db, path_,
          (std::string(kTileColumns) + "WHERE t.map_id = ?1 AND t.version = ?2 AND t.tx = ?3 AND t.ty = ?4").c_str());
  st.bind_int64(1, *map_id).bind_int64(2, version).bind_int64(3, key.tx).bind_int64(4, key.ty);
  if (!st.step()) return std::nullopt;
  return read_tile(st);
}

std::vector<TileRecord> Store::list_tiles(const std::string& map, std::int64_t version) const {
  sqlite3* db = handle(db_, path_);
  std::vector<TileRecord> out;
  auto map_id = find_map_id(db, path_, map);
  if (!map_id) return out;
  Stmt st(db, path_,
          (std::string(kTileColumns) + "WHERE t.map_id = ?1 AND t.version = ?2 ORDER BY t.tx, t.ty").c_str());
  st.bind_int64(1, *map_id).bind_int64(2, version);
  while (st.step()) out.push_back(read_tile(st));
  return out;
}

std::vector<TileRecord> Store::tiles_in_box(const std::string& map, std::int64_t version, double min_x, double min_y,
                                            double max_x, double max_y) const {
  sqlite3* db = handle(db_, path_);
  std::vector<TileRecord> out;
  if (!(min_x <= max_x && min_y <= max_y)) return out;  // inverted or NaN: nothing
  auto map_id = find_map_id(db, path_, map);
  if (!map_id) return out;
  // CROSS JOIN keeps the R*Tree as the outer loop (SQLite does not reorder it), so the search is
  // spatial first; the R*Tree's float32 boxes are rounded outwards, hence the exact re-check on
  // tiles' own bounds. The R*Tree holds every version's tiles; the map/version filter follows.
  Stmt st(db, path_,
          "SELECT t.tx, t.ty, t.hash, t.points, t.bytes, t.min_x, t.min_y, t.min_z, t.max_x, t.max_y, t.max_z "
          "FROM tile_rtree AS r CROSS JOIN tiles AS t ON t.id = r.id "
          "WHERE r.min_x <= ?5 AND r.max_x >= ?3 AND r.min_y <= ?6 AND r.max_y >= ?4 "
          "AND t.map_id = ?1 AND t.version = ?2 "
          "AND t.min_x <= ?5 AND t.max_x >= ?3 AND t.min_y <= ?6 AND t.max_y >= ?4 "
          "ORDER BY t.tx, t.ty");
  st.bind_int64(1, *map_id)
      .bind_int64(2, version)
      .bind_double(3, min_x)
      .bind_double(4, min_y)
      .bind_double(5, max_x)
      .bind_double(6, max_y);
  while (st.step()) out.push_back(read_tile(st));
  return out;
}

std::optional<std::string> Store::blob(const std::string& hash) const {
  Stmt st(handle(db_, path_), path_, "SELECT bytes FROM blobs WHERE hash = ?1");
  st.bind_text(1, hash);
  if (!st.step()) return std::nullopt;
  return st.blob(0);
}

bool Store::has_blob(const std::string& hash) const {
  Stmt st(handle(db_, path_), path_, "SELECT 1 FROM blobs WHERE hash = ?1");
  st.bind_text(1, hash);
  return st.step();
}

// ---- tokens and the upload log -------------------------------------------------------------------

void Store::add_token(const std::string& token, Role role, const std::string& note) {
  sqlite3* db = handle(db_, path_);
  if (token.empty()) throw Error(path_ + ": empty token");
  if (!parse_role(role_name(role))) throw Error(path_ + ": invalid role " + num(static_cast<int>(role)));
  std::string hash = content_hash(token);
  WriteScope tx(db, path_);
  {
    Stmt st(db, path_, "SELECT 1 FROM tokens WHERE hash = ?1");
    st.bind_text(1, hash);
    // Never echo the token itself into a message.
    if (st.step()) throw Error(path_ + ": this token is already registered");
  }
  Stmt(db, path_, "INSERT INTO tokens (hash, role, note) VALUES (?1, ?2, ?3)")
      .bind_text(1, hash)
      .bind_text(2, role_name(role))
      .bind_text(3, note)
      .run();
  tx.commit();
}

std::optional<Role> Store::check_token(const std::string& token) const {
  sqlite3* db = handle(db_, path_);
  if (token.empty()) return std::nullopt;
  Stmt st(db, path_, "SELECT role FROM tokens WHERE hash = ?1");
  st.bind_text(1, content_hash(token));
  if (!st.step()) return std::nullopt;
  return parse_role(st.text(0));
}

void Store::log_upload(const std::string& map, std::optional<std::int64_t> version, const std::string& action,
                       const std::string& detail, const std::string& who) {
  sqlite3* db = handle(db_, path_);
  if (action.empty()) throw Error(path_ + ": upload log entry without an action");
  Stmt(db, path_, "INSERT INTO upload_log (map, version, action, detail, who) VALUES (?1, ?2, ?3, ?4, ?5)")
      .bind_text(1, map)
      .bind_opt_int64(2, version)
      .bind_text(3, action)
      .bind_text(4, detail)
      .bind_text(5, who)
      .run();
}

std::vector<Store::LogEntry> Store::upload_log(const std::string& map) const {
  Stmt st(handle(db_, path_), path_,
          "SELECT id, at, map, version, action, detail, who FROM upload_log WHERE map = ?1 ORDER BY id");
  st.bind_text(1, map);
  std::vector<LogEntry> out;
  while (st.step()) {
    LogEntry e;
    e.id = st.int64(0);
    e.at = st.text(1);
    e.map = st.text(2);
    e.version = st.opt_int64(3);
    e.action = st.text(4);
    e.detail = st.text(5);
    e.who = st.text(6);
    out.push_back(std::move(e));
  }
  return out;
}

// ---- transactions and maintenance ----------------------------------------------------------------

Store::Transaction::Transaction(Store& store) : store_(store) {
  nested_ = detail::begin_write(handle(store_.db_, store_.path_), store_.path_, "pl_transaction");
}

void Store::Transaction::commit() {
  if (done_) throw Error(store_.path_ + ": transaction committed twice");
  detail::commit_write(handle(store_.db_, store_.path_), store_.path_, "pl_transaction", nested_);
  done_ = true;
}

Store::Transaction::~Transaction() {
  if (!done_ && store_.db_)
    detail::rollback_write_quietly(static_cast<sqlite3*>(store_.db_), "pl_transaction", nested_);
}

std::int64_t Store::database_bytes() const {
  sqlite3* db = handle(db_, path_);
  return pragma_int(db, path_, "PRAGMA page_count") * pragma_int(db, path_, "PRAGMA page_size");
}

bool Store::integrity_ok() const {
  sqlite3* db = handle(db_, path_);
  try {
    {
      Stmt st(db, path_, "PRAGMA integrity_check");
      if (!st.step() || st.text(0) != "ok" || st.step()) return false;
    }
    {
      Stmt st(db, path_, "PRAGMA foreign_key_check");
      if (st.step()) return false;
    }
    {
      Stmt st(db, path_, "SELECT rtreecheck('tile_rtree')");
      if (!st.step() || st.text(0) != "ok") return false;
    }
    {
      // One R*Tree entry per tile, with a box that contains the tile's xy box.
      Stmt st(db, path_,
              "SELECT (SELECT count(*) FROM tiles) = (SELECT count(*) FROM tile_rtree) AND NOT EXISTS ("
              "SELECT 1 FROM tiles AS t WHERE NOT EXISTS (SELECT 1 FROM tile_rtree AS r WHERE r.id = t.id "
              "AND r.min_x <= t.min_x AND r.max_x >= t.max_x AND r.min_y <= t.min_y AND r.max_y >= t.max_y))");
      if (!st.step() || st.int64(0) != 1) return false;
    }
  } catch (const Error&) {
    int code = sqlite3_errcode(db) & 0xFF;
    if (code == SQLITE_CORRUPT || code == SQLITE_NOTADB) return false;
    throw;
  }
  return true;
}

}  // namespace pl::store
