// Maps from drives with known poses: scans merged in the world frame into a voxel grid (exact
// centroids per voxel), a normal per point, and the cut into tiles.
#pragma once

#include <functional>
#include <map>
#include <vector>

#include "pl/common/tile_codec.hpp"
#include "pl/common/tile_key.hpp"
#include "pl/common/voxel.hpp"
#include "pl/recordings/dataset.hpp"
#include "pl/registration/cell_table.hpp"
#include "pl/registration/place_index.hpp"

namespace pl::maps {

// Accumulates points into voxels (sums in double, first-seen order) so that a map of thousands of
// scans is one centroid per voxel over all of them, not a centroid of centroids. With a scan number
// and a drive, each voxel also counts the scans that returned from it and the drives that did.
class VoxelAccumulator {
 public:
  explicit VoxelAccumulator(double voxel);
  void add(const Eigen::Vector3d& p, float intensity);
  // scan: numbered from 1, ascending; drive < 64.
  void add(const Eigen::Vector3d& p, float intensity, std::uint32_t scan, unsigned drive);
  std::size_t size() const { return sums_.size(); }
  Points3d centroids(std::vector<float>& intensity) const;
  std::vector<std::uint32_t> scans() const;   // per voxel, in the order of centroids()
  std::vector<std::uint64_t> drives() const;  // per voxel: bit d set when drive d returned from it

 private:
  struct Sum {
    double x, y, z, i;
    std::uint32_t n;
    std::uint32_t scans = 0, last_scan = 0;
    std::uint64_t drives = 0;
  };
  Sum& accumulate(const Eigen::Vector3d& p, float intensity);  // the point added to its voxel's sums
  double inv_;
  registration::CellTable<std::uint32_t> index_;  // voxel -> its sums
  std::uint64_t last_key_ = ~std::uint64_t{0};     // the voxel of the last point added (no key is all ones)
  std::uint32_t last_at_ = 0;
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
  std::vector<std::uint32_t> seen;    // per point: the scans that returned from its voxel
  std::vector<std::uint64_t> drives;  // per point: bit d set when drive d returned from its voxel
  registration::PlaceIndex places;  // world frame, like the points
  // Keeps the points whose `keep` is true (and their intensity, seen and drives).
  void keep_only(const std::vector<bool>& keep);
};

// Merges the dataset's scans placed by `poses` (one per scan). `progress(done, total)` may be null.
MapCloud build_map_from_poses(const Dataset& ds, const Trajectory& poses, const MapBuildConfig& cfg,
                              const std::function<void(std::size_t, std::size_t)>& progress = {});

// A drive of a map built from several: its dataset and a pose per scan in the map's frame.
struct PlacedDrive {
  const Dataset* dataset = nullptr;
  const Trajectory* poses = nullptr;
  bool deskew = false;  // motion compensation for this drive (cfg.deskew is not read)
  double sweep_s = 0.1;
};

// Merges several drives, in order, into one map (at most 64). progress(done, total) over all scans.
MapCloud build_map_from_drives(const std::vector<PlacedDrive>& drives, const MapBuildConfig& cfg,
                               const std::function<void(std::size_t, std::size_t)>& progress = {});

// The scans build_map_from_drives merges, in its order, each loaded and prepared as it merges them
// (crops, motion compensation), with the sensor pose: for a second pass over the same points.
void for_each_merged_scan(const std::vector<PlacedDrive>& drives, const MapBuildConfig& cfg,
                          const std::function<void(std::size_t drive, std::size_t scan, const Pose& sensor, const Scan& kept)>& visit);

// The scan's points moved to where the sensor was at the scan's time, `sweep` the sensor's motion
// over one sweep of sweep_s (its own frame); each point timed by `times` (seconds from the scan's
// time, one per point) when given, else by its azimuth.
void compensate_sweep(Scan& scan, const std::vector<float>& times, const Pose& sweep, double sweep_s);

// (Normals: pl::registration::estimate_normals.)

// The points of each tile (half-open tile boxes), ordered by key.
std::map<TileKey, TileCloud> cut_into_tiles(const Points3d& points, const std::vector<Eigen::Vector3f>& normals,
                                            const std::vector<float>& intensity, const TileGrid& grid);

}  // namespace pl::maps
