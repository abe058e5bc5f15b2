// One decoded map tile as the vehicle holds it: what the tile client keeps in memory and the ROI map
// is built from; and the extent of a map version's tiles.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <memory>
#include <string>

#include "pl/common/tile_codec.hpp"
#include "pl/common/tile_key.hpp"

namespace pl::client {

struct MapTile {
  TileKey key;
  std::string hash;  // content hash (the server's ETag): SHA-256 of the Draco bytes, 64 lowercase hex
  std::shared_ptr<const TileCloud> cloud;  // decoded points (map ENU frame), normals, intensity
  std::size_t bytes = 0;                   // Draco bytes (0 when not known)
};

// The x, y extent of a map version's points in its ENU frame, metres.
struct MapExtent {
  double min_x = 0, min_y = 0, max_x = 0, max_y = 0;
  // How far (x, y) lies outside the extent; 0 inside.
  double distance(double x, double y) const {
    return std::hypot(std::max({min_x - x, 0.0, x - max_x}), std::max({min_y - y, 0.0, y - max_y}));
  }
};

}  // namespace pl::client
