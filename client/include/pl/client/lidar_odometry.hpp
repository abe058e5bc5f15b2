// LiDAR odometry: each scan registered to a local map of the last few scans (placed where the
// localizer put them), so the prediction of the next scan is measured, not assumed. It needs no map
// tile: it carries the vehicle across a stretch the map cannot fix, and it notices a jump (a scan
// that fits none of the recent ones).
#pragma once

#include <Eigen/Geometry>

#include <deque>
#include <memory>
#include <vector>

#include "pl/registration/icp.hpp"
#include "pl/registration/point_map.hpp"

namespace pl::client {

struct LidarOdometryConfig {
  int scans = 4;                // scans in the local map
  double cell_m = 1.0;          // the local map's hash cell (registration points are ~1 m apart)
  double normal_radius_m = 2.0; // the normals of a scan from its own points within this
  double min_inlier_share = 0.75;  // a scan pairing fewer of its points with the local map: no increment
  // Take only the increment in the ground plane (along, across, yaw) and leave height, roll and pitch
  // to the prediction: the local map holds the sparse registration points of a few 16-beam scans,
  // whose ground rings fix the height and tilt poorly, and the map registration measures those three
  // absolutely on every scan. Drive 0005, LiDAR only, every 1st-4th odd scan (all k phases): APE mean
  // 0.055 / 0.054 / 0.055 / 0.057 m planar, 0.056 / 0.060 / 0.060 / 0.061 m with all six (a start
  // 0.19 m off in height led the registration into a worse minimum on frames 47-57).
  bool planar = true;
  // A wide track (a motion known worse than the fine basin) seeds the heading every seed_yaw_deg within
  // 3 sigma of the motion's yaw, and at least within seed_range_deg (momentum's window lags a turn
  // rate that builds up: entering a bend it underestimates its own error), at most max_yaw_deg, on the
  // coarse local map; the best seed is refined.
  // Drive 0005 four times as fast: a bend's momentum was 12 deg off, past the 10 deg basin, and such
  // scans searched the map instead, not ok until the next confirmed them (58 ok / 19 degraded of 77
  // without the seeds, 73 / 4 with them).
  double seed_yaw_deg = 6.0;
  double seed_range_deg = 18.0;
  double max_yaw_deg = 30.0;
  registration::IcpConfig icp = [] {
    registration::IcpConfig c;
    c.kernel_m = 0.5;  // as the localizer's registration (localizer.hpp)
    c.max_iterations = 20;
    c.converged_m = 3e-3;
    c.converged_rad = 3e-4;
    return c;
  }();
};

class LidarOdometry {
 public:
  explicit LidarOdometry(const LidarOdometryConfig& cfg = {});
  ~LidarOdometry();

  bool empty() const { return scans_.empty(); }
  // Registers `points` (sensor frame) to the local map from `guess` (map frame): coarse-to-fine when
  // `wide` (a guess off by up to ~2 m). The result is `accepted` only when it also pairs at least
  // min_inlier_share of the points.
  // `yaw_range_deg` > 0: the heading is searched within it (seeds, see seed_yaw_deg), the best one
  // refined as `wide`.
  registration::IcpResult track(const std::vector<Eigen::Vector3f>& points, const Eigen::Isometry3d& guess, bool wide,
                                double yaw_range_deg = 0.0) const;
  // The scan joins the local map at `pose` (map frame); the oldest leaves.
  void add(const std::vector<Eigen::Vector3f>& points, const Eigen::Isometry3d& pose);
  void reset();

 private:
  LidarOdometryConfig cfg_;
  struct Placed {
    std::vector<Eigen::Vector3d> points;  // map frame
    std::vector<Eigen::Vector3f> normals;
  };
  std::deque<Placed> scans_;
  // Rebuilt as one part from every held scan at each add: parts may not share cells, and the
  // scans of a local map overlap almost everywhere. The coarse map only when a wide track asks.
  std::vector<Eigen::Vector3d> points_;
  std::vector<Eigen::Vector3f> normals_;
  std::unique_ptr<registration::PointMap> fine_;
  mutable std::unique_ptr<registration::PointMap> coarse_;
};

}  // namespace pl::client
