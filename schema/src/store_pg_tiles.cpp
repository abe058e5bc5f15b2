// The map store over PostgreSQL: tiles and blobs, places, tokens, the upload log and maintenance
// (the rest: store_pg.cpp; how transactions and concurrency work: store_pg.hpp). All values reach
// SQL as parameters of prepared statements.
#include <cmath>
#include <cstring>
#include <iterator>

#include "pl/common/error.hpp"
#include "pl/schema/api_rules.hpp"
#include "store_pg.hpp"
#include "tile_row.hpp"

namespace pl::store::detail {

namespace {

// Text PostgreSQL can hold (UTF-8 without NUL): a map name in the upload log that is not can never
// have been logged.
bool is_pg_text(const std::string& s);

std::string version_name(const std::string& map, std::int64_t version) {
  return "map " + map + " version " + pg_num(version);
}

}  // namespace

// Every rule the schema states that PostgreSQL does not enforce on its own: tiles point at blobs and
// versions, places and change reports at versions, a current version is the one published version
// of its map, a parent exists.
#define PL_PG_INTEGRITY_RULES                                                                                         \
  "SELECT NOT EXISTS (SELECT 1 FROM tiles AS t WHERE NOT EXISTS (SELECT 1 FROM blobs AS b WHERE b.hash = t.hash)) "   \
  "AND NOT EXISTS (SELECT 1 FROM tiles AS t WHERE NOT EXISTS (SELECT 1 FROM versions AS v "                           \
  "  WHERE v.map_id = t.map_id AND v.number = t.version)) "                                                           \
  "AND NOT EXISTS (SELECT 1 FROM places AS p WHERE "                                                                  \
  "  NOT EXISTS (SELECT 1 FROM versions AS v WHERE v.map_id = p.map_id AND v.number = p.version)) "                   \
  "AND NOT EXISTS (SELECT 1 FROM change_reports AS r WHERE "                                                          \
  "  NOT EXISTS (SELECT 1 FROM versions AS v WHERE v.map_id = r.map_id AND v.number = r.version)) "                   \
  "AND NOT EXISTS (SELECT 1 FROM maps AS m WHERE m.current_version IS NOT NULL AND NOT EXISTS ("                      \
  "  SELECT 1 FROM versions AS v WHERE v.map_id = m.id AND v.number = m.current_version AND v.state = 'published')) " \
  "AND NOT EXISTS (SELECT 1 FROM versions WHERE state = 'published' GROUP BY map_id HAVING count(*) > 1) "            \
  "AND NOT EXISTS (SELECT 1 FROM versions AS v JOIN maps AS m ON m.id = v.map_id "                                    \
  "  WHERE v.state = 'published' AND m.current_version IS DISTINCT FROM v.number) "                                   \
  "AND NOT EXISTS (SELECT 1 FROM versions AS v WHERE v.parent IS NOT NULL AND NOT EXISTS ("                           \
  "  SELECT 1 FROM versions AS p WHERE p.map_id = v.map_id AND p.number = v.parent))"

const PgStatement kPgTileStatements[] = {
    {"schema_version", "SELECT coalesce(max(number), 0) FROM schema_migrations"},
    // ---- tiles and blobs
    {"tile_find",
     "SELECT t.tx, t.ty, t.hash, t.points, t.bytes, t.min_x, t.min_y, t.min_z, t.max_x, t.max_y, t.max_z "
     "FROM tiles AS t WHERE t.map_id = (SELECT id FROM maps WHERE name = $1) AND t.version = $2 "
     "AND t.tx = $3 AND t.ty = $4"},
    {"tiles_list",
     "SELECT t.tx, t.ty, t.hash, t.points, t.bytes, t.min_x, t.min_y, t.min_z, t.max_x, t.max_y, t.max_z "
     "FROM tiles AS t WHERE t.map_id = (SELECT id FROM maps WHERE name = $1) AND t.version = $2 "
     "ORDER BY t.tx, t.ty"},
    // The box expression is the GiST index's own (schema/pg/001_initial.sql). Its && compares with
    // PostgreSQL's geometric tolerance (1e-6), so the exact closed-box test on the bounds follows.
    {"tiles_box",
     "SELECT t.tx, t.ty, t.hash, t.points, t.bytes, t.min_x, t.min_y, t.min_z, t.max_x, t.max_y, t.max_z "
     "FROM tiles AS t WHERE t.map_id = (SELECT id FROM maps WHERE name = $1) AND t.version = $2 "
     "AND box(point(t.min_x, t.min_y), point(t.max_x, t.max_y)) && box(point($3::float8, $4::float8), "
     "point($5::float8, $6::float8)) "
     "AND t.min_x <= $5::float8 AND t.max_x >= $3::float8 AND t.min_y <= $6::float8 AND t.max_y >= $4::float8 "
     "ORDER BY t.tx, t.ty"},
    {"tile_hash", "SELECT hash FROM tiles WHERE map_id = $1 AND version = $2 AND tx = $3 AND ty = $4"},
    // The blob once per content: a second tile with the same bytes only adds a row.
    {"blob_insert", "INSERT INTO blobs (hash, bytes, size) VALUES ($1, $2, $3) ON CONFLICT (hash) DO NOTHING"},
    // Held until the put_tile commits: a concurrent garbage collection of the blob waits for it.
    {"blob_keep", "SELECT 1 FROM blobs WHERE hash = $1 FOR KEY SHARE"},
    // Same key: the row updated in place (same id), and not at all when nothing changed.
    {"tile_upsert",
     "INSERT INTO tiles (map_id, version, tx, ty, hash, points, bytes, min_x, min_y, min_z, max_x, max_y, max_z) "
     "VALUES ($1, $2, $3, $4, $5, $6, $7, $8::float8, $9::float8, $10::float8, $11::float8, $12::float8, $13::float8) "
     "ON CONFLICT (map_id, version, tx, ty) DO UPDATE SET hash = excluded.hash, points = excluded.points, "
     "bytes = excluded.bytes, min_x = excluded.min_x, min_y = excluded.min_y, min_z = excluded.min_z, "
     "max_x = excluded.max_x, max_y = excluded.max_y, max_z = excluded.max_z "
     "WHERE (tiles.hash, tiles.points, tiles.bytes, tiles.min_x, tiles.min_y, tiles.min_z, tiles.max_x, tiles.max_y, "
     "tiles.max_z) IS DISTINCT FROM (excluded.hash, excluded.points, excluded.bytes, excluded.min_x, excluded.min_y, "
     "excluded.min_z, excluded.max_x, excluded.max_y, excluded.max_z)"},
    {"tile_delete", "DELETE FROM tiles WHERE map_id = $1 AND version = $2 AND tx = $3 AND ty = $4"},
    // Garbage collection: the lock first, then the search for users in a statement of its own (a
    // new snapshot, which sees the tiles of every put_tile that held the blob before us).
    {"blob_lock", "SELECT 1 FROM blobs WHERE hash = $1 FOR UPDATE"},
    {"blob_drop", "DELETE FROM blobs WHERE hash = $1 AND NOT EXISTS (SELECT 1 FROM tiles WHERE hash = $1)"},
    {"blob_get", "SELECT bytes FROM blobs WHERE hash = $1"},
    {"blob_has", "SELECT 1 FROM blobs WHERE hash = $1"},
    // ---- places (the last column: whether the version exists)
    {"places_upsert",
     "INSERT INTO places (map_id, version, hash, bytes, size) VALUES ($1, $2, $3, $4, $5) "
     "ON CONFLICT (map_id, version) DO UPDATE SET hash = excluded.hash, bytes = excluded.bytes, size = excluded.size "
     "WHERE places.hash IS DISTINCT FROM excluded.hash"},
    {"places_exists", "SELECT 1 FROM places WHERE map_id = $1 AND version = $2"},
    {"places_delete", "DELETE FROM places WHERE map_id = $1 AND version = $2"},
    {"places_get",
     "SELECT p.hash, p.bytes, p.size, "
     "EXISTS (SELECT 1 FROM versions AS v WHERE v.map_id = p.map_id AND v.number = p.version) "
     "FROM places AS p WHERE p.map_id = (SELECT id FROM maps WHERE name = $1) AND p.version = $2"},
    {"places_hash",
     "SELECT p.hash, p.size, "
     "EXISTS (SELECT 1 FROM versions AS v WHERE v.map_id = p.map_id AND v.number = p.version) "
     "FROM places AS p WHERE p.map_id = (SELECT id FROM maps WHERE name = $1) AND p.version = $2"},
    // ---- signatures (the last column: whether the version exists)
    {"signature_upsert",
     "INSERT INTO signatures (map_id, version, public_key, signature) VALUES ($1, $2, $3, $4) "
     "ON CONFLICT (map_id, version) DO UPDATE SET public_key = excluded.public_key, signature = excluded.signature, "
     "signed = statement_timestamp()"},
    {"signature_get",
     "SELECT s.public_key, s.signature, " PL_PG_TIMESTAMP("s.signed") ", "
     "EXISTS (SELECT 1 FROM versions AS v WHERE v.map_id = s.map_id AND v.number = s.version) "
     "FROM signatures AS s WHERE s.map_id = (SELECT id FROM maps WHERE name = $1) AND s.version = $2"},
    // ---- tokens and the upload log
    {"token_insert", "INSERT INTO tokens (hash, role, note) VALUES ($1, $2, $3) ON CONFLICT (hash) DO NOTHING RETURNING id"},
    {"token_by_hash",
     "SELECT id, role, note, " PL_PG_TIMESTAMP("created") ", " PL_PG_TIMESTAMP("revoked") ", hash FROM tokens WHERE hash = $1"},
    {"token_list",
     "SELECT id, role, note, " PL_PG_TIMESTAMP("created") ", " PL_PG_TIMESTAMP("revoked") ", hash FROM tokens ORDER BY id"},
    {"token_revoke", "UPDATE tokens SET revoked = statement_timestamp() WHERE id = $1 AND revoked IS NULL RETURNING id"},
    {"log_insert", "INSERT INTO upload_log (map, version, action, detail, who) VALUES ($1, $2, $3, $4, $5)"},
    {"log_list",
     "SELECT id, " PL_PG_TIMESTAMP("at") ", map, version, action, detail, who FROM upload_log WHERE map = $1 "
     "ORDER BY id"},
    // ---- maintenance
    {"db_size", "SELECT pg_database_size(current_database())"},
    // What the schema promises and PostgreSQL cannot check once a row is written: tiles use
    // existing blobs of existing versions, every blob, places and change report hash to their hash,
    // the current version is the one published version of its map, parents exist.
    // integrity_ok: the rules, and with "integrity" the bytes of blobs, places and change reports
    // against their hashes and sizes too (one statement: one snapshot).
    {"integrity", PL_PG_INTEGRITY_RULES
     " AND NOT EXISTS (SELECT 1 FROM blobs WHERE encode(sha256(bytes), 'hex') <> hash OR size <> length(bytes)) "
     "AND NOT EXISTS (SELECT 1 FROM places WHERE encode(sha256(bytes), 'hex') <> hash OR size <> length(bytes)) "
     "AND NOT EXISTS (SELECT 1 FROM change_reports WHERE encode(sha256(body), 'hex') <> hash OR size <> length(body))"},
    {"integrity_rules", PL_PG_INTEGRITY_RULES},
};
const std::size_t kPgTileStatementCount = std::size(kPgTileStatements);

namespace {

bool is_pg_text(const std::string& s) {
  const auto* p = reinterpret_cast<const unsigned char*>(s.data());
  const std::size_t n = s.size();
  for (std::size_t i = 0; i < n;) {
    const unsigned c = p[i];
    if (c == 0) return false;
    if (c < 0x80) {
      ++i;
      continue;
    }
    const std::size_t len = c >= 0xF0 ? 4 : c >= 0xE0 ? 3 : c >= 0xC2 ? 2 : 0;
    if (len == 0 || c > 0xF4 || i + len > n) return false;
    for (std::size_t k = 1; k < len; ++k)
      if ((p[i + k] & 0xC0) != 0x80) return false;
    const unsigned c1 = p[i + 1];
    // Overlong forms, UTF-16 surrogates, and code points above U+10FFFF.
    if ((c == 0xE0 && c1 < 0xA0) || (c == 0xED && c1 >= 0xA0) || (c == 0xF0 && c1 < 0x90) || (c == 0xF4 && c1 >= 0x90))
      return false;
    i += len;
  }
  return true;
}

}  // namespace

void PgStore::require_text(const std::string& s, const char* what) const {
  if (!is_pg_text(s))
    throw Error(name_ + ": the " + what +
                " is not UTF-8 text without NUL bytes, which a PostgreSQL map store cannot hold: send it as UTF-8");
}

TileRecord read_pg_tile(const PgStore& store, const pqxx::row& r, int first) { return tile_row(PgRow(store, r, "tiles"), first); }

// ---- tiles ---------------------------------------------------------------------------------------

namespace {

std::optional<std::string> tile_hash(const PgStore& store, pqxx::nontransaction& w, std::int64_t map_id,
                                     std::int64_t version, const TileKey& key) {
  const pqxx::result r = w.exec_prepared("tile_hash", map_id, version, key.tx, key.ty);
  if (r.empty()) return std::nullopt;
  return PgRow(store, r[0], "tiles").hash(0, "hash");
}

// Deletes a blob that no tile uses any more.
void drop_blob_if_unused(pqxx::nontransaction& w, const std::string& hash) {
  w.exec_prepared("blob_lock", hash);
  w.exec_prepared("blob_drop", hash);
}

std::vector<TileRecord> read_tiles(const PgStore& store, const pqxx::result& r) {
  std::vector<TileRecord> out;
  out.reserve(r.size());
  for (const auto& row : r) out.push_back(read_pg_tile(store, row));
  return out;
}

}  // namespace

TileRecord PgStore::put_tile(const std::string& map, std::int64_t version, const TileKey& key,
                             std::string_view draco_bytes, std::int64_t points, double min_x, double min_y,
                             double min_z, double max_x, double max_y, double max_z) {
  TileRecord rec;
  rec.key = key;
  rec.hash = content_hash(draco_bytes);
  rec.points = points;
  rec.bytes = static_cast<std::int64_t>(draco_bytes.size());
  rec.min_x = min_x, rec.min_y = min_y, rec.min_z = min_z;
  rec.max_x = max_x, rec.max_y = max_y, rec.max_z = max_z;
  const pqxx::binarystring bytes(draco_bytes.data(), draco_bytes.size());

  atomically([&](Work& w) {
    const std::int64_t map_id = lock_map(w, map);
    require_staged(w, map, map_id, version, "tiles");
    const auto old_hash = tile_hash(*this, w, map_id, version, key);
    // The insert finds the blob there (or writes it), and the lock keeps it there until we commit;
    // a concurrent garbage collection that deleted it in between makes us write it again.
    for (int attempt = 0;; ++attempt) {
      w.exec_prepared("blob_insert", rec.hash, bytes, rec.bytes);
      if (!w.exec_prepared("blob_keep", rec.hash).empty()) break;
      if (attempt == 3)
        throw Error(name_ + ": map " + map + " version " + pg_num(version) + ": blob " + rec.hash +
                    " kept vanishing while it was written; try again");
    }
    w.exec_prepared("tile_upsert", map_id, version, key.tx, key.ty, rec.hash, rec.points, rec.bytes, pg_double(min_x),
                    pg_double(min_y), pg_double(min_z), pg_double(max_x), pg_double(max_y), pg_double(max_z));
    if (old_hash && *old_hash != rec.hash) drop_blob_if_unused(w, *old_hash);
  });
  return rec;
}

bool PgStore::delete_tile(const std::string& map, std::int64_t version, const TileKey& key) {
  return atomically([&](Work& w) {
    const std::int64_t map_id = lock_map(w, map);
    require_staged(w, map, map_id, version, "tiles");
    const auto hash = tile_hash(*this, w, map_id, version, key);
    if (!hash) return false;
    w.exec_prepared("tile_delete", map_id, version, key.tx, key.ty);
    drop_blob_if_unused(w, *hash);
    return true;
  });
}

std::optional<TileRecord> PgStore::find_tile(const std::string& map, std::int64_t version, const TileKey& key) const {
  if (!api::valid_map_name(map)) return std::nullopt;
  return one_statement([&](Work& w) -> std::optional<TileRecord> {
    const pqxx::result r = w.exec_prepared("tile_find", map, version, key.tx, key.ty);
    if (r.empty()) return std::nullopt;
    return read_pg_tile(*this, r[0]);
  });
}

std::vector<TileRecord> PgStore::list_tiles(const std::string& map, std::int64_t version) const {
  if (!api::valid_map_name(map)) return {};
  return one_statement([&](Work& w) { return read_tiles(*this, w.exec_prepared("tiles_list", map, version)); });
}

std::vector<TileRecord> PgStore::tiles_in_box(const std::string& map, std::int64_t version, double min_x, double min_y,
                                              double max_x, double max_y) const {
  if (!(min_x <= max_x && min_y <= max_y)) return {};  // inverted or NaN: nothing
  if (!api::valid_map_name(map)) return {};
  return one_statement([&](Work& w) {
    return read_tiles(*this, w.exec_prepared("tiles_box", map, version, pg_double(min_x), pg_double(min_y),
                                             pg_double(max_x), pg_double(max_y)));
  });
}

std::optional<std::string> PgStore::blob(const std::string& hash) const {
  if (!api::is_hash(hash)) return std::nullopt;  // no blob has it
  return one_statement([&](Work& w) -> std::optional<std::string> {
    const pqxx::result r = w.exec_prepared("blob_get", hash);
    if (r.empty()) return std::nullopt;
    PgRow row(*this, r[0], "blobs");
    std::string bytes = row.bytes(0, "bytes");
    // Bytes edited behind the store's back are caught here, and never handed out (the server would
    // serve them as immutable under a hash they do not have).
    if (content_hash(bytes) != hash) row.bad("bytes", "of blob " + hash + " do not match its content hash");
    return bytes;
  });
}

bool PgStore::has_blob(const std::string& hash) const {
  if (!api::is_hash(hash)) return false;
  return one_statement([&](Work& w) { return !w.exec_prepared("blob_has", hash).empty(); });
}

// ---- places --------------------------------------------------------------------------------------

void PgStore::put_places(const std::string& map, std::int64_t version, std::string_view bytes) {
  const std::string where = name_ + ": " + version_name(map, version) + " places";
  if (bytes.empty()) throw Error(where + ": empty places data (places are the non-empty bytes pl-map build writes)");
  if (bytes.size() > api::kMaxPlacesBytes)
    throw Error(where + ": " + pg_num(static_cast<std::int64_t>(bytes.size())) +
                " bytes, more than the store's limit of " + pg_num(static_cast<std::int64_t>(api::kMaxPlacesBytes >> 20)) +
                " MiB");
  const std::string hash = content_hash(bytes);
  const pqxx::binarystring data(bytes.data(), bytes.size());
  atomically([&](Work& w) {
    const std::int64_t map_id = lock_map(w, map);
    require_staged(w, map, map_id, version, "places");
    // Same version: the row replaced in place (same id), and not at all when the bytes are the same.
    w.exec_prepared("places_upsert", map_id, version, hash, data, static_cast<std::int64_t>(bytes.size()));
  });
}

bool PgStore::delete_places(const std::string& map, std::int64_t version) {
  return atomically([&](Work& w) {
    const std::int64_t map_id = lock_map(w, map);
    require_staged(w, map, map_id, version, "places");
    if (w.exec_prepared("places_exists", map_id, version).empty()) return false;
    w.exec_prepared("places_delete", map_id, version);
    return true;
  });
}

std::optional<std::string> PgStore::places(const std::string& map, std::int64_t version) const {
  if (!api::valid_map_name(map)) return std::nullopt;
  return one_statement([&](Work& w) -> std::optional<std::string> {
    const pqxx::result r = w.exec_prepared("places_get", map, version);
    if (r.empty()) return std::nullopt;
    PgRow row(*this, r[0], "places");
    const std::string hash = row.hash(0, "hash");
    std::string bytes = row.bytes(1, "bytes");
    const std::int64_t size = row.integer(2, "size", 1);
    row.require(3, version_name(map, version) + " has places but no such version");
    if (size != static_cast<std::int64_t>(bytes.size())) row.bad("size", "is not the length of places.bytes");
    // As for tile blobs: bytes edited behind the store's back are caught here and never handed out.
    if (content_hash(bytes) != hash)
      row.bad("bytes", "of " + version_name(map, version) + " do not match their content hash");
    return bytes;
  });
}

std::optional<std::string> PgStore::places_hash(const std::string& map, std::int64_t version) const {
  if (!api::valid_map_name(map)) return std::nullopt;
  return one_statement([&](Work& w) -> std::optional<std::string> {
    const pqxx::result r = w.exec_prepared("places_hash", map, version);
    if (r.empty()) return std::nullopt;
    PgRow row(*this, r[0], "places");
    std::string hash = row.hash(0, "hash");
    row.integer(1, "size", 1);
    row.require(2, version_name(map, version) + " has places but no such version");
    return hash;
  });
}

// ---- signatures ----------------------------------------------------------------------------------

void PgStore::put_signature(const std::string& map, std::int64_t version, std::string_view public_key, std::string_view signature) {
  const pqxx::binarystring key(public_key.data(), public_key.size()), sig(signature.data(), signature.size());
  atomically([&](Work& w) {
    const std::int64_t map_id = lock_map(w, map);
    require_staged(w, map, map_id, version, "a signature");
    w.exec_prepared("signature_upsert", map_id, version, key, sig);
  });
}

std::optional<Store::Signature> PgStore::signature(const std::string& map, std::int64_t version) const {
  if (!api::valid_map_name(map)) return std::nullopt;
  return one_statement([&](Work& w) -> std::optional<Store::Signature> {
    const pqxx::result r = w.exec_prepared("signature_get", map, version);
    if (r.empty()) return std::nullopt;
    PgRow row(*this, r[0], "signatures");
    Store::Signature out;
    out.public_key = row.bytes(0, "public_key");
    out.signature = row.bytes(1, "signature");
    out.signed_at = row.timestamp(2, "signed");
    row.require(3, version_name(map, version) + " has a signature but no such version");
    if (out.public_key.size() != 32) row.bad("public_key", "is not 32 bytes");
    if (out.signature.size() != 64) row.bad("signature", "is not 64 bytes");
    return out;
  });
}

// ---- tokens and the upload log -------------------------------------------------------------------

std::int64_t PgStore::add_token(const std::string& token, Role role, const std::string& note) {
  require_text(note, "token's note");
  const std::string hash = content_hash(token);
  return one_statement([&](Work& w) {
    const pqxx::result r = w.exec_prepared("token_insert", hash, role_name(role), note);
    // Never echo the token itself into a message.
    if (r.empty()) throw Error(name_ + ": this token is already registered");
    return PgRow(*this, r[0], "tokens").integer(0, "id", 1);
  });
}

namespace {
std::pair<Store::TokenInfo, std::string> read_token(const PgStore& store, const pqxx::row& r) {
  PgRow row(store, r, "tokens");
  Store::TokenInfo t;
  t.id = row.integer(0, "id", 1);
  auto role = parse_role(row.text(1, "role"));
  if (!role) row.bad("role", "is not one of read, report, upload, admin");
  t.role = *role;
  t.note = row.text(2, "note");
  t.created = row.timestamp(3, "created");
  if (!r[4].is_null()) t.revoked = row.timestamp(4, "revoked");
  return {t, row.hash(5, "hash")};
}
}  // namespace

std::optional<std::pair<Store::TokenInfo, std::string>> PgStore::token_by_hash(const std::string& hash) const {
  return one_statement([&](Work& w) -> std::optional<std::pair<Store::TokenInfo, std::string>> {
    const pqxx::result r = w.exec_prepared("token_by_hash", hash);
    if (r.empty()) return std::nullopt;
    return read_token(*this, r[0]);
  });
}

bool PgStore::revoke_token(std::int64_t id) {
  return one_statement([&](Work& w) { return !w.exec_prepared("token_revoke", id).empty(); });
}

std::vector<Store::TokenInfo> PgStore::list_tokens() const {
  return one_statement([&](Work& w) {
    std::vector<Store::TokenInfo> out;
    for (const auto& r : w.exec_prepared("token_list")) out.push_back(read_token(*this, r).first);
    return out;
  });
}

void PgStore::log_upload(const std::string& map, std::optional<std::int64_t> version, const std::string& action,
                         const std::string& detail, const std::string& who) {
  require_text(map, "upload log entry's map name");
  require_text(action, "upload log entry's action");
  require_text(detail, "upload log entry's detail");
  require_text(who, "upload log entry's who");
  const auto version_param = pg_opt_int(version);
  one_statement([&](Work& w) { w.exec_prepared("log_insert", map, pg_opt(version_param), action, detail, who); });
}

std::vector<Store::LogEntry> PgStore::upload_log(const std::string& map) const {
  if (!is_pg_text(map)) return {};
  return one_statement([&](Work& w) {
    std::vector<Store::LogEntry> out;
    for (const auto& r : w.exec_prepared("log_list", map)) {
      PgRow row(*this, r, "upload_log");
      Store::LogEntry e;
      e.id = row.integer(0, "id");
      e.at = row.timestamp(1, "at");
      e.map = row.text(2, "map");
      e.version = row.opt_integer(3, "version");
      e.action = row.text(4, "action");
      e.detail = row.text(5, "detail");
      e.who = row.text(6, "who");
      out.push_back(std::move(e));
    }
    return out;
  });
}

// ---- maintenance ---------------------------------------------------------------------------------

std::int64_t PgStore::database_bytes() const {
  return one_statement([&](Work& w) { return w.exec_prepared1("db_size")[0].as<std::int64_t>(); });
}

bool PgStore::integrity_ok(bool hash_bytes) const {
  return one_statement([&](Work& w) {
    try {
      const pqxx::row r = w.exec_prepared1(hash_bytes ? "integrity" : "integrity_rules");
      return std::strcmp(r[0].c_str(), "t") == 0;
    } catch (const pqxx::sql_error& e) {
      // PostgreSQL's own reports of damage (data_corrupted, index_corrupted) are a "no".
      const std::string state = e.sqlstate();
      if (state == "XX001" || state == "XX002") return false;
      throw;
    }
  });
}

}  // namespace pl::store::detail
