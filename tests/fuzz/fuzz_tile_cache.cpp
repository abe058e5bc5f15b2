// Fuzz target: the bytes are the vehicle's disk cache file (a power cut, a failing card, a file
// put there by someone else), opened and used as the tile client uses it. Refusing with a
// pl::Error is fine; what must hold (else abort):
// - blob() returns only bytes whose SHA-256 is the hash asked for;
// - rows and manifests keep the promises of tile_cache.hpp (hashes of 64 hex digits or none,
//   positive finite tile sizes, finite origins);
// - refusing to open leaves the file as it was (at most the header fields of the switch to WAL);
// - what put_blob, put_tiles and put_manifest stored is read back as it was stored.
#include <sqlite3.h>
#include <unistd.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <optional>
#include <string>
#include <vector>

#include "pl/client/tile_cache.hpp"
#include "pl/common/error.hpp"
#include "pl/schema/api_rules.hpp"
#include "sqlite_input.hpp"
#include "pl/schema/store.hpp"

namespace fs = std::filesystem;
using pl::client::CachedManifest;
using pl::client::CachedTile;
using pl::client::TileCache;

namespace {

using pl::fuzz::finding;
using pl::fuzz::InputFile;
using pl::fuzz::suspect;
using pl::fuzz::suspicion;
using pl::fuzz::WorkDir;

bool sqlite_finds_damage(const std::string& dir, const std::string& input) {
  return pl::fuzz::sqlite_finds_damage(dir, input, {"PRAGMA integrity_check"});
}

template <typename F>
void attempt(F&& f) {
  try {
    f();
  } catch (const pl::Error&) {
  }
}

void check_manifest(const std::optional<CachedManifest>& m) {
  if (!m) return;
  if (!(m->tile_size > 0) || !std::isfinite(m->tile_size) || !std::isfinite(m->voxel_size))
    finding("a manifest whose tile size is not a positive number");
  if (!std::isfinite(m->origin.lat_deg) || !std::isfinite(m->origin.lon_deg) || !std::isfinite(m->origin.alt_m))
    finding("a manifest whose origin is not finite");
}

void check_blob(TileCache& c, const std::string& hash) {
  attempt([&] {
    c.has_blob(hash);
    bool corrupt = false;
    auto bytes = c.blob(hash, &corrupt);
    if (bytes && pl::store::content_hash(*bytes) != hash) finding("blob() returned bytes that do not hash to their hash");
    if (bytes && corrupt) finding("blob() returned bytes and said they were corrupt");
  });
}

// What the tile client reads: manifests (pinned and last used), key rows, blobs.
void read(TileCache& c, const std::string& known_hash) {
  for (const char* map : {"town", "depot"}) {
    attempt([&] { check_manifest(c.last_used(map)); });
    for (long long v : {1, 2, 7}) attempt([&] { check_manifest(c.manifest(map, v)); });
    for (long long v : {1, 2}) {
      std::vector<CachedTile> rows;
      attempt([&] { rows = c.tiles(map, v); });
      std::size_t n = 0;
      for (const auto& t : rows) {
        if (t.exists() && !pl::api::is_hash(t.hash)) finding("a key row whose hash is not 64 lowercase hex digits");
        if (t.exists() && ++n <= 4) check_blob(c, t.hash);
      }
    }
  }
  check_blob(c, known_hash);
  attempt([&] { c.blob_count(); });
}

// What the tile client writes, read back.
void write(TileCache& c) {
  const std::string bytes = "fresh tile bytes from the server";
  const std::string hash = pl::store::content_hash(bytes);
  attempt([&] {
    c.put_blob(hash, bytes);
    bool corrupt = false;
    auto back = c.blob(hash, &corrupt);
    if (!back || *back != bytes) suspect("put_blob's bytes are not read back");
  });
  attempt([&] {
    c.put_tiles("town", 3, {{{5, -6}, hash, 42}, {{-7, 8}, "", 0}});
    bool five = false, seven = false;
    for (const auto& t : c.tiles("town", 3)) {
      five |= t.key == pl::TileKey{5, -6} && t.hash == hash && t.points == 42;
      seven |= t.key == pl::TileKey{-7, 8} && !t.exists();
    }
    if (!five || !seven) suspect("put_tiles' rows are not read back");
  });
  attempt([&] {
    c.put_manifest({"town", 3, 20.0, 0.2, pl::GeoPoint{49.0, 8.4, 110.0}});
    auto last = c.last_used("town");
    if (!last || last->version != 3 || last->tile_size != 20.0) suspect("put_manifest's manifest is not the last used");
  });
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static WorkDir work("cache");
  static const std::string known_hash = pl::store::content_hash("cached tile 0/0 of town v1");
  const std::string input(reinterpret_cast<const char*>(data), size);
  InputFile file(work.dir(), input);
  suspicion.clear();
  bool opened = false;
  attempt([&] {
    TileCache cache(file.path());
    opened = true;
    read(cache, known_hash);
    write(cache);
  });
  if (!opened && !pl::fuzz::same_but_wal_switch(input, file.bytes())) finding("a refused open changed the file");
  if (!suspicion.empty() && !sqlite_finds_damage(work.dir(), input)) finding(suspicion);
  return 0;
}
