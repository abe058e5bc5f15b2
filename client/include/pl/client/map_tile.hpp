// One decoded map tile as the vehicle holds it: what the tile client keeps in memory and the ROI map
// is built from.
#pragma once

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

}  // namespace pl::client
