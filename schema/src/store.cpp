// The map store's SQLite backend: opening and migrating, maps and versions (tiles, blobs, tokens and the
// upload log: store_tiles.cpp; places: store_places.cpp; change reports: store_reports.cpp). See store.hpp for the semantics and
// schema/NNN_*.sql for the tables. All values reach SQL through bound parameters; the only SQL built from strings are
// PRAGMAs and savepoints whose text comes from this file (integers and fixed identifiers).
#include "pl/schema/store.hpp"

#include "pl/schema/api_rules.hpp"

#include <openssl/evp.h>

#include <cmath>
#include <iterator>
#include <limits>
#include <map>
#include <mutex>
#include <utility>

#include "pl/common/error.hpp"
#include "pl/schema/detail/sqlite.hpp"
#include "store_internal.hpp"
#include "tile_row.hpp"

namespace pl::store {

namespace detail {

struct Migration {
  int number;
  const char* name;
  const char* sql;
};

// Generated at build time from schema/NNN_*.sql (see schema/CMakeLists.txt), in order 1, 2, ...
const Migration kMigrations[] = {
#include "pl_schema_migrations.inc"
};

// What messages call a store file, and the fixes they name.
const sqlite::FileKind kMapStore = {
    "map store",
    0x504C4D53,  // 'PLMS', set by migration 1
    "restore it from a backup, or rebuild it with pl-map",
    "is this the right file?",
    "upgrade the PointLocalization software",
};

std::int64_t pragma_int(const Db& db, const char* sql) { return sqlite::query_int(db, sql); }

std::string num(std::int64_t v) { return std::to_string(v); }

// "2024-05-01T10:11:12.345Z", as strftime('%Y-%m-%dT%H:%M:%fZ') writes every timestamp.
bool is_timestamp(const std::string& s) {
  static const char shape[] = "dddd-dd-ddTdd:dd:dd.dddZ";
  if (s.size() != sizeof(shape) - 1) return false;
  for (std::size_t i = 0; i < s.size(); ++i)
    if (shape[i] == 'd' ? !(s[i] >= '0' && s[i] <= '9') : s[i] != shape[i]) return false;
  return true;
}

// ---- values read from the file -------------------------------------------------------------------
// Every value is read through a checked Row (pl/schema/detail/sqlite.hpp) against what the schema
// promises; these are the store's own kinds of value.

std::string read_timestamp(const Row& row, int col, const char* column) {
  std::string s = row.text(col, column);
  if (!is_timestamp(s)) row.bad(column, "is not a UTC timestamp (YYYY-MM-DDTHH:MM:SS.sssZ)");
  return s;
}

VersionState read_state(const Row& row, int col, const char* column) {
  std::string s = row.text(col, column);
  if (s == "staged") return VersionState::Staged;
  if (s == "published") return VersionState::Published;
  if (s == "retired") return VersionState::Retired;
  row.bad(column, "is not one of staged, published, retired");
}


// ---- maps ----------------------------------------------------------------------------------------

// The last column says whether current_version names a published version of the map (the
// schema's triggers keep it so; a damaged file may point nowhere).
constexpr const char* kMapColumns =
    "SELECT id, name, origin_lat, origin_lon, origin_alt, tile_size, voxel_size, current_version, created, "
    "current_version IS NULL OR EXISTS (SELECT 1 FROM versions AS v WHERE v.map_id = maps.id AND "
    "v.number = maps.current_version AND v.state = 'published') FROM maps ";

MapInfo read_map(const Stmt& st) {
  Row row(st, "maps");
  MapInfo m;
  m.id = row.integer(0, "id");
  m.name = row.text(1, "name");
  if (!api::valid_map_name(m.name)) row.bad("name", "is not a valid map name");
  m.origin = GeoPoint{row.number(2, "origin_lat", -90, 90), row.number(3, "origin_lon", -180, 180),
                      row.number(4, "origin_alt")};
  m.tile_size = row.positive(5, "tile_size");
  m.voxel_size = row.positive(6, "voxel_size");
  m.current = row.opt_integer(7, "current_version", 1, kMaxInt64);
  m.created = read_timestamp(row, 8, "created");
  row.require(9, "map " + m.name + ": current_version " + (m.current ? num(*m.current) : "") +
                     " is not a published version of the map");
  return m;
}

std::optional<MapInfo> find_map_row(const Db& db, const std::string& name) {
  if (!api::valid_map_name(name)) return std::nullopt;
  Stmt st(db, (std::string(kMapColumns) + "WHERE name = ?1").c_str());
  st.bind_text(1, name);
  if (!st.step()) return std::nullopt;
  return read_map(st);
}

std::optional<std::int64_t> find_map_id(const Db& db, const std::string& name) {
  if (!api::valid_map_name(name)) return std::nullopt;
  Stmt st(db, "SELECT id FROM maps WHERE name = ?1");
  st.bind_text(1, name);
  if (!st.step()) return std::nullopt;
  return st.int64(0);
}

std::int64_t require_map(const Db& db, const std::string& name) {
  auto id = find_map_id(db, name);
  if (!id) throw Error(db.path() + ": unknown map " + name);
  return *id;
}

std::optional<std::int64_t> current_version(const Db& db, std::int64_t map_id) {
  Stmt st(db, "SELECT current_version FROM maps WHERE id = ?1");
  st.bind_int64(1, map_id);
  return st.step() ? Row(st, "maps").opt_integer(0, "current_version", 1, kMaxInt64) : std::nullopt;
}

// ---- versions ------------------------------------------------------------------------------------

// Versions with their tile totals; append "WHERE ..." and the grouping is added by the callers.
// The totals are total() (a double, exact below 2^53) rather than sum(), which fails with "integer
// overflow" on absurd counts; column 8 counts the tile rows whose points or bytes are not
// non-negative integers, column 9 says whether the parent exists.
constexpr const char* kVersionQuery =
    "SELECT v.number, v.parent, v.state, v.created, v.note, count(t.id), total(t.points), total(t.bytes), "
    "coalesce(sum(t.id IS NOT NULL AND (typeof(t.points) IS NOT 'integer' OR t.points < 0 OR "
    "typeof(t.bytes) IS NOT 'integer' OR t.bytes < 0)), 0), "
    "v.parent IS NULL OR EXISTS (SELECT 1 FROM versions AS p WHERE p.map_id = v.map_id AND p.number = v.parent) "
    "FROM versions AS v LEFT JOIN tiles AS t ON t.map_id = v.map_id AND t.version = v.number ";

// A total of non-negative integers computed as a double: exact, and within int64, below 2^53.
std::int64_t exact_total(const Row& row, int col, const char* column) {
  constexpr double kExact = 9007199254740992.0;  // 2^53
  return static_cast<std::int64_t>(row.number(col, column, 0, kExact));
}

VersionInfo read_version(const Stmt& st) {
  Row row(st, "versions");
  VersionInfo v;
  v.number = row.integer(0, "number", 1, kMaxInt64);
  v.parent = row.opt_integer(1, "parent", 1, kMaxInt64);
  v.state = read_state(row, 2, "state");
  v.created = read_timestamp(row, 3, "created");
  v.note = row.text(4, "note");
  Row tiles(st, "tiles");
  if (st.int64(8) != 0) tiles.bad("points", "or tiles.bytes is not a non-negative integer");
  v.tiles = tiles.integer(5, "(count)", 0, kMaxInt64);
  v.points = exact_total(tiles, 6, "points (total)");
  v.bytes = exact_total(tiles, 7, "bytes (total)");
  row.require(9, "version " + num(v.number) + " has parent " + (v.parent ? num(*v.parent) : "") +
                     ", which does not exist");
  return v;
}

std::optional<VersionInfo> find_version_row(const Db& db, std::int64_t map_id,
                                            std::int64_t number) {
  Stmt st(db, (std::string(kVersionQuery) + "WHERE v.map_id = ?1 AND v.number = ?2 GROUP BY v.id").c_str());
  st.bind_int64(1, map_id).bind_int64(2, number);
  if (!st.step()) return std::nullopt;
  return read_version(st);
}

std::optional<VersionState> version_state(const Db& db, std::int64_t map_id,
                                          std::int64_t number) {
  Stmt st(db, "SELECT state FROM versions WHERE map_id = ?1 AND number = ?2");
  st.bind_int64(1, map_id).bind_int64(2, number);
  if (!st.step()) return std::nullopt;
  return read_state(Row(st, "versions"), 0, "state");
}

VersionState require_version(const Db& db, const std::string& map, std::int64_t map_id,
                             std::int64_t number) {
  auto state = version_state(db, map_id, number);
  if (!state) throw Error(db.path() + ": map " + map + " has no version " + num(number));
  return *state;
}

// Writes of tiles and places go to staged versions only.
void require_staged(const Db& db, const std::string& map, std::int64_t map_id,
                    std::int64_t number, const char* what) {
  VersionState state = require_version(db, map, map_id, number);
  if (state != VersionState::Staged)
    throw Error(db.path() + ": map " + map + " version " + num(number) + " is " + state_name(state) +
                ": " + what + " can only be changed in a staged version (create a new version)");
}

// ---- tiles ---------------------------------------------------------------------------------------


TileRecord read_tile(const Stmt& st, int first) { return tile_row(Row(st, "tiles"), first); }

std::optional<std::string> tile_hash(const Db& db, std::int64_t map_id, std::int64_t version,
                                     const TileKey& key) {
  Stmt st(db, "SELECT hash FROM tiles WHERE map_id = ?1 AND version = ?2 AND tx = ?3 AND ty = ?4");
  st.bind_int64(1, map_id).bind_int64(2, version).bind_int64(3, key.tx).bind_int64(4, key.ty);
  if (!st.step()) return std::nullopt;
  return Row(st, "tiles").hash(0, "hash");
}

// Deletes a blob that no tile uses any more.
void drop_blob_if_unused(const Db& db, const std::string& hash) {
  Stmt st(db, "DELETE FROM blobs WHERE hash = ?1 AND NOT EXISTS (SELECT 1 FROM tiles WHERE hash = ?1)");
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

// The R*Tree's shadow tables (tile_rtree_node, ...): SQLite makes them, with text that may differ
// between SQLite versions, so only their presence is compared.
const std::vector<std::string> kShadowPrefixes = {"tile_rtree_"};

// The schema that migrations 1..version make, built once per version.
const sqlite::Schema& expected_schema(int version) {
  static std::mutex mutex;
  static std::map<int, sqlite::Schema> built;
  std::lock_guard<std::mutex> lock(mutex);
  auto it = built.find(version);
  if (it != built.end()) return it->second;
  std::vector<const char*> scripts;
  for (const Migration& m : kMigrations)
    if (m.number <= version) scripts.push_back(m.sql);
  return built.emplace(version, sqlite::schema_of(kMapStore, scripts, kShadowPrefixes)).first->second;
}

// The schema must be exactly the migrations' own for the file's schema version (check_schema says
// why). Released migrations are never edited, so the text SQLite keeps is byte for byte the
// migration's.
void check_schema(const Db& db, int version) {
  sqlite::check_schema(db, expected_schema(version),
                       "its schema is not the one of map store schema version " + num(version), kShadowPrefixes);
}

// Everything open checks before it writes anything (the switch to WAL, migrations), so that a file
// that fails a check is left exactly as it was. Opening a current WAL store writes nothing at all;
// when open will write, the whole file is checked first (PRAGMA quick_check reads every page: once
// per file, when it is migrated or switched to WAL, e.g. a restored backup).
void check_before_writing(const Db& db, bool create) {
  sqlite::ReadSnapshot snapshot(db);
  const sqlite::Header h = sqlite::read_header(db);
  sqlite::check_identity(db, h, Store::latest_schema_version());
  if (h.user_version == 0 && h.objects == 0) {
    // An empty database: nothing in it to check or to lose. Without `create` it was expected to be a
    // store, and an empty file is most likely one that lost its content.
    if (!create)
      throw Error(db.path() + ": the file is empty, not a map store (was it truncated?): restore it from a backup, or "
                              "create a store with pl-map");
    snapshot.end();
    return;
  }
  check_schema(db, static_cast<int>(h.user_version));
  if (sqlite::journal_mode(db) != "wal" || h.user_version < Store::latest_schema_version()) sqlite::quick_check(db);
  snapshot.end();
}

// Every pending migration in one transaction: a file that a later one fails on (damage only a write
// finds, say) is left exactly as it was, as a refused open promises, and no connection ever sees a
// schema between two versions.
void migrate(const Db& db) {
  const int latest = Store::latest_schema_version();
  if (pragma_int(db, "PRAGMA user_version") >= latest) return;
  // Foreign keys stay off while migrating (a later migration may rebuild a table, which the
  // enforcement would block); each migration checks them before the next.
  exec(db, "PRAGMA foreign_keys = OFF");
  WriteScope tx(db);
  // Another connection may have migrated while this one waited for the write lock.
  std::int64_t now = pragma_int(db, "PRAGMA user_version");
  if (now > latest) sqlite::refuse_newer(db, now, latest);
  for (const Migration& m : kMigrations) {
    if (now >= m.number) continue;
    char* err = nullptr;
    if (sqlite3_exec(db.get(), m.sql, nullptr, nullptr, &err) != SQLITE_OK) {
      std::string msg = err ? err : sqlite3_errmsg(db.get());
      sqlite3_free(err);
      throw Error(db.path() + ": schema migration " + m.name + " failed: " + msg);
    }
    {
      Stmt fk(db, "PRAGMA foreign_key_check");
      if (fk.step())
        throw Error(db.path() + ": schema migration " + m.name + " left a foreign key violation in table " +
                    fk.text(0));
    }
    // PRAGMA takes no bound parameters; the number is this build's own integer.
    exec(db, ("PRAGMA user_version = " + num(m.number)).c_str());
    now = m.number;
  }
  tx.commit();
  exec(db, "PRAGMA foreign_keys = ON");
}

}  // namespace detail

using namespace detail;

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
    case Role::Report:
      return "report";
    case Role::Upload:
      return "upload";
    case Role::Admin:
      return "admin";
  }
  return "unknown";
}

std::optional<Role> parse_role(std::string_view name) {
  if (name == "read") return Role::Read;
  if (name == "report") return Role::Report;
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

SqliteStore::SqliteStore(std::string path) : path_(std::move(path)), stmts_(std::make_unique<sqlite::StmtCache>()) {}

SqliteStore::~SqliteStore() {
  stmts_.reset();  // finalizes the kept statements: a connection closes only once they are gone
  if (db_) sqlite3_close_v2(static_cast<sqlite3*>(db_));
}

Db SqliteStore::conn() const { return sqlite::checked(db_, path_, kMapStore, stmts_.get()); }

std::unique_ptr<StoreBackend> detail::open_sqlite(const std::string& path, bool create) {
  auto store = std::make_unique<SqliteStore>(path);
  sqlite3* handle = nullptr;
  int flags = SQLITE_OPEN_READWRITE | (create ? SQLITE_OPEN_CREATE : 0);
  sqlite::configure_library();
  int rc = sqlite3_open_v2(path.c_str(), &handle, flags, nullptr);
  store->db_ = handle;  // closed by ~SqliteStore even when opening failed
  if (rc != SQLITE_OK) {
    std::string msg = handle ? sqlite3_errmsg(handle) : sqlite3_errstr(rc);
    throw Error(path + ": cannot open the map store: " + msg + (create ? "" : " (does the file exist?)"));
  }
  const Db db(handle, path, kMapStore);
  sqlite::prepare_connection(db);
  check_before_writing(db, create);
  sqlite::trust_schema(db);  // the schema is the migrations' own, or there is none yet
  sqlite::use_wal(db);
  migrate(db);  // ends with foreign_keys = ON
  return store;
}

int SqliteStore::schema_version() const {
  return static_cast<int>(pragma_int(conn(), "PRAGMA user_version"));
}

// ---- maps ----------------------------------------------------------------------------------------

MapInfo SqliteStore::create_map(const std::string& name, const GeoPoint& origin, double tile_size, double voxel_size) {
  const Db db = conn();
  WriteScope tx(db);
  if (find_map_id(db, name)) throw Error(path_ + ": map " + name + " already exists");
  Stmt ins(db,
           "INSERT INTO maps (name, origin_lat, origin_lon, origin_alt, tile_size, voxel_size) "
           "VALUES (?1, ?2, ?3, ?4, ?5, ?6)");
  ins.bind_text(1, name)
      .bind_double(2, origin.lat_deg)
      .bind_double(3, origin.lon_deg)
      .bind_double(4, origin.alt_m)
      .bind_double(5, tile_size)
      .bind_double(6, voxel_size)
      .run();
  auto info = find_map_row(db, name);
  if (!info) throw Error(path_ + ": map " + name + " vanished after it was created");
  tx.commit();
  return *info;
}

std::optional<MapInfo> SqliteStore::find_map(const std::string& name) const {
  return find_map_row(conn(), name);
}

std::vector<MapInfo> SqliteStore::list_maps() const {
  Stmt st(conn(), (std::string(kMapColumns) + "ORDER BY name").c_str());
  std::vector<MapInfo> out;
  while (st.step()) out.push_back(read_map(st));
  return out;
}

// ---- versions ------------------------------------------------------------------------------------

VersionInfo SqliteStore::create_version(const std::string& map, std::optional<std::int64_t> parent, const std::string& note) {
  const Db db = conn();
  WriteScope tx(db);
  std::int64_t map_id = require_map(db, map);
  if (parent) {
    require_version(db, map, map_id, *parent);
  } else {
    parent = current_version(db, map_id);  // none before the first publish: an empty version
  }
  std::int64_t number = 1;
  {
    Stmt st(db, "SELECT max(number) FROM versions WHERE map_id = ?1");
    st.bind_int64(1, map_id);
    if (st.step() && !st.is_null(0)) number = Row(st, "versions").integer(0, "number", 1, kMaxInt64 - 1) + 1;
  }
  Stmt(db, "INSERT INTO versions (map_id, number, parent, note) VALUES (?1, ?2, ?3, ?4)")
      .bind_int64(1, map_id)
      .bind_int64(2, number)
      .bind_opt_int64(3, parent)
      .bind_text(4, note)
      .run();
  if (parent) {
    // Rows only: the copies point at the same blobs. The R*Tree entries come from the insert trigger.
    Stmt(db,
         "INSERT INTO tiles (map_id, version, tx, ty, hash, points, bytes, min_x, min_y, min_z, max_x, max_y, max_z) "
         "SELECT map_id, ?3, tx, ty, hash, points, bytes, min_x, min_y, min_z, max_x, max_y, max_z FROM tiles "
         "WHERE map_id = ?1 AND version = ?2 ORDER BY tx, ty")
        .bind_int64(1, map_id)
        .bind_int64(2, *parent)
        .bind_int64(3, number)
        .run();
    // The places are one row of their own, bytes included.
    Stmt(db,
         "INSERT INTO places (map_id, version, hash, bytes, size) "
         "SELECT map_id, ?3, hash, bytes, size FROM places WHERE map_id = ?1 AND version = ?2")
        .bind_int64(1, map_id)
        .bind_int64(2, *parent)
        .bind_int64(3, number)
        .run();
  }
  auto info = find_version_row(db, map_id, number);
  if (!info) throw Error(path_ + ": map " + map + " version " + num(number) + " vanished after it was created");
  tx.commit();
  return *info;
}

std::optional<VersionInfo> SqliteStore::find_version(const std::string& map, std::int64_t number) const {
  const Db db = conn();
  auto map_id = find_map_id(db, map);
  if (!map_id) return std::nullopt;
  return find_version_row(db, *map_id, number);
}

std::vector<VersionInfo> SqliteStore::list_versions(const std::string& map) const {
  const Db db = conn();
  std::vector<VersionInfo> out;
  auto map_id = find_map_id(db, map);
  if (!map_id) return out;
  Stmt st(db, (std::string(kVersionQuery) + "WHERE v.map_id = ?1 GROUP BY v.id ORDER BY v.number").c_str());
  st.bind_int64(1, *map_id);
  while (st.step()) out.push_back(read_version(st));
  return out;
}

bool SqliteStore::publish(const std::string& map, std::int64_t number,
                          const std::optional<std::optional<std::int64_t>>& only_if_current, std::optional<std::int64_t> restores) {
  const Db db = conn();
  WriteScope tx(db);  // one IMMEDIATE transaction (a savepoint inside a Transaction)
  std::int64_t map_id = require_map(db, map);
  VersionState state = require_version(db, map, map_id, number);
  if (state != VersionState::Staged)
    throw Error(path_ + ": map " + map + " version " + num(number) + " is " + state_name(state) +
                ": only a staged version can be published");
  auto old = current_version(db, map_id);
  if (only_if_current && *only_if_current != old) return false;  // the write lock is held: no publish can come between
  std::optional<std::int64_t> step = old;
  if (restores) {  // a rollback: a further rollback goes where one from the restored version would
    require_version(db, map, map_id, *restores);
    Stmt st(db, "SELECT replaces FROM versions WHERE map_id = ?1 AND number = ?2");
    st.bind_int64(1, map_id).bind_int64(2, *restores);
    step.reset();
    if (st.step()) step = Row(st, "versions").opt_integer(0, "replaces", 1, kMaxInt64);
  }
  // Retire the old one first: the schema allows one published version per map.
  if (old) {
    Stmt(db, "UPDATE versions SET state = 'retired' WHERE map_id = ?1 AND number = ?2")
        .bind_int64(1, map_id)
        .bind_int64(2, *old)
        .run();
  }
  Stmt(db,
       "UPDATE versions SET state = 'published', published = strftime('%Y-%m-%dT%H:%M:%fZ', 'now'), replaces = ?3 "
       "WHERE map_id = ?1 AND number = ?2")
      .bind_int64(1, map_id)
      .bind_int64(2, number)
      .bind_opt_int64(3, step)
      .run();
  Stmt(db, "UPDATE maps SET current_version = ?2 WHERE id = ?1")
      .bind_int64(1, map_id)
      .bind_int64(2, number)
      .run();
  tx.commit();
  return true;
}

std::int64_t SqliteStore::rollback_target(const std::string& map) const {
  const Db db = conn();
  std::int64_t map_id = require_map(db, map);
  auto cur = current_version(db, map_id);
  if (!cur) throw Error(path_ + ": map " + map + " has no published version to roll back");
  std::optional<std::int64_t> prev;
  {
    Stmt st(db, "SELECT replaces FROM versions WHERE map_id = ?1 AND number = ?2");
    st.bind_int64(1, map_id).bind_int64(2, *cur);
    if (st.step()) prev = Row(st, "versions").opt_integer(0, "replaces", 1, kMaxInt64);
  }
  if (!prev)
    throw Error(path_ + ": map " + map + ": version " + num(*cur) +
                " was the first version published, or restores its content: there is no earlier one to roll back to");
  VersionState prev_state = require_version(db, map, map_id, *prev);
  if (prev_state != VersionState::Retired)
    throw Error(path_ + ": map " + map + ": cannot roll back to version " + num(*prev) + ", it is " +
                state_name(prev_state));
  return *prev;
}

}  // namespace pl::store
