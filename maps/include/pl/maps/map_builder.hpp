// Maps from drives with known poses: scans merged in the world frame into a voxel grid (exact
// centroids per voxel), a normal per point, and the cut into tiles.
#pragma once

#include <functional>
#include <map>
#include <unordered_map>
#include <vector>

#include "pl/common/tile_codec.hpp"
#include "pl/common/tile_key.hpp"
#include "pl/common/voxel.hpp"
#include "pl/recordings/dataset.hpp"
#include "pl/registration/place_index.hpp"

namespace pl::maps {

// Accumulates points into voxels (sums in double, first-seen order) so that a map of thousands of
// scans is one centroid per voxel over all of them, not a centroid of centroids.
class VoxelAccumulator {
 public:
  explicit VoxelAccumulator(double voxel);
  void add(const Eigen::Vector3d& p, float intensity);
  std::size_t size() const { return sums_.size(); }
  Points3d centroids(std::vector<float>& intensity) const;

 private:
  struct Sum {
    double x, y, z, i;
    std::uint32_t n;
  };
  double inv_;
  std::unordered_map<VoxelIndex, std::uint32_t, VoxelIndexHash> index_;
  std::vector<Sum> sums_;
};

struct MapBuildConfig {
  double voxel_m = 0.2;
  ScanPrepConfig scan;  // crops applied to every scan before merging (all beams by default)
  std::size_t first = 0, last = SIZE_MAX, every = 1;  // which scans
  // Places for relocalization: the descriptor of a merged scan (levelled by its pose) whenever the
  // sensor has moved this far since the last place; 0: none.
  double place_spacing_m = 2.0;
  // Motion compensation: each scan's points moved to where the sensor was at the scan's time, by
  // the motion between its neighbours' poses (constant velocity over the sweep of sweep_s), each
  // point's time from its azimuth.
  bool deskew = false;
  double sweep_s = 0.1;
  registration::PlaceDescriptorConfig place;
};

struct MapCloud {
  Points3d points;               // world frame of the dataset
  std::vector<float> intensity;  // one per point
  registration::PlaceIndex places;  // world frame, like the points
};

// Merges the dataset's scans placed by `poses` (one per scan). `progress(done, total)` may be null.
MapCloud build_map_from_poses(const Dataset& ds, const Trajectory& poses, const MapBuildConfig& cfg,
                              const std::function<void(std::size_t, std::size_t)>& progress = {});

// (Normals: pl::registration::estimate_normals.)

// The points of each tile (half-open tile boxes), ordered by key.
std::map<TileKey, TileCloud> cut_into_tiles(const Points3d& points, const std::vector<Eigen::Vector3f>& normals,
                                            const std::vector<float>& intensity, const TileGrid& grid);

}  // namespace pl::maps
