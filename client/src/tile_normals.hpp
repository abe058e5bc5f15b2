// Tiles stored without normals (pl-map's default) get them on the vehicle when decoded: ICP's
// point-to-plane pairs need them.
#pragma once

#include <memory>

#include "pl/common/tile_codec.hpp"

namespace pl::client {

// The cloud, with normals estimated from its own points within 3 x the map's voxel (the radius
// pl-map gives the normals it stores; 0.6 m when the map names no voxel) when it has none.
std::shared_ptr<const TileCloud> with_normals(TileCloud cloud, double map_voxel_m);

}  // namespace pl::client
