#include "tile_normals.hpp"

#include "pl/registration/normals.hpp"

namespace pl::client {

std::shared_ptr<const TileCloud> with_normals(TileCloud cloud, double map_voxel_m) {
  if (cloud.normals.size() != cloud.size()) {
    const double radius = registration::map_normal_radius(map_voxel_m > 0 ? map_voxel_m : 0.2);
    cloud.normals = registration::estimate_normals(cloud.points, radius);
  }
  return std::make_shared<const TileCloud>(std::move(cloud));
}

}  // namespace pl::client
