// Tiles straight from a local map store (SQLite, no server): for benchmarks, tests and localizing
// against a map on disk. Decoded tiles are kept by content hash.
#pragma once

#include <Eigen/Core>

#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "pl/client/map_tile.hpp"
#include "pl/common/geo.hpp"

namespace pl::client {

class StoreTiles {
 public:
  // The map's current version unless `version` > 0. Throws pl::Error naming what is missing.
  StoreTiles(const std::string& db_path, const std::string& map, long long version = 0);
  ~StoreTiles();
  double tile_size() const { return tile_size_; }
  long long version() const { return version_; }
  const GeoPoint& origin() const { return origin_; }  // of the map's ENU frame
  const std::optional<MapExtent>& extent() const { return extent_; }  // of the version's tiles (none: no tiles)
  // Every tile of the version within `radius` of `center`, decoded.
  std::vector<MapTile> near(const Eigen::Vector2d& center, double radius);
  // The version's places (opaque bytes, checked against their hash as the store reads them);
  // nothing when it has none. Read from the store at each call.
  std::optional<std::string> places() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  double tile_size_ = 0;
  GeoPoint origin_;
  long long version_ = 0;
  std::optional<MapExtent> extent_;
};

}  // namespace pl::client
