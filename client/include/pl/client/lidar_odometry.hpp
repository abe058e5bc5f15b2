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
  registration::IcpConfig icp = [] {
    registration::IcpConfig c;
    c.kernel_m = 0.3;
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
  registration::IcpResult track(const std::vector<Eigen::Vector3f>& points, const Eigen::Isometry3d& guess, bool wide) const;
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
