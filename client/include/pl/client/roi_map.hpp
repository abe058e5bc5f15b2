// The map the localizer registers against: the points and normals of the tiles around the vehicle,
// as a registration point map whose parts are the tiles, updated only as tiles enter and leave
// (never rebuilt per scan).
//
// The anchor sits on the tile grid and cells divide the tile size exactly, so a tile owns its cells
// and leaves without a trace.
#pragma once

#include <Eigen/Core>

#include <map>
#include <memory>
#include <string>
#include <vector>

#include "pl/client/map_tile.hpp"
#include "pl/common/tile_key.hpp"
#include "pl/registration/point_map.hpp"

namespace pl::client {

struct RoiMapConfig {
  double cell_m = 1.0;  // hash cell edge, rounded so that cells divide the tile size; nearest-neighbour
                        // search is exact within cell_m / 2 and approximate up to cell_m
  double thin_m = 0;    // > 0: one point (with its normal) per thin_m voxel of each tile, for a coarse map
};

class RoiMap {
 public:
  // tile_size: the map's tile edge; anchor: any point near where the drive happens (map frame).
  RoiMap(double tile_size, const Eigen::Vector3d& anchor, const RoiMapConfig& cfg = {});

  // Makes the held tiles exactly `tiles` (key, content hash, decoded cloud): adds the new ones,
  // drops the ones not listed or whose hash changed, keeps the rest untouched. Tiles without normals
  // are skipped (the localizer needs them). Returns the number of tiles added + removed.
  std::size_t update(const std::vector<MapTile>& tiles);

  // The points to register against.
  const registration::PointMap& points_map() const { return *map_; }
  const Eigen::Vector3d& anchor() const { return map_->anchor(); }
  double cell_m() const { return map_->cell_m(); }
  std::size_t tiles() const { return held_.size(); }
  // The tiles held, in key order: the handles given to update() (their clouds are shared with the
  // tile source, not copied; the ROI keeps them alive). For logs and displays.
  std::vector<MapTile> held_tiles() const;
  std::size_t points() const { return map_->points(); }
  std::size_t cells() const { return map_->cells(); }

 private:
  double thin_m_ = 0;
  std::unique_ptr<registration::PointMap> map_;
  std::map<TileKey, MapTile> held_;
};

}  // namespace pl::client
