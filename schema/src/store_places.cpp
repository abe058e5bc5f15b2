// The map store's places: one opaque blob per version (schema/002_places.sql), written while the
// version is staged, copied to a new version by create_version (store.cpp). All values reach SQL
// through bound parameters.
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include "pl/common/error.hpp"
#include "pl/schema/api_rules.hpp"
#include "pl/schema/detail/sqlite.hpp"
#include "pl/schema/store.hpp"
#include "store_internal.hpp"

namespace pl::store {

using namespace detail;

namespace {

// The rest of a query of a version's places row, after its columns: whether the version exists
// (the foreign key keeps it so; a damaged file may hold places of a version that is gone).
constexpr const char* kPlacesRow =
    "EXISTS (SELECT 1 FROM versions AS v WHERE v.map_id = p.map_id AND v.number = p.version) "
    "FROM places AS p WHERE p.map_id = ?1 AND p.version = ?2";

std::string version_name(const std::string& map, std::int64_t version) { return "map " + map + " version " + num(version); }

}  // namespace

void SqliteStore::put_places(const std::string& map, std::int64_t version, std::string_view bytes) {
  const Db db = conn();
  const std::string where = path_ + ": " + version_name(map, version) + " places";
  if (bytes.empty()) throw Error(where + ": empty places data (places are the non-empty bytes pl-map build writes)");
  if (bytes.size() > api::kMaxPlacesBytes)
    throw Error(where + ": " + num(static_cast<std::int64_t>(bytes.size())) + " bytes, more than the store's limit of " +
                num(static_cast<std::int64_t>(api::kMaxPlacesBytes >> 20)) + " MiB");
  const std::string hash = content_hash(bytes);
  WriteScope tx(db);
  std::int64_t map_id = require_map(db, map);
  require_staged(db, map, map_id, version, "places");
  // Same version: the row replaced in place (same id), and not at all when the bytes are the same.
  Stmt(db,
       "INSERT INTO places (map_id, version, hash, bytes, size) VALUES (?1, ?2, ?3, ?4, ?5) "
       "ON CONFLICT (map_id, version) DO UPDATE SET hash = excluded.hash, bytes = excluded.bytes, size = excluded.size "
       "WHERE hash IS NOT excluded.hash")
      .bind_int64(1, map_id)
      .bind_int64(2, version)
      .bind_text(3, hash)
      .bind_blob_static(4, bytes)
      .bind_int64(5, static_cast<std::int64_t>(bytes.size()))
      .run();
  tx.commit();
}

bool SqliteStore::delete_places(const std::string& map, std::int64_t version) {
  const Db db = conn();
  WriteScope tx(db);
  std::int64_t map_id = require_map(db, map);
  require_staged(db, map, map_id, version, "places");
  {
    Stmt st(db, "SELECT 1 FROM places WHERE map_id = ?1 AND version = ?2");
    st.bind_int64(1, map_id).bind_int64(2, version);
    if (!st.step()) return false;
  }
  Stmt(db, "DELETE FROM places WHERE map_id = ?1 AND version = ?2").bind_int64(1, map_id).bind_int64(2, version).run();
  tx.commit();
  return true;
}

std::optional<std::string> SqliteStore::places(const std::string& map, std::int64_t version) const {
  const Db db = conn();
  auto map_id = find_map_id(db, map);
  if (!map_id) return std::nullopt;
  Stmt st(db, (std::string("SELECT hash, bytes, size, ") + kPlacesRow).c_str());
  st.bind_int64(1, *map_id).bind_int64(2, version);
  if (!st.step()) return std::nullopt;
  Row row(st, "places");
  const std::string hash = row.hash(0, "hash");
  std::string bytes = row.blob(1, "bytes");
  const std::int64_t size = row.integer(2, "size", 1, kMaxInt64);
  row.require(3, version_name(map, version) + " has places but no such version");
  if (size != static_cast<std::int64_t>(bytes.size())) row.bad("size", "is not the length of places.bytes");
  // As for tile blobs: bytes that changed on disk are caught here, and never handed out (the
  // server would serve them under a hash they do not have).
  if (content_hash(bytes) != hash) row.bad("bytes", "of " + version_name(map, version) + " do not match their content hash");
  return bytes;
}

std::optional<std::string> SqliteStore::places_hash(const std::string& map, std::int64_t version) const {
  const Db db = conn();
  auto map_id = find_map_id(db, map);
  if (!map_id) return std::nullopt;
  Stmt st(db, (std::string("SELECT hash, size, ") + kPlacesRow).c_str());
  st.bind_int64(1, *map_id).bind_int64(2, version);
  if (!st.step()) return std::nullopt;
  Row row(st, "places");
  std::string hash = row.hash(0, "hash");
  row.integer(1, "size", 1, kMaxInt64);
  row.require(2, version_name(map, version) + " has places but no such version");
  return hash;
}

// ---- signatures (schema/004_signatures.sql) ------------------------------------------------------

void SqliteStore::put_signature(const std::string& map, std::int64_t version, std::string_view public_key, std::string_view signature) {
  const Db db = conn();
  WriteScope tx(db);
  std::int64_t map_id = require_map(db, map);
  require_staged(db, map, map_id, version, "a signature");
  Stmt(db,
       "INSERT INTO signatures (map_id, version, public_key, signature) VALUES (?1, ?2, ?3, ?4) "
       "ON CONFLICT (map_id, version) DO UPDATE SET public_key = excluded.public_key, signature = excluded.signature, "
       "signed = strftime('%Y-%m-%dT%H:%M:%fZ', 'now')")
      .bind_int64(1, map_id)
      .bind_int64(2, version)
      .bind_blob_static(3, public_key)
      .bind_blob_static(4, signature)
      .run();
  tx.commit();
}

std::optional<Store::Signature> SqliteStore::signature(const std::string& map, std::int64_t version) const {
  const Db db = conn();
  auto map_id = find_map_id(db, map);
  if (!map_id) return std::nullopt;
  Stmt st(db,
          "SELECT s.public_key, s.signature, s.signed, "
          "EXISTS (SELECT 1 FROM versions AS v WHERE v.map_id = s.map_id AND v.number = s.version) "
          "FROM signatures AS s WHERE s.map_id = ?1 AND s.version = ?2");
  st.bind_int64(1, *map_id).bind_int64(2, version);
  if (!st.step()) return std::nullopt;
  Row row(st, "signatures");
  Store::Signature out;
  out.public_key = row.blob(0, "public_key");
  out.signature = row.blob(1, "signature");
  out.signed_at = read_timestamp(row, 2, "signed");
  row.require(3, version_name(map, version) + " has a signature but no such version");
  if (out.public_key.size() != 32) row.bad("public_key", "is not 32 bytes");
  if (out.signature.size() != 64) row.bad("signature", "is not 64 bytes");
  return out;
}

}  // namespace pl::store
