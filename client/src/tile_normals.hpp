// Tiles stored without normals (pl-map's default) get them on the vehicle when decoded: ICP's
// point-to-plane pairs need them.
#pragma once

#include <memory>

#include "pl/common/tile_codec.hpp"

namespace pl::client {

// The cloud, with normals estimated from its own points within registration::map_normal_radius of
// the map's voxel (0.2 m when the map names none) when it has none.
std::shared_ptr<const TileCloud> with_normals(TileCloud cloud, double map_voxel_m);

}  // namespace pl::client
