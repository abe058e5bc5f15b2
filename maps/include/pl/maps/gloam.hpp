// G-LOAM: a map from one drive or several. The scans are placed at the datasets' ground-truth poses,
// or at the poses of LiDAR odometry (LOAM, each drive its own chain), optionally corrected by one
// pose graph of keyframes with every drive's GPS fixes and with loop closures within and between
// drives, then merged into one voxelized cloud. pl-map build runs it.
//
// The map's frame is the first drive's world frame. Another drive's ground truth and GPS fixes are
// brought into it through their geodetic reference (both datasets' projections of the same points);
// drives without one are taken to share the first's frame.
#pragma once

#include <cstddef>
#include <functional>
#include <optional>
#include <string>

#include "pl/common/geo.hpp"
#include "pl/common/pose.hpp"
#include "pl/maps/free_space.hpp"
#include "pl/maps/loam.hpp"
#include "pl/maps/loop_closure.hpp"
#include "pl/maps/map_builder.hpp"
#include "pl/maps/pose_graph.hpp"
#include "pl/recordings/dataset.hpp"

namespace pl::maps {

enum class PoseSource { GroundTruth, Lidar };
// auto: the LiDAR odometry deskews recordings without meta.json (KITTI sweeps while moving) and drives
// with point_times/; the merged map only the latter.
enum class Deskew { Auto, On, Off };

// The merge's defaults: 0.2 m voxels, every scan, returns from 2 to 80 m.
inline MapBuildConfig gloam_merge_defaults() {
  MapBuildConfig c;
  c.scan.min_range_m = 2.0;
  c.scan.max_range_m = 80.0;
  return c;
}

struct GloamConfig {
  PoseSource poses = PoseSource::GroundTruth;
  // With poses = Lidar only: a pose graph over the odometry with the GPS fixes (the ground truth is
  // then not used at all), and loop closures found by position and by place, verified by ICP.
  bool gps = false;
  bool loops = false;
  Deskew deskew = Deskew::Auto;
  MapBuildConfig merge = gloam_merge_defaults();  // voxel, which scans (`every` thins the map only), crops
  double loop_voxel_m = 0.3;  // the keyframe clouds kept for loop closure (merge crops, this voxel)
  // Things that moved during the drives left out of the merged map (free_space.hpp), by the rays of
  // every merged scan of every drive. Off by default: on drive 0005 it leaves the localizer's
  // figures as they were, and one real drive is too little evidence to change every map (docs/g-loam.md).
  bool remove_moving = false;
  FreeSpaceConfig free_space;
  LoamConfig loam;            // its deskew and scan period are set from `deskew` and the dataset
  PoseGraphConfig graph;
  LoopClosureConfig loop;
};

// What a long build tells as it goes: progress(stage, done, total) for "lidar odometry", "loop
// closure", "merging scans" and "removing moving things"; log(line) with a summary line at the end of each stage.
struct GloamObserver {
  std::function<void(const std::string& stage, std::size_t done, std::size_t total)> progress;
  std::function<void(const std::string& line)> log;
};

// One drive's poses in the map's frame.
struct GloamDrive {
  std::string dataset;             // its path, as given
  Trajectory poses;                // the LiDAR pose of every scan, with the scan times
  Trajectory odometry;             // with LiDAR poses: the odometry's, before the pose graph (moved as a
                                   // whole to start where the graph put its first scan); empty otherwise
  bool merge_deskew = false;       // the merge corrected its sweeps, each of sweep_s
  double sweep_s = 0.1;
};

// A base map's drives (pl-map build --base-map, drive_record.hpp): the first poses.size() drives given
// are placed at these poses (map frame, one per scan), held fixed in the pose graph and merged first,
// so that the voxels the other drives do not reach keep their points to the bit.
struct GloamBase {
  std::vector<Trajectory> poses;
  std::vector<bool> deskew;        // per drive: the base map's merge corrected its sweeps (checked against cfg)
  std::optional<GeoPoint> origin;  // the base map's; the map keeps it
};

struct GloamResult {
  std::vector<GloamDrive> drives;  // in the order given
  std::size_t base_drives = 0;     // the first base_drives of them are the base map's
  MapCloud map;                    // in the first dataset's world frame (or its first scan's, see origin)
  std::optional<GeoPoint> origin;  // the map frame's geodetic origin; none in the first scan's frame
  std::size_t merged_scans = 0;
  double voxel_m = 0;              // of the merge
  MapBuildConfig merge;            // the merge's settings
  std::string source;              // "ground truth", "lidar odometry + GPS pose graph", ...
  std::string report_json;         // keyframes, GPS edges, loops, errors against ground truth, times
};

// Throws pl::Error naming the fix for a config that cannot work (GPS or loops without LiDAR poses,
// a bad voxel or scan step) and for a dataset that lacks what the config needs (ground truth for
// poses = GroundTruth, GPS fixes for gps). Checked before any scan is read.
void check_gloam_config(const GloamConfig& cfg);
// Several drives: a drive that nothing ties to the map (no GPS fixes, no loop to a drive that is
// tied) is refused by name, as is a second drive with LiDAR poses and neither gps nor loops. With a
// base, `drives` starts with the base map's drives (their datasets opened again).
GloamResult build_gloam_map(const std::vector<const Dataset*>& drives, const GloamConfig& cfg, const GloamObserver& observer = {},
                            const GloamBase& base = {});
GloamResult build_gloam_map(const Dataset& ds, const GloamConfig& cfg, const GloamObserver& observer = {});

// The paths to write (empty: not written); trajectories and odometry one per drive after the base
// map's, or none.
struct GloamOutputs {
  std::string map_pcd, report;
  std::vector<std::string> trajectories, odometry;
};
// pl::Error for a number of trajectory or odometry paths other than `drives` (none is fine).
void check_gloam_outputs(const GloamOutputs& out, std::size_t drives);
// Writes the odometry's trajectories, the report and the trajectories (KITTI, or TUM with the scan
// times when the name ends in .tum), then the map (PCD with its origin), its places and its drive
// record (drive_record.hpp: what a later --base-map build reads); returns a
// "wrote ..." line for each. Throws pl::Error for odometry paths when no odometry ran, and for a
// number of trajectory paths other than the drives'.
std::string write_gloam_outputs(const GloamResult& r, const GloamOutputs& out);

}  // namespace pl::maps
