// Generated scenes as the tiles a localizer holds: the surfaces of scene.hpp sampled every `step`
// metres, cut into tiles (the hash names a tile's content, as the server's does).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "pl/client/map_tile.hpp"
#include "scene.hpp"

namespace pl::test {

inline std::vector<pl::client::MapTile> map_tiles(const std::vector<Surface>& surfaces, double step = 0.2, double tile_size = 20.0) {
  std::vector<pl::client::MapTile> out;
  for (auto& [key, cloud] : surface_tiles(surfaces, step, tile_size))
    out.push_back({key, std::to_string(key.tx) + "," + std::to_string(key.ty) + "/" + std::to_string(cloud.size()),
                   std::make_shared<const pl::TileCloud>(std::move(cloud))});
  return out;
}

}  // namespace pl::test
