// The map store's tiles and blobs, tokens and upload log, transactions and maintenance (the rest:
// store.cpp). All values reach SQL through bound parameters.
#include <openssl/evp.h>

#include <cmath>
#include <iterator>
#include <limits>
#include <map>
#include <utility>

#include "pl/common/error.hpp"
#include "pl/schema/api_rules.hpp"
#include "pl/schema/detail/sqlite.hpp"
#include "pl/schema/store.hpp"
#include "store_internal.hpp"

namespace pl::store {

using namespace detail;

// ---- tiles ---------------------------------------------------------------------------------------

TileRecord SqliteStore::put_tile(const std::string& map, std::int64_t version, const TileKey& key,
                           std::string_view draco_bytes, std::int64_t points, double min_x, double min_y, double min_z,
                           double max_x, double max_y, double max_z) {
  static_assert(kMaxTileBytes <= sqlite::kMaxValueBytes, "a tile Store takes must fit a SQLite value");
  const Db db = conn();
  TileRecord rec;
  rec.key = key;
  rec.hash = content_hash(draco_bytes);
  rec.points = points;
  rec.bytes = static_cast<std::int64_t>(draco_bytes.size());
  rec.min_x = min_x, rec.min_y = min_y, rec.min_z = min_z;
  rec.max_x = max_x, rec.max_y = max_y, rec.max_z = max_z;

  WriteScope tx(db);
  std::int64_t map_id = require_map(db, map);
  require_staged(db, map, map_id, version);
  auto old_hash = tile_hash(db, map_id, version, key);
  // The blob once per content: a second tile with the same bytes only adds a row.
  Stmt(db, "INSERT INTO blobs (hash, bytes, size) VALUES (?1, ?2, ?3) ON CONFLICT (hash) DO NOTHING")
      .bind_text(1, rec.hash)
      .bind_blob_static(2, draco_bytes)
      .bind_int64(3, rec.bytes)
      .run();
  // Same key: update the row in place (same id), and not at all when nothing changed.
  Stmt(db,
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
  if (old_hash && *old_hash != rec.hash) drop_blob_if_unused(db, *old_hash);
  tx.commit();
  return rec;
}

bool SqliteStore::delete_tile(const std::string& map, std::int64_t version, const TileKey& key) {
  const Db db = conn();
  WriteScope tx(db);
  std::int64_t map_id = require_map(db, map);
  require_staged(db, map, map_id, version);
  auto hash = tile_hash(db, map_id, version, key);
  if (!hash) return false;
  Stmt(db, "DELETE FROM tiles WHERE map_id = ?1 AND version = ?2 AND tx = ?3 AND ty = ?4")
      .bind_int64(1, map_id)
      .bind_int64(2, version)
      .bind_int64(3, key.tx)
      .bind_int64(4, key.ty)
      .run();
  drop_blob_if_unused(db, *hash);
  tx.commit();
  return true;
}

std::optional<TileRecord> SqliteStore::find_tile(const std::string& map, std::int64_t version, const TileKey& key) const {
  const Db db = conn();
  auto map_id = find_map_id(db, map);
  if (!map_id) return std::nullopt;
  Stmt st(db,
          (std::string(kTileColumns) + "WHERE t.map_id = ?1 AND t.version = ?2 AND t.tx = ?3 AND t.ty = ?4").c_str());
  st.bind_int64(1, *map_id).bind_int64(2, version).bind_int64(3, key.tx).bind_int64(4, key.ty);
  if (!st.step()) return std::nullopt;
  return read_tile(st);
}

std::vector<TileRecord> SqliteStore::list_tiles(const std::string& map, std::int64_t version) const {
  const Db db = conn();
  std::vector<TileRecord> out;
  auto map_id = find_map_id(db, map);
  if (!map_id) return out;
  Stmt st(db, (std::string(kTileColumns) + "WHERE t.map_id = ?1 AND t.version = ?2 ORDER BY t.tx, t.ty").c_str());
  st.bind_int64(1, *map_id).bind_int64(2, version);
  while (st.step()) out.push_back(read_tile(st));
  return out;
}

std::vector<TileRecord> SqliteStore::tiles_in_box(const std::string& map, std::int64_t version, double min_x, double min_y,
                                            double max_x, double max_y) const {
  const Db db = conn();
  std::vector<TileRecord> out;
  if (!(min_x <= max_x && min_y <= max_y)) return out;  // inverted or NaN: nothing
  auto map_id = find_map_id(db, map);
  if (!map_id) return out;
  // CROSS JOIN keeps the R*Tree as the outer loop (SQLite does not reorder it), so the search is
  // spatial first; the R*Tree's float32 boxes are rounded outwards, hence the exact re-check on
  // tiles' own bounds. The R*Tree holds every version's tiles; the map/version filter follows.
  Stmt st(db,
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

std::optional<std::string> SqliteStore::blob(const std::string& hash) const {
  Stmt st(conn(), "SELECT bytes FROM blobs WHERE hash = ?1");
  st.bind_text(1, hash);
  if (!st.step()) return std::nullopt;
  Row row(st, "blobs");
  std::string bytes = row.blob(0, "bytes");
  // SQLite keeps no checksums of its own: bytes that changed on disk are only caught here, and are
  // never handed out (the server would serve them as immutable under a hash they do not have).
  if (content_hash(bytes) != hash) row.bad("bytes", "of blob " + plain(hash) + " do not match its content hash");
  return bytes;
}

bool SqliteStore::has_blob(const std::string& hash) const {
  Stmt st(conn(), "SELECT 1 FROM blobs WHERE hash = ?1");
  st.bind_text(1, hash);
  return st.step();
}

// ---- tokens and the upload log -------------------------------------------------------------------

std::int64_t SqliteStore::add_token(const std::string& token, Role role, const std::string& note) {
  const Db db = conn();
  std::string hash = content_hash(token);
  WriteScope tx(db);
  {
    Stmt st(db, "SELECT 1 FROM tokens WHERE hash = ?1");
    st.bind_text(1, hash);
    // Never echo the token itself into a message.
    if (st.step()) throw Error(path_ + ": this token is already registered");
  }
  Stmt(db, "INSERT INTO tokens (hash, role, note) VALUES (?1, ?2, ?3)")
      .bind_text(1, hash)
      .bind_text(2, role_name(role))
      .bind_text(3, note)
      .run();
  const std::int64_t id = sqlite3_last_insert_rowid(db.get());
  tx.commit();
  return id;
}

namespace {
constexpr const char* kTokenColumns = "SELECT id, role, note, created, revoked, hash FROM tokens ";

std::pair<Store::TokenInfo, std::string> read_token(const Stmt& st) {
  Row row(st, "tokens");
  Store::TokenInfo t;
  t.id = row.integer(0, "id", 1);
  auto role = parse_role(row.text(1, "role"));
  if (!role) row.bad("role", "is not one of read, report, upload, admin");
  t.role = *role;
  t.note = row.text(2, "note");
  t.created = read_timestamp(row, 3, "created");
  if (!st.is_null(4)) t.revoked = read_timestamp(row, 4, "revoked");
  return {t, row.hash(5, "hash")};
}
}  // namespace

std::optional<std::pair<Store::TokenInfo, std::string>> SqliteStore::token_by_hash(const std::string& hash) const {
  Stmt st(conn(), (std::string(kTokenColumns) + "WHERE hash = ?1").c_str());
  st.bind_text(1, hash);
  if (!st.step()) return std::nullopt;
  return read_token(st);
}

bool SqliteStore::revoke_token(std::int64_t id) {
  const Db db = conn();
  WriteScope tx(db);
  Stmt(db, "UPDATE tokens SET revoked = strftime('%Y-%m-%dT%H:%M:%fZ', 'now') WHERE id = ?1 AND revoked IS NULL")
      .bind_int64(1, id)
      .run();
  const bool changed = sqlite3_changes(db.get()) == 1;
  tx.commit();
  return changed;
}

std::vector<Store::TokenInfo> SqliteStore::list_tokens() const {
  Stmt st(conn(), (std::string(kTokenColumns) + "ORDER BY id").c_str());
  std::vector<Store::TokenInfo> out;
  while (st.step()) out.push_back(read_token(st).first);
  return out;
}

void SqliteStore::log_upload(const std::string& map, std::optional<std::int64_t> version, const std::string& action,
                       const std::string& detail, const std::string& who) {
  const Db db = conn();
  Stmt(db, "INSERT INTO upload_log (map, version, action, detail, who) VALUES (?1, ?2, ?3, ?4, ?5)")
      .bind_text(1, map)
      .bind_opt_int64(2, version)
      .bind_text(3, action)
      .bind_text(4, detail)
      .bind_text(5, who)
      .run();
}

std::vector<Store::LogEntry> SqliteStore::upload_log(const std::string& map) const {
  Stmt st(conn(),
          "SELECT id, at, map, version, action, detail, who FROM upload_log WHERE map = ?1 ORDER BY id");
  st.bind_text(1, map);
  std::vector<Store::LogEntry> out;
  while (st.step()) {
    Row row(st, "upload_log");
    Store::LogEntry e;
    e.id = row.integer(0, "id");
    e.at = read_timestamp(row, 1, "at");
    e.map = row.text(2, "map");
    e.version = row.opt_integer(3, "version", std::numeric_limits<std::int64_t>::min(), kMaxInt64);
    e.action = row.text(4, "action");
    e.detail = row.text(5, "detail");
    e.who = row.text(6, "who");
    out.push_back(std::move(e));
  }
  return out;
}

// ---- transactions and maintenance ----------------------------------------------------------------

bool SqliteStore::begin_transaction() { return sqlite::begin_write(conn(), "pl_transaction"); }

void SqliteStore::commit_transaction(bool nested) { sqlite::commit_write(conn(), "pl_transaction", nested); }

void SqliteStore::rollback_transaction_quietly(bool nested) noexcept {
  if (db_) sqlite::rollback_write_quietly(static_cast<sqlite3*>(db_), "pl_transaction", nested);
}

std::int64_t SqliteStore::database_bytes() const {
  const Db db = conn();
  return pragma_int(db, "PRAGMA page_count") * pragma_int(db, "PRAGMA page_size");
}

bool SqliteStore::integrity_ok(bool hash_bytes) const {
  const Db db = conn();
  try {
    {
      Stmt st(db, "PRAGMA integrity_check");
      if (!st.step() || st.text(0) != "ok" || st.step()) return false;
    }
    {
      Stmt st(db, "PRAGMA foreign_key_check");
      if (st.step()) return false;
    }
    {
      Stmt st(db, "SELECT rtreecheck('tile_rtree')");
      if (!st.step() || st.text(0) != "ok") return false;
    }
    {
      // One R*Tree entry per tile, with a box that contains the tile's xy box.
      Stmt st(db, "SELECT (SELECT count(*) FROM tiles) = (SELECT count(*) FROM tile_rtree) AND NOT EXISTS ("
              "SELECT 1 FROM tiles AS t WHERE NOT EXISTS (SELECT 1 FROM tile_rtree AS r WHERE r.id = t.id "
              "AND r.min_x <= t.min_x AND r.max_x >= t.max_x AND r.min_y <= t.min_y AND r.max_y >= t.max_y))");
      if (!st.step() || st.int64(0) != 1) return false;
    }
    if (hash_bytes) {
      // Every blob, every version's places and every change report hash to their hash, as on
      // PostgreSQL: SQLite keeps no checksums of its own, so bytes that changed on disk show only
      // here (or in export_rows).
      Stmt st(db, "SELECT hash, bytes FROM blobs UNION ALL SELECT hash, bytes FROM places "
                  "UNION ALL SELECT hash, body FROM change_reports");
      while (st.step()) {
        Row row(st, "blobs");
        if (content_hash(row.blob(1, "bytes")) != st.text(0)) return false;
      }
    }
  } catch (const Error&) {
    int code = sqlite3_errcode(db.get()) & 0xFF;
    if (code == SQLITE_CORRUPT || code == SQLITE_NOTADB) return false;
    throw;
  }
  return true;
}

}  // namespace pl::store
