// The simulated vehicle's path: a LiDAR pose at any time, from a KITTI pose file or a built-in route.
#pragma once

#include <string>
#include <vector>

#include "pl/common/pose.hpp"

namespace pl::sim {

// Poses sampled densely in time, interpolated in between (linear translation, slerp rotation).
// The world frame is a local ENU frame (x east, y north, z up); the poses are LiDAR poses.
class SimTrajectory {
 public:
  SimTrajectory() = default;
  SimTrajectory(std::vector<double> times, std::vector<Pose, Eigen::aligned_allocator<Pose>> poses);

  double start_time() const { return times_.front(); }
  double end_time() const { return times_.back(); }
  Pose pose_at(double t) const;  // clamped to [start, end]
  // Distance travelled from the start to time t (along the sampled path).
  double distance_at(double t) const;
  double length() const { return cumulative_.back(); }
  // Time at which the path has covered distance s (inverse of distance_at; clamped).
  double time_at_distance(double s) const;
  const std::vector<double>& times() const { return times_; }
  // The same path driven `speed_scale` times as fast (times from the start divided by it).
  SimTrajectory retimed(double speed_scale) const;
  // The same path driven the other way: its time start + end - t is this one's time t, and the
  // vehicle is turned by 180 deg about its up axis (same place and height), facing the way it drives.
  SimTrajectory reversed() const;
  // The fastest speed between two samples, m/s.
  double max_speed() const;
  const std::vector<Pose, Eigen::aligned_allocator<Pose>>& poses() const { return poses_; }

 private:
  std::size_t segment(double t, double& frac) const;
  std::vector<double> times_;
  std::vector<Pose, Eigen::aligned_allocator<Pose>> poses_;
  std::vector<double> cumulative_;
};

// KITTI odometry ground truth (cam0 poses, 12 numbers a line) turned into LiDAR poses with the
// nominal axis change (x_cam = -y_velo, y_cam = -z_velo, z_cam = x_velo). Times come from
// `times_path`, or 10 Hz when it is empty.
SimTrajectory trajectory_from_kitti(const std::string& poses_path, const std::string& times_path);
// The same, for a file that holds LiDAR poses already (e.g. `pl-dataset poses` of a drive).
SimTrajectory trajectory_from_lidar_poses(const std::string& poses_path, const std::string& times_path);
// The times file that goes with a KITTI pose file: `times-NN.txt` beside `NN.txt`, else `times.txt`
// beside it; empty when there is none.
std::string find_times_for(const std::string& poses_path);

// Built-in routes, driven at town speeds with slowing in the turns, LiDAR 1.73 m above the road:
//   loop    a ~600 m town loop (rounded rectangle with a kink), gentle grades
//   estate  an industrial-estate loop (~900 m) around warehouses, across an open square
SimTrajectory builtin_route(const std::string& name);
bool is_builtin_route(const std::string& name);

// Height of the LiDAR above the road surface.
constexpr double kLidarHeight = 1.73;

}  // namespace pl::sim
