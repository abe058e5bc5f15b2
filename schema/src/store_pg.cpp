// The map store over PostgreSQL: connecting, checking and migrating the database, transactions,
// maps and versions (tiles, blobs, places, tokens, the upload log and maintenance:
// store_pg_tiles.cpp; change reports: store_pg_reports.cpp; values read back: store_pg_row.cpp). store_pg.hpp says how transactions
// and concurrency work. All values reach SQL as parameters of statements prepared once per
// connection; the only SQL sent as text is transaction control, the migrations and the checks at
// open (fixed text of this build).
#include "store_pg.hpp"

#include <charconv>
#include <cmath>
#include <cstring>
#include <iterator>
#include <limits>

#include "pl/common/error.hpp"
#include "pl/schema/api_rules.hpp"

namespace pl::store::detail {

namespace {

struct PgMigration {
  int number;
  const char* name;
  const char* sql;
};

// Generated at build time from schema/pg/NNN_*.sql (see schema/CMakeLists.txt), in order 1, 2, ...;
// as many as the SQLite migrations (checked there).
constexpr PgMigration kPgMigrations[] = {
#include "pl_schema_pg_migrations.inc"
};

constexpr int kPgLatest = kPgMigrations[std::size(kPgMigrations) - 1].number;

// The comment migration 1 puts on schema_migrations: what marks a database as a map store.
constexpr const char* kMarker = "PointLocalization map store (PLMS)";
// pg_advisory_xact_lock key of the migrations: 'PLMS'.
constexpr std::int64_t kMigrationLock = 0x504C4D53;

constexpr const char* kIfDamaged = "restore it from a backup, or rebuild it with pl-map";

std::string trimmed(std::string s) {
  while (!s.empty() && (s.back() == '\n' || s.back() == '\r' || s.back() == ' ')) s.pop_back();
  return s;
}

}  // namespace

// store::is_postgres_url is store_facade.cpp's (Store::open picks the engine with it).

// The URL as messages show it: a password in the user part or in a password= parameter is ***.
std::string redact_url(const std::string& url) {
  std::string out = url;
  const std::size_t start = out.find("://");
  if (start == std::string::npos) return out;
  const std::size_t host_start = start + 3;
  std::size_t end = out.find_first_of("/?#", host_start);
  if (end == std::string::npos) end = out.size();
  const std::size_t at = out.rfind('@', end);
  if (at != std::string::npos && at >= host_start) {
    const std::size_t colon = out.find(':', host_start);
    if (colon != std::string::npos && colon < at) out.replace(colon + 1, at - colon - 1, "***");
  }
  const std::size_t query = out.find('?');
  if (query != std::string::npos) {
    std::size_t i = query + 1;
    while (i < out.size()) {
      std::size_t amp = out.find_first_of("&#", i);
      if (amp == std::string::npos) amp = out.size();
      if (out.compare(i, 9, "password=") == 0) {
        out.replace(i + 9, amp - i - 9, "***");
        amp = i + 12;
      }
      if (amp >= out.size() || out[amp] == '#') break;
      i = amp + 1;
    }
  }
  return out;
}

std::unique_ptr<StoreBackend> open_postgres(const std::string& url, bool create) {
  return std::make_unique<PgStore>(url, create);
}

// ---- parameters and errors -----------------------------------------------------------------------

std::string pg_double(double v) {
  char buf[64];
  auto res = std::to_chars(buf, buf + sizeof(buf), v);
  return std::string(buf, res.ptr);
}

const char* pg_opt(const std::optional<std::string>& s) { return s ? s->c_str() : nullptr; }

std::optional<std::string> pg_opt_int(const std::optional<std::int64_t>& v) {
  if (!v) return std::nullopt;
  return std::to_string(*v);
}

std::string pg_num(std::int64_t v) { return std::to_string(v); }

void PgStore::damaged(const std::string& what) const {
  throw Error(name_ + ": the map store is damaged (" + what + "): " + kIfDamaged);
}

void PgStore::fail_connection(const std::exception& e) const {
  throw Error(name_ + ": the connection to the map store database failed: " + trimmed(e.what()) +
              " (is the PostgreSQL server running and reachable?)");
}

void PgStore::fail_sql(const pqxx::sql_error& e) const {
  // Damage PostgreSQL reports itself (data_corrupted, index_corrupted): the one message with the fix.
  const std::string state = e.sqlstate();
  if (state == "XX001" || state == "XX002") damaged(trimmed(e.what()));
  throw Error(name_ + ": " + trimmed(e.what()));
}

void PgStore::fail_other(const std::exception& e) const { throw Error(name_ + ": " + trimmed(e.what())); }

void PgStore::undo(Work& w, bool nested) const noexcept {
  try {
    w.exec(nested ? "ROLLBACK TO SAVEPOINT pl_call; RELEASE SAVEPOINT pl_call" : "ROLLBACK");
  } catch (...) {
    // The connection is gone or the transaction with it: the next call reports it.
  }
}

// ---- statements ----------------------------------------------------------------------------------

// The last column says whether current_version names a published version of the map (the schema's
// trigger keeps it so; a damaged database may point nowhere).
#define PL_PG_MAP_COLUMNS                                                                                       \
  "SELECT m.id, m.name, m.origin_lat, m.origin_lon, m.origin_alt, m.tile_size, m.voxel_size, m.current_version, " \
  PL_PG_TIMESTAMP("m.created") ", "                                                                           \
  "m.current_version IS NULL OR EXISTS (SELECT 1 FROM versions AS v WHERE v.map_id = m.id AND "                 \
  "v.number = m.current_version AND v.state = 'published') FROM maps AS m "

// Versions with their tile totals (sum() of bigint is numeric in PostgreSQL: no overflow); the last
// column says whether the parent exists.
#define PL_PG_VERSION_QUERY                                                                                    \
  "SELECT v.number, v.parent, v.state, " PL_PG_TIMESTAMP("v.created") ", v.note, count(t.id), "              \
  "coalesce(sum(t.points), 0), coalesce(sum(t.bytes), 0), "                                                  \
  "v.parent IS NULL OR EXISTS (SELECT 1 FROM versions AS p WHERE p.map_id = v.map_id AND p.number = v.parent) " \
  "FROM versions AS v LEFT JOIN tiles AS t ON t.map_id = v.map_id AND t.version = v.number "

const PgStatement kPgStatements[] = {
    {"map_by_name", PL_PG_MAP_COLUMNS "WHERE m.name = $1"},
    // Byte order, as SQLite's BINARY collation sorts them (the database's collation may differ).
    {"maps_all", PL_PG_MAP_COLUMNS "ORDER BY m.name COLLATE \"C\""},
    {"map_insert",
     "INSERT INTO maps (name, origin_lat, origin_lon, origin_alt, tile_size, voxel_size) "
     "VALUES ($1, $2::float8, $3::float8, $4::float8, $5::float8, $6::float8) ON CONFLICT (name) DO NOTHING "
     "RETURNING id"},
    // Writers to a map take turns on its row; FOR NO KEY UPDATE leaves foreign key checks (which take
    // FOR KEY SHARE) of other writers unblocked.
    {"map_lock", "SELECT id FROM maps WHERE name = $1 FOR NO KEY UPDATE"},
    {"map_current", "SELECT current_version FROM maps WHERE id = $1"},
    {"map_set_current", "UPDATE maps SET current_version = $2 WHERE id = $1"},
    {"version_by_id", PL_PG_VERSION_QUERY "WHERE v.map_id = $1 AND v.number = $2 GROUP BY v.id"},
    {"version_by_name",
     PL_PG_VERSION_QUERY "WHERE v.map_id = (SELECT id FROM maps WHERE name = $1) AND v.number = $2 GROUP BY v.id"},
    {"versions_by_name",
     PL_PG_VERSION_QUERY "WHERE v.map_id = (SELECT id FROM maps WHERE name = $1) GROUP BY v.id ORDER BY v.number"},
    {"version_state", "SELECT state FROM versions WHERE map_id = $1 AND number = $2"},
    {"version_next", "SELECT coalesce(max(number), 0) + 1 FROM versions WHERE map_id = $1"},
    {"version_insert", "INSERT INTO versions (map_id, number, parent, note) VALUES ($1, $2, $3, $4)"},
    {"version_replaces", "SELECT replaces FROM versions WHERE map_id = $1 AND number = $2"},
    {"version_retire", "UPDATE versions SET state = 'retired' WHERE map_id = $1 AND number = $2"},
    {"version_publish",
     "UPDATE versions SET state = 'published', published = statement_timestamp(), replaces = $3 "
     "WHERE map_id = $1 AND number = $2"},
    // Rows only: the copies point at the same blobs.
    {"tiles_copy",
     "INSERT INTO tiles (map_id, version, tx, ty, hash, points, bytes, min_x, min_y, min_z, max_x, max_y, max_z) "
     "SELECT map_id, $3, tx, ty, hash, points, bytes, min_x, min_y, min_z, max_x, max_y, max_z FROM tiles "
     "WHERE map_id = $1 AND version = $2 ORDER BY tx, ty"},
    // The places are one row of their own, bytes included.
    {"places_copy",
     "INSERT INTO places (map_id, version, hash, bytes, size) "
     "SELECT map_id, $3, hash, bytes, size FROM places WHERE map_id = $1 AND version = $2"},
};
const std::size_t kPgStatementCount = std::size(kPgStatements);

void PgStore::prepare_statements() {
  for (std::size_t i = 0; i < kPgStatementCount; ++i) conn_->prepare(kPgStatements[i].name, kPgStatements[i].sql);
  for (std::size_t i = 0; i < kPgTileStatementCount; ++i)
    conn_->prepare(kPgTileStatements[i].name, kPgTileStatements[i].sql);
  for (std::size_t i = 0; i < kPgReportStatementCount; ++i)
    conn_->prepare(kPgReportStatements[i].name, kPgReportStatements[i].sql);
}

// ---- opening and migrating -----------------------------------------------------------------------

// libpqxx 6 may reconnect a broken connection by itself at the next statement; a store's open
// transaction does not survive that, and statements must not go on outside it. Deprecated in
// libpqxx 6 (7 never reconnects), hence the pragma.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wdeprecated-declarations"
static void no_reconnecting(pqxx::connection& c) { c.inhibit_reactivation(true); }
#pragma GCC diagnostic pop

namespace {

// A server that does not answer (a host cut off, a firewall dropping packets) would hold a connect
// for minutes of TCP retries, and a dead peer an idle connection for hours: bounded unless the URL
// says otherwise (libpq's connect_timeout, TCP keepalives).
std::string with_timeouts(std::string url) {
  for (const char* p : {"connect_timeout=5", "keepalives_idle=30", "keepalives_interval=10", "keepalives_count=3"}) {
    const std::string key = std::string(p).substr(0, std::string(p).find('=') + 1);
    if (url.find(key) != std::string::npos) continue;
    url += (url.find('?') == std::string::npos ? "?" : "&");
    url += p;
  }
  return url;
}

std::unique_ptr<pqxx::connection> connect(const std::string& url, const std::string& name, bool create) {
  try {
    return std::make_unique<pqxx::connection>(with_timeouts(url));
  } catch (const std::exception& e) {
    throw Error(name + ": cannot connect to the map store database: " + trimmed(e.what()) +
                (create ? "" : " (does the database exist, and is the server running?)"));
  }
}

}  // namespace

PgStore::PgStore(const std::string& url, bool create) : name_(redact_url(url)), conn_(connect(url, name_, create)) {
  guarded([&] {
    no_reconnecting(*conn_);
    conn_->set_client_encoding("UTF8");
    {
      Work w(*conn_);
      // The store's own notices (a CREATE ... IF NOT EXISTS, ...) are not for its users.
      w.exec("SET client_min_messages = warning");
    }
    check_and_migrate(create);
    prepare_statements();
  });
}

// What open finds in the database: the migrations applied (0: none), or why it is not a store.
struct PgStoreState {
  bool marked = false;        // schema_migrations with the store's comment
  bool foreign = false;       // a schema_migrations that is someone else's
  std::int64_t objects = 0;   // tables, views, sequences, ... in the current schema
  std::int64_t version = 0;   // highest migration applied
};

static PgStoreState read_state(pqxx::nontransaction& w) {
  PgStoreState s;
  const pqxx::row r = w.exec1(
      "SELECT to_regclass('schema_migrations') IS NOT NULL, "
      "coalesce(obj_description(to_regclass('schema_migrations'), 'pg_class'), ''), "
      "(SELECT count(*) FROM pg_class AS c WHERE c.relnamespace = "
      "(SELECT oid FROM pg_namespace WHERE nspname = current_schema()) AND c.relkind IN ('r', 'p', 'v', 'm', 'f', 'S'))");
  const bool has_table = std::strcmp(r[0].c_str(), "t") == 0;
  s.objects = r[2].as<std::int64_t>();
  if (has_table) {
    s.marked = r[1].as<std::string>() == kMarker;
    s.foreign = !s.marked;
    if (s.marked) s.version = w.exec1("SELECT coalesce(max(number), 0) FROM schema_migrations")[0].as<std::int64_t>();
  }
  return s;
}

void PgStore::check_and_migrate(bool create) {
  // Everything is checked before anything is written: a database open refuses is left as it was.
  auto check = [&](const PgStoreState& s) {
    if (s.foreign)
      throw Error(name_ + ": not a map store (its schema_migrations table is not the map store's): "
                          "is this the right database?");
    if (!s.marked && s.objects > 0)
      throw Error(name_ + ": not a map store (the database holds other tables and no map store schema): "
                          "is this the right database?");
    if (s.version > kPgLatest)
      throw Error(name_ + ": the map store has schema version " + pg_num(s.version) + ", newer than this build knows (" +
                  pg_num(kPgLatest) + "): upgrade the PointLocalization software");
  };
  PgStoreState s;
  {
    Work w(*conn_);
    s = read_state(w);
  }
  check(s);
  if (!s.marked && !create)
    throw Error(name_ + ": the database is empty, not a map store: create a store with pl-map (or is this the "
                        "right database?)");
  if (s.version == kPgLatest) return;  // the usual open: nothing written
  // Every pending migration in one transaction, as on SQLite: all or nothing.
  Work w(*conn_);
  w.exec("BEGIN");
  try {
    // Concurrent opens take turns here; the one that waited finds the work done.
    w.exec_params("SELECT pg_advisory_xact_lock($1)", kMigrationLock);
    s = read_state(w);
    check(s);
    for (const PgMigration& m : kPgMigrations) {
      if (s.version >= m.number) continue;
      try {
        w.exec(m.sql);
      } catch (const pqxx::sql_error& e) {
        throw Error(name_ + ": schema migration pg/" + m.name + " failed: " + trimmed(e.what()));
      }
      w.exec_params("INSERT INTO schema_migrations (number, name) VALUES ($1, $2)", m.number, m.name);
      s.version = m.number;
    }
    w.exec("COMMIT");
  } catch (...) {
    undo(w, false);
    throw;
  }
}

int PgStore::schema_version() const {
  return one_statement([&](Work& w) {
    return static_cast<int>(w.exec_prepared1("schema_version")[0].as<std::int64_t>());
  });
}

// ---- maps ----------------------------------------------------------------------------------------

namespace {

MapInfo read_map(const PgStore& store, const pqxx::row& r) {
  PgRow row(store, r, "maps");
  MapInfo m;
  m.id = row.integer(0, "id");
  m.name = row.text(1, "name");
  if (!api::valid_map_name(m.name)) row.bad("name", "is not a valid map name");
  m.origin = GeoPoint{row.number(2, "origin_lat", -90, 90), row.number(3, "origin_lon", -180, 180),
                      row.number(4, "origin_alt")};
  m.tile_size = row.positive(5, "tile_size");
  m.voxel_size = row.positive(6, "voxel_size");
  m.current = row.opt_integer(7, "current_version", 1);
  m.created = row.timestamp(8, "created");
  row.require(9, "map " + m.name + ": current_version " + (m.current ? pg_num(*m.current) : "") +
                     " is not a published version of the map");
  return m;
}

VersionInfo read_version(const PgStore& store, const pqxx::row& r) {
  PgRow row(store, r, "versions");
  VersionInfo v;
  v.number = row.integer(0, "number", 1);
  v.parent = row.opt_integer(1, "parent", 1);
  v.state = row.state(2, "state");
  v.created = row.timestamp(3, "created");
  v.note = row.text(4, "note");
  PgRow tiles(store, r, "tiles");
  v.tiles = tiles.integer(5, "(count)", 0);
  v.points = tiles.integer(6, "points (total)", 0);
  v.bytes = tiles.integer(7, "bytes (total)", 0);
  row.require(8, "version " + pg_num(v.number) + " has parent " + (v.parent ? pg_num(*v.parent) : "") +
                     ", which does not exist");
  return v;
}

}  // namespace

MapInfo PgStore::create_map(const std::string& name, const GeoPoint& origin, double tile_size, double voxel_size) {
  return atomically([&](Work& w) {
    // ON CONFLICT: two connections creating the same name at once get one map and one refusal.
    if (w.exec_prepared("map_insert", name, pg_double(origin.lat_deg), pg_double(origin.lon_deg),
                        pg_double(origin.alt_m), pg_double(tile_size), pg_double(voxel_size))
            .empty())
      throw Error(name_ + ": map " + name + " already exists");
    const pqxx::result r = w.exec_prepared("map_by_name", name);
    if (r.empty()) throw Error(name_ + ": map " + name + " vanished after it was created");
    return read_map(*this, r[0]);
  });
}

std::optional<MapInfo> PgStore::find_map(const std::string& name) const {
  if (!api::valid_map_name(name)) return std::nullopt;
  return one_statement([&](Work& w) -> std::optional<MapInfo> {
    const pqxx::result r = w.exec_prepared("map_by_name", name);
    if (r.empty()) return std::nullopt;
    return read_map(*this, r[0]);
  });
}

std::vector<MapInfo> PgStore::list_maps() const {
  return one_statement([&](Work& w) {
    std::vector<MapInfo> out;
    for (const auto& row : w.exec_prepared("maps_all")) out.push_back(read_map(*this, row));
    return out;
  });
}

// ---- lookups inside a write ----------------------------------------------------------------------

std::int64_t PgStore::lock_map(Work& w, const std::string& name) const {
  if (!api::valid_map_name(name)) throw Error(name_ + ": unknown map " + name);
  const pqxx::result r = w.exec_prepared("map_lock", name);
  if (r.empty()) throw Error(name_ + ": unknown map " + name);
  return PgRow(*this, r[0], "maps").integer(0, "id");
}

std::optional<VersionState> PgStore::version_state(Work& w, std::int64_t map_id, std::int64_t number) const {
  const pqxx::result r = w.exec_prepared("version_state", map_id, number);
  if (r.empty()) return std::nullopt;
  return PgRow(*this, r[0], "versions").state(0, "state");
}

VersionState PgStore::require_version(Work& w, const std::string& map, std::int64_t map_id,
                                      std::int64_t number) const {
  auto state = version_state(w, map_id, number);
  if (!state) throw Error(name_ + ": map " + map + " has no version " + pg_num(number));
  return *state;
}

void PgStore::require_staged(Work& w, const std::string& map, std::int64_t map_id, std::int64_t number,
                             const char* what) const {
  VersionState state = require_version(w, map, map_id, number);
  if (state != VersionState::Staged)
    throw Error(name_ + ": map " + map + " version " + pg_num(number) + " is " + state_name(state) + ": " + what +
                " can only be changed in a staged version (create a new version)");
}

std::optional<VersionInfo> PgStore::version_by_id(Work& w, std::int64_t map_id, std::int64_t number) const {
  const pqxx::result r = w.exec_prepared("version_by_id", map_id, number);
  if (r.empty()) return std::nullopt;
  return read_version(*this, r[0]);
}

static std::optional<std::int64_t> current_of(const PgStore& store, pqxx::nontransaction& w, std::int64_t map_id) {
  const pqxx::result r = w.exec_prepared("map_current", map_id);
  if (r.empty()) return std::nullopt;
  return PgRow(store, r[0], "maps").opt_integer(0, "current_version", 1);
}

// ---- versions ------------------------------------------------------------------------------------

VersionInfo PgStore::create_version(const std::string& map, std::optional<std::int64_t> parent,
                                    const std::string& note) {
  require_text(note, "note");
  return atomically([&](Work& w) {
    // The map's row lock makes concurrent create_version calls take turns: each reads the number
    // the previous one committed.
    const std::int64_t map_id = lock_map(w, map);
    std::optional<std::int64_t> from = parent;
    if (from) {
      require_version(w, map, map_id, *from);
    } else {
      from = current_of(*this, w, map_id);  // none before the first publish: an empty version
    }
    const std::int64_t number =
        PgRow(*this, w.exec_prepared1("version_next", map_id), "versions").integer(0, "number", 1);
    const auto parent_param = pg_opt_int(from);
    w.exec_prepared("version_insert", map_id, number, pg_opt(parent_param), note);
    if (from) {
      w.exec_prepared("tiles_copy", map_id, *from, number);
      w.exec_prepared("places_copy", map_id, *from, number);
    }
    auto info = version_by_id(w, map_id, number);
    if (!info) throw Error(name_ + ": map " + map + " version " + pg_num(number) + " vanished after it was created");
    return *info;
  });
}

std::optional<VersionInfo> PgStore::find_version(const std::string& map, std::int64_t number) const {
  if (!api::valid_map_name(map)) return std::nullopt;
  return one_statement([&](Work& w) -> std::optional<VersionInfo> {
    const pqxx::result r = w.exec_prepared("version_by_name", map, number);
    if (r.empty()) return std::nullopt;
    return read_version(*this, r[0]);
  });
}

std::vector<VersionInfo> PgStore::list_versions(const std::string& map) const {
  if (!api::valid_map_name(map)) return {};
  return one_statement([&](Work& w) {
    std::vector<VersionInfo> out;
    for (const auto& row : w.exec_prepared("versions_by_name", map)) out.push_back(read_version(*this, row));
    return out;
  });
}

bool PgStore::publish(const std::string& map, std::int64_t number, const std::optional<std::optional<std::int64_t>>& only_if_current,
                      std::optional<std::int64_t> restores) {
  return atomically([&](Work& w) {
    const std::int64_t map_id = lock_map(w, map);
    VersionState state = require_version(w, map, map_id, number);
    if (state != VersionState::Staged)
      throw Error(name_ + ": map " + map + " version " + pg_num(number) + " is " + state_name(state) +
                  ": only a staged version can be published");
    const auto old = current_of(*this, w, map_id);
    if (only_if_current && *only_if_current != old) return false;  // the map's row lock is held: no publish can come between
    // A rollback: a further rollback goes where one from the restored version would.
    const std::optional<std::int64_t> step = [&]() -> std::optional<std::int64_t> {
      if (!restores) return old;
      require_version(w, map, map_id, *restores);
      const pqxx::result r = w.exec_prepared("version_replaces", map_id, *restores);
      if (r.empty()) return std::nullopt;
      return PgRow(*this, r[0], "versions").opt_integer(0, "replaces", 1);
    }();
    // Retire the old one first: the schema allows one published version per map.
    if (old) w.exec_prepared("version_retire", map_id, *old);
    const auto step_param = pg_opt_int(step);
    w.exec_prepared("version_publish", map_id, number, pg_opt(step_param));
    w.exec_prepared("map_set_current", map_id, number);
    return true;
  });
}

std::int64_t PgStore::rollback_target(const std::string& map) const {
  return atomically([&](Work& w) {
    const std::int64_t map_id = lock_map(w, map);
    const auto cur = current_of(*this, w, map_id);
    if (!cur) throw Error(name_ + ": map " + map + " has no published version to roll back");
    std::optional<std::int64_t> prev;
    {
      const pqxx::result r = w.exec_prepared("version_replaces", map_id, *cur);
      if (!r.empty()) prev = PgRow(*this, r[0], "versions").opt_integer(0, "replaces", 1);
    }
    if (!prev)
      throw Error(name_ + ": map " + map + ": version " + pg_num(*cur) +
                  " was the first version published, or restores its content: there is no earlier one to roll back to");
    VersionState prev_state = require_version(w, map, map_id, *prev);
    if (prev_state != VersionState::Retired)
      throw Error(name_ + ": map " + map + ": cannot roll back to version " + pg_num(*prev) + ", it is " +
                  state_name(prev_state));
    return *prev;
  });
}

// ---- transactions --------------------------------------------------------------------------------

bool PgStore::begin_transaction() {
  return guarded([&] {
    Work w(*conn_);
    const bool nested = depth_ > 0;
    w.exec(nested ? "SAVEPOINT pl_transaction" : "BEGIN");
    ++depth_;
    return nested;
  });
}

void PgStore::commit_transaction(bool nested) {
  guarded([&] {
    Work w(*conn_);
    if (nested) {
      w.exec("RELEASE SAVEPOINT pl_transaction");
    } else {
      // A transaction PostgreSQL has aborted would answer COMMIT with ROLLBACK rather than an error;
      // every call inside a Transaction runs in a savepoint it rolls back to when it fails, so the
      // transaction is never left aborted while the connection lives.
      w.exec("COMMIT");
    }
    // Only after it succeeded: a failed commit is rolled back by the Transaction's destructor,
    // which counts the level down.
    --depth_;
  });
}

void PgStore::rollback_transaction_quietly(bool nested) noexcept {
  if (depth_ > 0) --depth_;
  try {
    Work w(*conn_);
    w.exec(nested ? "ROLLBACK TO SAVEPOINT pl_transaction; RELEASE SAVEPOINT pl_transaction" : "ROLLBACK");
  } catch (...) {
    // In a destructor: the connection is gone, and its transaction with it.
  }
}

}  // namespace pl::store::detail
