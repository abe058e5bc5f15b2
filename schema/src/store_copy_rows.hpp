// The exact copy's row readers, one per table for both engines (store_copy_sqlite.cpp,
// store_pg_copy.cpp export_rows): the columns of each SELECT in the order below, every value checked
// as the other reads check it. R is the engine's adapter over one result row, with the engine's
// checked readers: integer, opt_integer, number, positive, text, hash, bytes (a blob or bytea),
// timestamp, opt_timestamp (NULL or a timestamp), state, tile(first) (the engine's own tile reader,
// read_tile / read_pg_tile, from column `first` on) and bad (the damaged error).
// Private to pl_schema.
#pragma once

#include <cstdint>
#include <limits>
#include <string>

#include "pl/common/error.hpp"
#include "pl/schema/api_rules.hpp"
#include "pl/schema/store.hpp"
#include "report_row.hpp"
#include "store_backend.hpp"

namespace pl::store::detail::copy_rows {

inline constexpr std::int64_t kLowest = std::numeric_limits<std::int64_t>::min();
inline constexpr std::int64_t kHighest = std::numeric_limits<std::int64_t>::max();

// Blobs, places and change reports: the size column and the hash must both be those of the bytes.
template <typename R>
bool bytes_sound(const R& row, int size_col, const std::string& hash, const std::string& bytes) {
  return row.integer(size_col, "size") == static_cast<std::int64_t>(bytes.size()) && content_hash(bytes) == hash;
}

// The damaged error, as DamagedBytes: the one damage that integrity_ok(false) leaves to the export.
template <typename R>
[[noreturn]] void bad_bytes(const R& row, const std::string& why, const char* column = "bytes") {
  try {
    row.bad(column, why);
  } catch (const Error& e) {
    throw DamagedBytes(e.what());
  }
}

// id, name, origin_lat, origin_lon, origin_alt, tile_size, voxel_size, current_version, created
template <typename R>
MapRow map_row(const R& row) {
  MapRow m;
  m.id = row.integer(0, "id");
  m.name = row.text(1, "name");
  if (!api::valid_map_name(m.name)) row.bad("name", "is not a valid map name");
  m.origin_lat = row.number(2, "origin_lat", -90, 90);
  m.origin_lon = row.number(3, "origin_lon", -180, 180);
  m.origin_alt = row.number(4, "origin_alt");
  m.tile_size = row.positive(5, "tile_size");
  m.voxel_size = row.positive(6, "voxel_size");
  m.current_version = row.opt_integer(7, "current_version", 1, kHighest);
  m.created = row.timestamp(8, "created");
  return m;
}

// id, map_id, number, parent, state, created, note, published, replaces
template <typename R>
VersionRow version_row(const R& row) {
  VersionRow v;
  v.id = row.integer(0, "id");
  v.map_id = row.integer(1, "map_id");
  v.number = row.integer(2, "number", 1, kHighest);
  v.parent = row.opt_integer(3, "parent", 1, kHighest);
  v.state = row.state(4, "state");
  v.created = row.timestamp(5, "created");
  v.note = row.text(6, "note");
  v.published = row.opt_timestamp(7, "published");
  v.replaces = row.opt_integer(8, "replaces", 1, kHighest);
  return v;
}

// hash, bytes, size
template <typename R>
BlobRow blob_row(const R& row) {
  BlobRow b;
  b.hash = row.hash(0, "hash");
  b.bytes = row.bytes(1, "bytes");
  if (!bytes_sound(row, 2, b.hash, b.bytes)) bad_bytes(row, "of blob " + b.hash + " do not hash to it");
  return b;
}

// id, map_id, version, then the engine's tile columns: tx, ty, hash, points, bytes, min_x, min_y,
// min_z, max_x, max_y, max_z
template <typename R>
TileRow tile_row(const R& row) {
  TileRow t;
  t.id = row.integer(0, "id");
  t.map_id = row.integer(1, "map_id");
  t.version = row.integer(2, "version", 1, kHighest);
  const TileRecord r = row.tile(3);
  t.tx = r.key.tx;
  t.ty = r.key.ty;
  t.hash = r.hash;
  t.points = r.points;
  t.bytes = r.bytes;
  t.min_x = r.min_x, t.min_y = r.min_y, t.min_z = r.min_z;
  t.max_x = r.max_x, t.max_y = r.max_y, t.max_z = r.max_z;
  return t;
}

// id, map_id, version, hash, bytes, size
template <typename R>
PlacesRow places_row(const R& row) {
  PlacesRow p;
  p.id = row.integer(0, "id");
  p.map_id = row.integer(1, "map_id");
  p.version = row.integer(2, "version", 1, kHighest);
  p.hash = row.hash(3, "hash");
  p.bytes = row.bytes(4, "bytes");
  if (!bytes_sound(row, 5, p.hash, p.bytes))
    bad_bytes(row, "of the places of version " + std::to_string(p.version) + " do not hash to their hash");
  return p;
}

// id, map_id, version, public_key, signature, signed
template <typename R>
SignatureRow signature_row(const R& row) {
  SignatureRow s;
  s.id = row.integer(0, "id");
  s.map_id = row.integer(1, "map_id");
  s.version = row.integer(2, "version", 1, kHighest);
  s.public_key = row.bytes(3, "public_key");
  s.signature = row.bytes(4, "signature");
  if (s.public_key.size() != 32 || s.signature.size() != 64) row.bad("signature", "or its key has the wrong size");
  s.signed_at = row.timestamp(5, "signed");
  return s;
}

// id, hash, role, note, created, revoked
template <typename R>
TokenRow token_row(const R& row) {
  TokenRow t;
  t.id = row.integer(0, "id", 1);
  t.hash = row.hash(1, "hash");
  auto role = parse_role(row.text(2, "role"));
  if (!role) row.bad("role", "is not one of read, report, upload, admin");
  t.role = *role;
  t.note = row.text(3, "note");
  t.created = row.timestamp(4, "created");
  t.revoked = row.opt_timestamp(5, "revoked");
  return t;
}

// id, at, map, version, action, detail, who
template <typename R>
LogRow log_row(const R& row) {
  LogRow e;
  e.id = row.integer(0, "id");
  e.at = row.timestamp(1, "at");
  e.map = row.text(2, "map");
  e.version = row.opt_integer(3, "version", kLowest, kHighest);
  e.action = row.text(4, "action");
  e.detail = row.text(5, "detail");
  e.who = row.text(6, "who");
  return e;
}

// report_row.hpp's columns (id, version, vehicle, drive, start_s, end_s, hash, size, who), then
// map_id, body, received
template <typename R>
ReportRow change_report_row(const R& row) {
  const Store::ReportInfo info = report_row(row, 0);
  ReportRow r;
  r.id = info.id;
  r.version = info.version;
  r.vehicle = info.vehicle;
  r.drive = info.drive;
  r.start = info.start;
  r.end = info.end;
  r.hash = info.hash;
  r.who = info.who;
  r.map_id = row.integer(9, "map_id");
  r.body = row.bytes(10, "body");
  if (!bytes_sound(row, 7, r.hash, r.body))
    bad_bytes(row, "of change report " + std::to_string(r.id) + " do not hash to its hash", "body");
  r.received = row.timestamp(11, "received");
  return r;
}

}  // namespace pl::store::detail::copy_rows
