// The back end of map building: a pose graph over keyframes of a LiDAR odometry trajectory. Edges:
// the odometry chain (the relative pose between consecutive keyframes, weighted by the front end's
// registration information) and GPS positions of the antenna (pose * lever arm) with a robust loss,
// so that multipath fixes are down-weighted. Levenberg-Marquardt in Ceres; every scan is then placed
// at its odometry offset from the nearest preceding keyframe.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <cstddef>
#include <string>
#include <vector>

#include "pl/common/dataset.hpp"
#include "pl/common/pose.hpp"

namespace pl::maps {

using PoseList = std::vector<Pose, Eigen::aligned_allocator<Pose>>;
using Information6 = Eigen::Matrix<double, 6, 6>;

struct PoseGraphConfig {
  // Keyframes of the graph: the first scan, then a scan whenever the odometry moved this far or
  // turned this much since the last keyframe.
  double keyframe_m = 1.0;
  double keyframe_deg = 10.0;
  // Odometry edges. The front end's information is for unit measurement variance: it is divided by
  // odometry_sigma_m^2. Each scan's covariance adds up along an edge, and every scan also gets the
  // fallback information below (all of it when the front end gave none: degenerate or unregistered).
  double odometry_sigma_m = 0.05;
  double fallback_sigma_m = 0.2;     // per scan, translation
  double fallback_sigma_deg = 0.5;   // per scan, rotation
  // Drift floor: each edge's translation and rotation standard deviations are at least this share of
  // its length (metres) and this many degrees per metre, so that a long edge is never rigid.
  double min_drift_ratio = 0.002;
  double min_drift_deg_per_m = 0.002;
  // GPS edges: sigma = max(std_m, min_gps_std_m, the status' floor) horizontally, times
  // gps_vertical_factor vertically. Fixes with status none are dropped.
  double min_gps_std_m = 0.02;
  double gps_vertical_factor = 2.0;
  double float_min_std_m = 0.1, dgps_min_std_m = 0.5, single_min_std_m = 1.5;
  // Robust loss (Cauchy) on each GPS edge, its scale in standard deviations; and the normalized
  // residual (in standard deviations) above which a fix counts as an outlier in the report.
  double gps_kernel_sigmas = 3.0;
  double gps_outlier_sigmas = 6.0;
  int max_iterations = 100;
};

// A GPS fix tied to the drive: taken between scan `scan` and `scan + 1`, `fraction` of the way
// (0 = at the scan's time). The antenna position is in the world frame of the poses.
struct GpsEdge {
  std::size_t scan = 0;
  double fraction = 0.0;
  Eigen::Vector3d antenna_world = Eigen::Vector3d::Zero();
  double std_m = 0.0;  // reported horizontal standard deviation
  int status = kGpsNone;
  EIGEN_MAKE_ALIGNED_OPERATOR_NEW
};

struct PoseGraphReport {
  std::size_t keyframes = 0;
  std::size_t gps_edges = 0;     // used (status other than none)
  std::size_t gps_outliers = 0;  // normalized residual above gps_outlier_sigmas after the solve
  double gps_rms_before_m = 0.0, gps_rms_after_m = 0.0;  // antenna residuals, outliers excluded
  int iterations = 0;
  double solve_ms = 0.0;
  std::string termination;  // Ceres' termination type, or "no gps" / "skipped"
};

// Optimizes a trajectory (one odometry pose per scan, `information` one per scan or empty) with GPS
// edges; `lever_arm` is the antenna in the sensor frame. Without GPS the first pose is held fixed
// (and the chain comes back as it went in); with GPS the fixes set the absolute frame: the odometry
// is first aligned to them (yaw and translation) when they spread enough. Returns one pose per scan.
// Throws pl::Error on mismatched sizes or a GPS edge naming a scan out of range.
PoseList optimize_trajectory(const PoseList& odometry_poses, const std::vector<Information6>& information,
                             const std::vector<GpsEdge>& gps, const Eigen::Vector3d& lever_arm, const PoseGraphConfig& cfg,
                             PoseGraphReport* report = nullptr);

// The dataset's GPS fixes (status other than none) as edges: each tied to the scans around it in
// time, kept when the nearest scan is within max_dt_s. Throws pl::Error when the dataset has no
// geographic reference and it has fixes.
std::vector<GpsEdge> gps_edges_from_dataset(const Dataset& ds, double max_dt_s = 0.05);

}  // namespace pl::maps
