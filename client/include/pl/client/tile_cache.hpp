// The vehicle's disk cache of map tiles: one SQLite file (WAL) that keeps tile bytes by content hash,
// checked against that hash on every read, and what the vehicle needs to localize while the server
// is down: the manifest of each map version it used and the (map, version, tx, ty) -> hash rows it
// learned from region-of-interest answers.
//
// A TileCache is one SQLite connection: use it from one thread at a time (open one per thread).
// Several connections and processes may share the file. Every failure is a pl::Error whose message
// starts with the file's path. A damaged file (SQLite's reports of damage, values of the wrong type
// or out of range, a schema other than this build's own) gives "PATH: the tile cache is damaged
// (WHAT): delete it (...)"; nothing is written to a file that is refused at opening.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "pl/common/geo.hpp"
#include "pl/common/tile_key.hpp"

namespace pl::client {

// What the vehicle keeps of a map version's manifest.
struct CachedManifest {
  std::string map;
  long long version = 0;
  double tile_size = 0;  // metres
  double voxel_size = 0;
  GeoPoint origin;  // of the map's ENU frame
};

// What a version holds at one key: the content hash of its tile, or no tile at all (empty hash:
// the server's answer covered the key and listed nothing there).
struct CachedTile {
  TileKey key;
  std::string hash;  // SHA-256 of the Draco bytes, lowercase hex; empty: no tile at this key
  long long points = 0;
  bool exists() const { return !hash.empty(); }
};

class TileCache {
 public:
  // Opens the file, creating it when missing. Throws pl::Error naming the file when it cannot be
  // opened or written, is not a tile cache, or was written by a newer build.
  explicit TileCache(const std::string& path);
  ~TileCache();
  TileCache(TileCache&&) noexcept;
  TileCache& operator=(TileCache&&) noexcept;
  TileCache(const TileCache&) = delete;
  TileCache& operator=(const TileCache&) = delete;

  const std::string& path() const { return path_; }

  // Tile bytes by content hash. Bytes that no longer hash to `hash` (a damaged disk, a torn write)
  // are deleted and never returned: the result is then empty and *corrupt (when given) is true.
  std::optional<std::string> blob(const std::string& hash, bool* corrupt = nullptr);
  bool has_blob(const std::string& hash) const;
  // Stores bytes under their hash (the caller has checked that `hash` is their SHA-256: a wrong one
  // is caught by blob() as corruption; one that is not 64 lowercase hex digits is refused). Idempotent.
  void put_blob(const std::string& hash, std::string_view bytes);
  std::size_t blob_count() const;

  // Manifests. put_manifest stores (or replaces) one and makes it the last used of its map; it
  // refuses a tile size that is not a positive number, a voxel size that is negative or not finite,
  // and an origin that is not finite.
  void put_manifest(const CachedManifest& m);
  std::optional<CachedManifest> manifest(const std::string& map, long long version) const;
  std::optional<CachedManifest> last_used(const std::string& map) const;

  // The key -> hash rows of a version, written in one transaction (a row replaces the key's old one;
  // a hash must be empty or 64 lowercase hex digits).
  void put_tiles(const std::string& map, long long version, const std::vector<CachedTile>& tiles);
  std::vector<CachedTile> tiles(const std::string& map, long long version) const;

  // A version's signed manifest as the server sent it (pl/schema/signed_manifest.hpp), kept so
  // that a client with fleet keys starts with the server down. Stored as given: the reader
  // verifies it (a body altered on disk fails its signature).
  void put_signed_manifest(const std::string& map, long long version, std::string_view body);
  std::optional<std::string> signed_manifest(const std::string& map, long long version) const;
  // The highest version of the map with a signed manifest kept (not verified here).
  std::optional<long long> newest_signed_version(const std::string& map) const;

 private:
  std::string path_;
  void* db_ = nullptr;  // sqlite3*
};

}  // namespace pl::client
