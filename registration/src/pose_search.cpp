#include "pl/registration/pose_search.hpp"

#include <algorithm>
#include <cmath>

#include "pl/common/pose.hpp"

namespace pl::registration {

bool search_pose(const PointMap& coarse, const PointMap& fine, const std::vector<Eigen::Vector3f>& scan,
                 const Eigen::Isometry3d& guess, const PoseSearch& search, const IcpConfig& icp, Eigen::Isometry3d& pose_out) {
  IcpConfig wide = icp;
  wide.max_pair_m = 2.0;
  wide.kernel_start_m = 2.0;
  wide.kernel_m = 0.5;
  wide.max_iterations = 12;
  // The seeds only have to find the right basin: 400 of the scan's points, evenly taken.
  std::vector<Eigen::Vector3f> sparse;
  const std::size_t stride = std::max<std::size_t>(1, scan.size() / 400);
  for (std::size_t i = 0; i < scan.size(); i += stride) sparse.push_back(scan[i]);
  struct Candidate {
    Eigen::Isometry3d pose;
    double score;
  };
  std::vector<Candidate> coarse_results;
  const double yaw0 = yaw_of(guess);
  const int np = static_cast<int>(std::floor(search.radius_m / search.position_step_m));
  const int ny = static_cast<int>(std::floor(search.yaw_range_deg / search.yaw_step_deg));
  for (int ix = -np; ix <= np; ++ix)
    for (int iy = -np; iy <= np; ++iy) {
      if (std::hypot(ix, iy) * search.position_step_m > search.radius_m + 1e-9) continue;
      for (int k = -ny; k <= ny; ++k) {
        const Eigen::Vector3d p = guess.translation() + search.position_step_m * Eigen::Vector3d(ix, iy, 0);
        const Eigen::Isometry3d seed = make_pose(p.x(), p.y(), p.z(), 0, 0, yaw0 + k * search.yaw_step_deg * M_PI / 180.0);
        const IcpResult r = register_scan(coarse, sparse, seed, wide);
        coarse_results.push_back({r.pose, r.inlier_share / (0.05 + r.rms_m)});
      }
    }
  std::sort(coarse_results.begin(), coarse_results.end(),
            [](const Candidate& a, const Candidate& b) { return a.score > b.score; });
  bool found = false;
  double best = -1;
  for (std::size_t i = 0; i < coarse_results.size() && i < 5; ++i) {
    const IcpResult r = register_scan(fine, scan, coarse_results[i].pose, icp);
    if (!r.accepted) continue;
    const double score = r.inlier_share / (0.05 + r.rms_m);
    if (score > best) {
      best = score;
      pose_out = r.pose;
      found = true;
    }
  }
  return found;
}

}  // namespace pl::registration
