// The back end of map building: a pose graph over keyframes of the LiDAR odometry of one or more
// drives (each its own chain). Edges:
// the odometry chain (the relative pose between consecutive keyframes, weighted by the front end's
// registration information), GPS positions of the antenna (pose * lever arm) with a robust loss, so
// that multipath fixes are down-weighted, and loop closures (relative poses between keyframes far
// apart along the drive, measured by ICP and verified before they enter; see loop_closure.hpp). Levenberg-Marquardt in
// Ceres, re-solved as loops are added; every scan is then placed at its odometry offset from the
// nearest preceding keyframe.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <cstddef>
#include <memory>
#include <string>
#include <vector>

#include "pl/common/pose.hpp"
#include "pl/recordings/dataset.hpp"

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
  // Tilt: GPS positions pin the trajectory's roll and pitch only weakly (not at all along a straight
  // road, where rolling the whole drive about it only moves the antenna a little), so the first
  // keyframe keeps the odometry's gravity direction: a prior of this many degrees.
  double tilt_prior_deg = 0.5;
  int max_iterations = 100;
  // Loop edges: a robust loss (Cauchy) at this many standard deviations; 0: none. None by default:
  // loops are verified before they enter, and the drift they correct is systematic, many times what
  // the odometry's random-walk covariance allows, so a robust loss would weigh true loops away.
  double loop_kernel_sigmas = 0.0;
};

// Whether `pose` starts a new keyframe after the keyframe at `last` (moved keyframe_m or turned
// keyframe_deg). The rule is causal: callers may apply it while the odometry runs.
bool is_new_keyframe(const Pose& last, const Pose& pose, const PoseGraphConfig& cfg);

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

// One drive's share of the graph's report.
struct PoseGraphDriveReport {
  std::size_t keyframes = 0;
  std::size_t gps_edges = 0, gps_outliers = 0;
  double gps_rms_before_m = 0.0, gps_rms_after_m = 0.0;
  bool fixed = false;  // held as given (a base map's drive)
};

struct PoseGraphReport {
  std::size_t keyframes = 0;
  std::size_t gps_edges = 0;     // used (status other than none)
  std::size_t gps_outliers = 0;  // normalized residual above gps_outlier_sigmas after the solve
  double gps_rms_before_m = 0.0, gps_rms_after_m = 0.0;  // antenna residuals, outliers excluded
  std::size_t loop_edges = 0;
  int solves = 0;
  int iterations = 0;     // over all solves
  double solve_ms = 0.0;  // over all solves
  std::string termination;  // Ceres' termination type of the last solve, "skipped" (no poses) or "no gps or loops"
  std::vector<PoseGraphDriveReport> drives;  // one per drive, in order
};

// One drive's chain: its odometry (own frame), the front end's information, its GPS fixes (antenna
// positions in the map frame) and the antenna's lever arm in the sensor frame.
struct GraphDrive {
  PoseList odometry;
  std::vector<Information6> information;  // one per scan, or empty
  std::vector<GpsEdge> gps;
  Eigen::Vector3d lever_arm = Eigen::Vector3d::Zero();
  // Its poses are known (a base map's drive, already in the map frame): its keyframes are held
  // constant and the other drives join it.
  bool fixed = false;
  EIGEN_MAKE_ALIGNED_OPERATOR_NEW
};

// The graph, kept between solves so that loop edges can be added as they are found.
class PoseGraph {
 public:
  // Keyframes from the odometry (one pose per scan, `information` one per scan or empty); GPS edges
  // resolved onto them. Without GPS the first keyframe is held fixed; with GPS the fixes set the
  // absolute frame: the odometry is first aligned to them (yaw and translation) when they spread
  // enough. Throws pl::Error on mismatched sizes or a GPS edge naming a scan out of range.
  PoseGraph(const PoseList& odometry_poses, const std::vector<Information6>& information, const std::vector<GpsEdge>& gps,
            const Eigen::Vector3d& lever_arm, const PoseGraphConfig& cfg);
  // Several drives, keyframes numbered drive after drive. Each drive with GPS is aligned to its own
  // fixes. The frame is held by the fixed drives, else by the fixes, else by the first drive's first
  // keyframe. A drive with neither fixes nor a fixed pose floats until a loop joins it (join_drive):
  // until then its first keyframe is held where it is.
  PoseGraph(const std::vector<GraphDrive>& drives, const PoseGraphConfig& cfg);
  ~PoseGraph();
  PoseGraph(const PoseGraph&) = delete;
  PoseGraph& operator=(const PoseGraph&) = delete;

  // Scan index of each keyframe within its drive (ascending per drive; each drive's first is scan 0).
  const std::vector<std::size_t>& keyframes() const;
  std::size_t drives() const;
  std::size_t drive_of(std::size_t keyframe) const;
  std::size_t first_keyframe(std::size_t drive) const;  // the drive's keyframes: first .. first of the next
  // Whether the drive is tied to the map frame: fixed, with GPS fixes, the frame's own first drive,
  // or joined by a loop.
  bool joined(std::size_t drive) const;
  bool fixed(std::size_t drive) const;  // held as given (GraphDrive::fixed)
  // Moves a floating drive's whole estimate by `correction` (map frame, on the left) and lets its
  // first keyframe go: the loop just found ties it to the others.
  void join_drive(std::size_t drive, const Pose& correction);
  // Current estimate of keyframe k, and its pose from the odometry alone (same frame as the input).
  Pose keyframe_pose(std::size_t k) const;
  const Pose& odometry_pose(std::size_t k) const;
  // A measured relative pose T_a^-1 T_b between keyframes a and b (e.g. ICP on a revisit), with its
  // information (perturbation T_b * exp(d), d = (translation, rotation)). Returns the edge's id.
  std::size_t add_loop(std::size_t a, std::size_t b, const Pose& relative, const Information6& information);
  // Takes a loop edge out again (one found inconsistent with the rest of the graph).
  void remove_loop(std::size_t id);
  // The estimate (every keyframe), to put back after a trial.
  std::vector<double> save() const;
  void restore(const std::vector<double>& state);
  // The GPS edges' cost at the current estimate (robust loss applied; 0 without GPS): a loop that
  // pulls the graph away from the fixes raises it.
  double gps_cost() const;
  // Levenberg-Marquardt from the current estimate (at most max_iterations; 0: the config's).
  void optimize(int max_iterations = 0);
  // One pose per scan of the (first) drive: each at its odometry offset from its keyframe.
  PoseList poses(std::size_t drive = 0) const;
  // Keyframes, edges, GPS residuals before (the odometry) and now, solve statistics.
  PoseGraphReport report() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// The graph built and solved once (no loops): one pose per scan. `lever_arm` is the antenna in the
// sensor frame. Without GPS the chain comes back as it went in.
PoseList optimize_trajectory(const PoseList& odometry_poses, const std::vector<Information6>& information,
                             const std::vector<GpsEdge>& gps, const Eigen::Vector3d& lever_arm, const PoseGraphConfig& cfg,
                             PoseGraphReport* report = nullptr);

// The dataset's GPS fixes (status other than none) as edges: each tied to the scans around it in
// time, kept when the nearest scan is within max_dt_s. Throws pl::Error when the dataset has no
// geographic reference and it has fixes.
std::vector<GpsEdge> gps_edges_from_dataset(const Dataset& ds, double max_dt_s = 0.05);

}  // namespace pl::maps
