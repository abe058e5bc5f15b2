// The tiles of one map version that can no longer change (published or retired), in memory: what a
// region-of-interest query needs (key, content hash, points, bytes), found by key without a trip to
// the store, and the ROI answer written straight into its JSON text.
// Private to pl_server.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

#include "pl/common/tile_key.hpp"
#include "pl/schema/store.hpp"

namespace pl::server {

class VersionIndex {
 public:
  struct Tile {
    TileKey key;
    std::string hash;
    std::int64_t points = 0, bytes = 0;
  };

  // From the version's tiles as the store lists them (any order).
  VersionIndex(double tile_size, const std::vector<store::TileRecord>& tiles);

  double tile_size() const { return tile_size_; }
  std::size_t size() const { return tiles_.size(); }

  // What a map's manifest says of the version, summed once here rather than over the store's rows
  // on every request (a map of 50,000 tiles made each manifest a scan of them all).
  struct Totals {
    std::int64_t points = 0, bytes = 0;
    double min[3] = {0, 0, 0}, max[3] = {0, 0, 0};  // the tiles' points' box; zeros without tiles
  };
  const Totals& totals() const { return totals_; }

  // The tiles whose square has a point within `radius` of (x, y), ordered by (tx, ty): the keys of
  // the disc looked up one by one, or, when the disc spans more keys than the version has tiles,
  // every tile tested. Nothing for a negative or NaN radius.
  std::vector<const Tile*> in_disc(double x, double y, double radius) const;

 private:
  static std::uint64_t pack(const TileKey& k) {
    return (static_cast<std::uint64_t>(static_cast<std::uint32_t>(k.tx)) << 32) | static_cast<std::uint32_t>(k.ty);
  }
  double tile_size_;
  Totals totals_;
  std::vector<Tile> tiles_;  // ordered by (tx, ty)
  std::unordered_map<std::uint64_t, std::uint32_t> by_key_;
};

// The body of a ROI answer, byte for byte what nlohmann::json's dump() gives for
// {"version", "tile_size", "tiles": [{"tx", "ty", "hash", "url", "points", "bytes"}...], "drop"}
// (keys sorted, no spaces, a newline after), written directly: the answer is the server's most
// frequent JSON and building it as a json tree cost more than the rest of the query. The hashes
// must be api::is_hash's 64 lowercase hex digits, written as they are (the store checks every hash
// it reads, the API every have= hash); the map name is escaped.
std::string roi_body(const std::string& map, std::int64_t version, double tile_size, const std::vector<const VersionIndex::Tile*>& tiles,
                     const std::vector<std::string_view>& drop);

// A bounded set of indexes by (map, version), shared by the server's threads; the least recently
// built one goes first when full.
class VersionIndexCache {
 public:
  explicit VersionIndexCache(std::size_t capacity);
  std::shared_ptr<const VersionIndex> find(const std::string& map, std::int64_t version) const;
  void put(const std::string& map, std::int64_t version, std::shared_ptr<const VersionIndex> index);

 private:
  struct Impl;
  std::size_t capacity_;
  std::shared_ptr<Impl> impl_;
};

}  // namespace pl::server
