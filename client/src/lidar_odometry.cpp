#include "pl/client/lidar_odometry.hpp"

#include <cmath>

#include "pl/common/error.hpp"
#include "pl/common/pose.hpp"
#include "pl/registration/normals.hpp"
#include "pl/registration/pose_search.hpp"

namespace pl::client {

LidarOdometry::LidarOdometry(const LidarOdometryConfig& cfg) : cfg_(cfg) {
  if (cfg.scans < 1) throw Error("LidarOdometryConfig::scans must be at least 1");
  if (!(cfg.cell_m > 0) || !(cfg.normal_radius_m > 0)) throw Error("LidarOdometryConfig: cell_m and normal_radius_m must be positive");
}

LidarOdometry::~LidarOdometry() = default;

void LidarOdometry::reset() {
  fine_.reset();
  coarse_.reset();
  scans_.clear();
  points_.clear();
  normals_.clear();
}

registration::IcpResult LidarOdometry::track(const std::vector<Eigen::Vector3f>& points, const Eigen::Isometry3d& guess,
                                             bool wide, double yaw_range_deg) const {
  registration::IcpResult r;
  if (!fine_) {
    r.reject_reason = "no earlier scan";
    return r;
  }
  const int headings = cfg_.seed_yaw_deg > 0 ? static_cast<int>(std::floor(std::min(yaw_range_deg, cfg_.max_yaw_deg) / cfg_.seed_yaw_deg)) : 0;
  wide = wide || headings > 0;
  if (wide && !coarse_) {
    coarse_ = std::make_unique<registration::PointMap>(fine_->anchor(), 2.0);
    coarse_->add(1, points_, normals_);
  }
  Eigen::Isometry3d start = guess;
  if (headings > 0) {  // the heading of the best seed on the coarse map (turned about the vertical)
    const std::vector<Eigen::Vector3f> sparse = registration::subsample(points, 400);
    const registration::IcpConfig coarse = registration::coarse_icp(cfg_.icp);
    double best = -1.0;
    for (int k = -headings; k <= headings; ++k) {
      Eigen::Isometry3d seed = guess;
      seed.linear() = rotation_from_vector(Eigen::Vector3d(0, 0, k * cfg_.seed_yaw_deg * M_PI / 180.0)) * guess.linear();
      const registration::IcpResult c = registration::register_scan(*coarse_, sparse, seed, coarse);
      const double score = registration::registration_score(c);
      if (score > best) best = score, start = c.pose;
    }
  }
  r = wide ? registration::register_coarse_to_fine(*coarse_, *fine_, points, start, cfg_.icp)
           : registration::register_scan(*fine_, points, guess, cfg_.icp);
  if (r.accepted && r.inlier_share < cfg_.min_inlier_share) {
    r.accepted = false;
    r.reject_reason = "the scan does not fit the previous ones";
  }
  return r;
}

void LidarOdometry::add(const std::vector<Eigen::Vector3f>& points, const Eigen::Isometry3d& pose) {
  Placed placed;
  placed.points.reserve(points.size());
  for (const Eigen::Vector3f& p : points) placed.points.push_back(pose * p.cast<double>());
  placed.normals = registration::estimate_normals(placed.points, cfg_.normal_radius_m);
  // A jump of kilometres (a new start elsewhere) empties the local map.
  if (fine_ && (pose.translation() - fine_->anchor()).norm() > 2000.0) scans_.clear();
  scans_.push_back(std::move(placed));
  while (static_cast<int>(scans_.size()) > cfg_.scans) scans_.pop_front();
  points_.clear();
  normals_.clear();
  for (const Placed& s : scans_) {
    points_.insert(points_.end(), s.points.begin(), s.points.end());
    normals_.insert(normals_.end(), s.normals.begin(), s.normals.end());
  }
  fine_ = std::make_unique<registration::PointMap>(pose.translation(), cfg_.cell_m);
  fine_->add(1, points_, normals_);
  coarse_.reset();
}

}  // namespace pl::client
