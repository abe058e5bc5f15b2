// G-LOAM: a map from a drive. The scans are placed at the dataset's ground-truth poses, or at the
// poses of LiDAR odometry (LOAM), optionally corrected by a pose graph of keyframes with the drive's
// GPS fixes and with loop closures, then merged into one voxelized cloud. pl-map build runs it.
#pragma once

#include <cstddef>
#include <functional>
#include <optional>
#include <string>

#include "pl/common/geo.hpp"
#include "pl/common/pose.hpp"
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
  LoamConfig loam;            // its deskew and scan period are set from `deskew` and the dataset
  PoseGraphConfig graph;
  LoopClosureConfig loop;
};

// What a long build tells as it goes: progress(stage, done, total) for "lidar odometry", "loop
// closure" and "merging scans"; log(line) with a summary line at the end of each stage.
struct GloamObserver {
  std::function<void(const std::string& stage, std::size_t done, std::size_t total)> progress;
  std::function<void(const std::string& line)> log;
};

struct GloamResult {
  Trajectory poses;                // the LiDAR pose of every scan, with the scan times
  Trajectory odometry;             // with LiDAR poses: the odometry's, before the pose graph (moved as a
                                   // whole to start where the graph put the first scan); empty otherwise
  MapCloud map;                    // in the dataset's world frame (or the first scan's, see origin)
  std::optional<GeoPoint> origin;  // the map frame's geodetic origin; none in the first scan's frame
  std::size_t merged_scans = 0;
  double voxel_m = 0;              // of the merge
  std::string source;              // "ground truth", "lidar odometry + GPS pose graph", ...
  std::string report_json;         // keyframes, GPS edges, loops, errors against ground truth, times
};

// Throws pl::Error naming the fix for a config that cannot work (GPS or loops without LiDAR poses,
// a bad voxel or scan step) and for a dataset that lacks what the config needs (ground truth for
// poses = GroundTruth, GPS fixes for gps). Checked before any scan is read.
void check_gloam_config(const GloamConfig& cfg);
GloamResult build_gloam_map(const Dataset& ds, const GloamConfig& cfg, const GloamObserver& observer = {});

// Writes the odometry's trajectory, the report and the trajectory (KITTI, or TUM with the scan times
// when the name ends in .tum) when their paths are not empty, then the map (PCD with its origin);
// returns a "wrote ..." line for each. Throws pl::Error for an odometry path when no odometry ran.
std::string write_gloam_outputs(const GloamResult& r, const std::string& map_pcd, const std::string& trajectory,
                                const std::string& report, const std::string& odometry = {});

}  // namespace pl::maps
