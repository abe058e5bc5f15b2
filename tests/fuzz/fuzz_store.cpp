// Fuzz target: the bytes are a map store file (a damaged disk, a torn copy, a store crafted by
// someone else). It is opened as pl-server opens it (Store::open(path, false)) and read the way the
// server reads it, then opened as pl-map opens it (create = true) and written. Refusing with a
// pl::Error is fine; what must hold (else abort):
// - every value returned keeps the promises of store.hpp (valid names, states, hashes, finite
//   bounds with min <= max, a blob's bytes and a version's places hash to their hash, tiles_in_box
//   answers intersect the box);
// - refusing to open leaves the file as it was (at most the header fields of the switch to WAL);
// - reading a current WAL store (what pl-map writes) changes no byte of it;
// - a tile that put_tile stored is found again, with its bytes, and so are places put_places
//   stored and a change report put_report stored (once).
#include <sqlite3.h>
#include <unistd.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <string>
#include <vector>

#include "pl/common/error.hpp"
#include "pl/schema/store.hpp"
#include "pl/schema/api_rules.hpp"
#include "sqlite_input.hpp"

namespace fs = std::filesystem;
using pl::store::MapInfo;
using pl::store::Store;
using pl::store::TileRecord;
using pl::store::VersionInfo;

namespace {

using pl::fuzz::finding;
using pl::fuzz::InputFile;
using pl::fuzz::suspect;
using pl::fuzz::suspicion;
using pl::fuzz::WorkDir;

bool sqlite_finds_damage(const std::string& dir, const std::string& input) {
  return pl::fuzz::sqlite_finds_damage(dir, input, {"PRAGMA integrity_check", "SELECT rtreecheck('tile_rtree')"});
}

// Runs one read or write; a pl::Error is a refusal, which is allowed.
template <typename F>
void attempt(F&& f) {
  try {
    f();
  } catch (const pl::Error&) {
  }
}

std::uint32_t be32(const std::string& b, std::size_t at) {
  return static_cast<std::uint32_t>(static_cast<unsigned char>(b[at])) << 24 |
         static_cast<std::uint32_t>(static_cast<unsigned char>(b[at + 1])) << 16 |
         static_cast<std::uint32_t>(static_cast<unsigned char>(b[at + 2])) << 8 |
         static_cast<std::uint32_t>(static_cast<unsigned char>(b[at + 3]));
}

// The file header says WAL and the newest schema: Store::open has nothing to switch or migrate.
bool current_wal_store(const std::string& b) {
  return b.size() >= 100 && b.compare(0, 16, std::string("SQLite format 3\0", 16)) == 0 && b[18] == 2 && b[19] == 2 &&
         be32(b, 60) == static_cast<std::uint32_t>(Store::latest_schema_version());
}

void check_map(const MapInfo& m) {
  if (!pl::api::valid_map_name(m.name)) finding("list_maps/find_map returned an invalid map name");
  if (!(m.origin.lat_deg >= -90 && m.origin.lat_deg <= 90) || !(m.origin.lon_deg >= -180 && m.origin.lon_deg <= 180) ||
      !std::isfinite(m.origin.alt_m))
    finding("map " + m.name + ": origin out of range");
  if (!(m.tile_size > 0) || !std::isfinite(m.tile_size) || !(m.voxel_size > 0) || !std::isfinite(m.voxel_size))
    finding("map " + m.name + ": tile or voxel size is not a positive number");
  if (m.current && *m.current < 1) finding("map " + m.name + ": current version < 1");
}

void check_version(const VersionInfo& v) {
  if (v.number < 1 || (v.parent && *v.parent < 1)) finding("a version number < 1");
  if (v.tiles < 0 || v.points < 0 || v.bytes < 0) finding("negative version totals");
}

void check_tile(const TileRecord& t) {
  if (!pl::api::is_hash(t.hash)) finding("a tile whose hash is not 64 lowercase hex digits");
  if (t.points < 0 || t.bytes < 0) finding("a tile with negative points or bytes");
  for (double v : {t.min_x, t.min_y, t.min_z, t.max_x, t.max_y, t.max_z})
    if (!std::isfinite(v)) finding("a tile with bounds that are not finite");
  if (!(t.min_x <= t.max_x && t.min_y <= t.max_y && t.min_z <= t.max_z)) finding("a tile with min > max");
}

bool same_tile(const TileRecord& a, const TileRecord& b) {
  return a.key == b.key && a.hash == b.hash && a.points == b.points && a.bytes == b.bytes && a.min_x == b.min_x &&
         a.min_y == b.min_y && a.min_z == b.min_z && a.max_x == b.max_x && a.max_y == b.max_y && a.max_z == b.max_z;
}

void check_blob(const Store& s, const std::string& hash) {
  attempt([&] {
    auto bytes = s.blob(hash);
    if (bytes && pl::store::content_hash(*bytes) != hash) finding("blob() returned bytes that do not hash to their hash");
    s.has_blob(hash);
  });
}

// Boxes the server asks for: around the tiles it knows, a point, everything, nothing, NaN.
void check_boxes(const Store& s, const std::string& map, std::int64_t version, const std::vector<TileRecord>& tiles) {
  const double inf = std::numeric_limits<double>::infinity(), nan = std::numeric_limits<double>::quiet_NaN();
  std::vector<std::vector<double>> boxes = {{-1e300, -1e300, 1e300, 1e300}, {0, 0, 0, 0}, {-inf, -inf, inf, inf},
                                            {5, 5, -5, -5}, {nan, 0, 1, 1}, {-25, -25, 25, 25}};
  if (!tiles.empty()) {
    const TileRecord& t = tiles.front();
    boxes.push_back({t.min_x, t.min_y, t.max_x, t.max_y});
    boxes.push_back({t.max_x, t.max_y, t.max_x + 1, t.max_y + 1});  // touching a corner
  }
  for (const auto& b : boxes) {
    attempt([&] {
      for (const auto& t : s.tiles_in_box(map, version, b[0], b[1], b[2], b[3])) {
        check_tile(t);
        if (!(t.min_x <= b[2] && t.max_x >= b[0] && t.min_y <= b[3] && t.max_y >= b[1]))
          finding("tiles_in_box returned a tile outside the box");
      }
    });
  }
}

void read_version(const Store& s, const std::string& map, const VersionInfo& v) {
  check_version(v);
  attempt([&] {
    auto again = s.find_version(map, v.number);
    if (!again) return suspect("find_version does not find a version list_versions lists");
    check_version(*again);
  });
  std::vector<TileRecord> tiles;
  attempt([&] {
    tiles = s.list_tiles(map, v.number);
    for (const auto& t : tiles) check_tile(t);
  });
  std::size_t n = 0;
  for (const auto& t : tiles) {
    if (++n > 4) break;
    attempt([&] {
      auto found = s.find_tile(map, v.number, t.key);
      if (found) check_tile(*found);
    });
    check_blob(s, t.hash);
  }
  check_boxes(s, map, v.number, tiles);
  attempt([&] {
    auto hash = s.places_hash(map, v.number);
    if (hash && !pl::api::is_hash(*hash)) finding("places_hash returned a hash that is not 64 lowercase hex digits");
    auto bytes = s.places(map, v.number);
    if (bytes && bytes->empty()) finding("places() returned empty places");
    if (bytes && hash && pl::store::content_hash(*bytes) != *hash) finding("places() returned bytes that do not hash to places_hash");
    if (bytes.has_value() != hash.has_value()) suspect("places() and places_hash() disagree on whether a version has places");
  });
}

// What pl-server reads: maps, versions, tiles, regions, blobs, places, tokens, the log, health.
void serve(const Store& s) {
  std::vector<MapInfo> maps;
  attempt([&] { maps = s.list_maps(); });
  std::size_t n = 0;
  for (const auto& m : maps) {
    check_map(m);
    if (++n > 3) break;
    attempt([&] {
      auto found = s.find_map(m.name);
      if (!found) return suspect("find_map does not find a map list_maps lists");
      check_map(*found);
    });
    std::vector<VersionInfo> versions;
    attempt([&] { versions = s.list_versions(m.name); });
    std::size_t k = 0;
    for (const auto& v : versions)
      if (++k <= 3) read_version(s, m.name, v);
    if (m.current) attempt([&] { s.find_version(m.name, *m.current); });
    attempt([&] {
      for (const auto& e : s.upload_log(m.name))
        if (e.map != m.name) suspect("upload_log(map) returned an entry of another map");
    });
    // Change reports: each one's body hashes to its hash, and has the size listed.
    attempt([&] {
      std::size_t n = 0;
      for (const auto& r : s.list_reports(m.name)) {
        if (r.map != m.name) finding("list_reports(map) returned a report of another map");
        if (!pl::api::is_hash(r.hash)) finding("list_reports returned a hash that is not 64 lowercase hex digits");
        if (++n > 3) continue;
        const auto body = s.report_body(m.name, r.id);
        if (body && (pl::store::content_hash(*body) != r.hash || static_cast<std::int64_t>(body->size()) != r.bytes))
          finding("report_body returned bytes that do not hash to the report's hash or size");
      }
    });
  }
  attempt([&] { s.find_map("town"); });
  attempt([&] { s.list_versions("town"); });
  attempt([&] { s.find_tile("town", 1, {0, 0}); });
  for (const char* token : {"fuzz-read", "fuzz-upload", "fuzz-admin", "nope"}) attempt([&] { s.check_token(token); });
  attempt([&] { s.upload_log("town"); });
  attempt([&] { s.upload_log("nowhere"); });
  attempt([&] {
    if (s.database_bytes() < 0) finding("negative database_bytes");
  });
  attempt([&] { s.integrity_ok(); });
  attempt([&] {
    if (s.schema_version() != Store::latest_schema_version()) finding("an open store is not at the newest schema");
  });
}

// What pl-map writes: a map, a version, tiles and places (found again), a publish, a child version
// (with its parent's places), a rollback, a token, the log.
void build(Store& s) {
  std::vector<std::string> names = {"fuzz-new"};
  attempt([&] {
    auto maps = s.list_maps();
    if (!maps.empty()) names.push_back(maps.front().name);
  });
  attempt([&] { s.create_map("fuzz-new", {48.1, 11.5, 500.0}, 20.0, 0.2); });
  for (const auto& map : names) {
    attempt([&] {
      const VersionInfo v = s.create_version(map, std::nullopt, "fuzz");
      const std::string bytes = "not draco, but bytes " + map;
      const TileRecord put = s.put_tile(map, v.number, {3, -4}, bytes, 10, 60, -80, 0, 70, -70, 2);
      auto found = s.find_tile(map, v.number, {3, -4});
      if (!found || !same_tile(*found, put)) suspect("put_tile's tile is not found again as it was put");
      auto blob = s.blob(put.hash);
      if (!blob || *blob != bytes) suspect("put_tile's bytes are not found again");
      bool in_box = false;
      for (const auto& t : s.tiles_in_box(map, v.number, 65, -75, 66, -74)) in_box |= t.key == put.key;
      if (!in_box) suspect("tiles_in_box does not find the tile put_tile put");
      s.delete_tile(map, v.number, {0, 0});
      const std::string places = "places of " + map;
      s.put_places(map, v.number, places);
      if (s.places(map, v.number) != places) suspect("put_places's bytes are not found again");
      s.publish(map, v.number);
      const std::string report = "{\"report of\": \"" + map + "\"}";
      if (s.put_report(map, v.number, "fuzz-vehicle", "fuzz-drive", 0, 1, report, "fuzz") != Store::ReportPut::Stored ||
          s.put_report(map, v.number, "fuzz-vehicle", "fuzz-drive", 0, 1, report, "fuzz") != Store::ReportPut::AlreadyStored)
        suspect("put_report does not store a report once");
      const auto reports = s.list_reports(map, v.number);
      if (reports.empty() || s.report_body(map, reports.back().id) != report) suspect("put_report's bytes are not found again");
      const VersionInfo child = s.create_version(map, v.number, "fuzz child");
      if (s.places(map, child.number) != places) suspect("a new version does not start with its parent's places");
      s.delete_places(map, child.number);
      s.rollback(map);
    });
  }
  attempt([&] { s.add_token("fuzz-new-token", pl::store::Role::Upload, "fuzz"); });
  attempt([&] { s.log_upload("fuzz-new", 1, "upload", "detail", "fuzz"); });
  attempt([&] { s.integrity_ok(); });
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static WorkDir work("store");
  const std::string input(reinterpret_cast<const char*>(data), size);
  InputFile file(work.dir(), input);
  suspicion.clear();

  // As pl-server: open without create, read.
  bool opened = false;
  attempt([&] {
    Store s = Store::open(file.path(), false);
    opened = true;
    serve(s);
  });
  const std::string after = file.bytes();
  if (!opened && !pl::fuzz::same_but_wal_switch(input, after)) finding("a refused open changed the file");
  if (opened && current_wal_store(input) && after != input) finding("reading a current WAL store changed the file");

  // As pl-map: open with create (migrating an empty file), write.
  attempt([&] {
    Store s = Store::open(file.path(), true);
    build(s);
  });
  if (!suspicion.empty() && !sqlite_finds_damage(work.dir(), input)) finding(suspicion);
  return 0;
}
