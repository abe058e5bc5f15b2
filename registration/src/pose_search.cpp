#include "pl/registration/pose_search.hpp"

#include <algorithm>
#include <cmath>

#include "pl/common/pose.hpp"

namespace pl::registration {

double registration_score(const IcpResult& r) { return r.inlier_share / (0.05 + r.rms_m); }

IcpConfig coarse_icp(const IcpConfig& fine, int iterations) {
  IcpConfig wide = fine;
  wide.max_pair_m = 2.0;
  wide.kernel_start_m = 2.0;
  wide.kernel_m = 0.5;
  wide.max_iterations = iterations;
  return wide;
}

std::vector<Eigen::Vector3f> subsample(const std::vector<Eigen::Vector3f>& points, std::size_t count) {
  if (count == 0 || points.size() <= count) return points;
  std::vector<Eigen::Vector3f> out;
  out.reserve(count);
  const double stride = static_cast<double>(points.size()) / static_cast<double>(count);
  for (std::size_t k = 0; k < count; ++k) out.push_back(points[static_cast<std::size_t>(static_cast<double>(k) * stride)]);
  return out;
}

IcpResult register_coarse_to_fine(const PointMap& coarse, const PointMap& fine, const std::vector<Eigen::Vector3f>& scan,
                                  const Eigen::Isometry3d& guess, const IcpConfig& icp, std::size_t coarse_points) {
  const IcpResult c = register_scan(coarse, subsample(scan, coarse_points), guess, coarse_icp(icp));
  IcpResult r = register_scan(fine, scan, c.pose, icp);
  r.iterations += c.iterations;
  return r;
}

std::vector<Candidate> search_poses(const PointMap& coarse, const PointMap& fine, const std::vector<Eigen::Vector3f>& scan,
                                    const Eigen::Isometry3d& guess, const PoseSearch& search, const IcpConfig& icp) {
  const IcpConfig wide = coarse_icp(icp);
  const std::vector<Eigen::Vector3f> sparse = subsample(scan, 400);  // the seeds only have to find the basin
  const bool ellipse = search.along_m > 0 && search.across_m > 0;
  const double a = ellipse ? search.along_m : search.radius_m;
  const double b = ellipse ? search.across_m : search.radius_m;
  const double step = search.position_step_m;
  const int na = static_cast<int>(std::floor(a / step)), nb = static_cast<int>(std::floor(b / step));
  const int ny = search.yaw_step_deg > 0 ? static_cast<int>(std::floor(search.yaw_range_deg / search.yaw_step_deg)) : 0;
  const double yaw0 = yaw_of(guess);
  const Eigen::Vector3d along(std::cos(yaw0), std::sin(yaw0), 0), across(-std::sin(yaw0), std::cos(yaw0), 0);
  std::vector<Candidate> seeds;
  for (int i = -na; i <= na; ++i)
    for (int j = -nb; j <= nb; ++j) {
      const double u = i * step, v = j * step;
      if ((u * u) / (a * a) + (v * v) / (b * b) > 1.0 + 1e-9) continue;
      for (int k = -ny; k <= ny; ++k) {
        const Eigen::Vector3d p = guess.translation() + u * along + v * across;
        const Eigen::Isometry3d seed = make_pose(p.x(), p.y(), p.z(), 0, 0, yaw0 + k * search.yaw_step_deg * M_PI / 180.0);
        Candidate c;
        c.icp = register_scan(coarse, sparse, seed, wide);
        c.score = registration_score(c.icp);
        seeds.push_back(c);
      }
    }
  std::sort(seeds.begin(), seeds.end(), [](const Candidate& x, const Candidate& y) { return x.score > y.score; });
  std::vector<Candidate> out;
  for (std::size_t i = 0; i < seeds.size() && static_cast<int>(i) < search.refine; ++i) {
    Candidate c;
    c.icp = register_scan(fine, scan, seeds[i].icp.pose, icp);
    if (!c.icp.accepted) continue;
    c.score = registration_score(c.icp);
    out.push_back(c);
  }
  std::sort(out.begin(), out.end(), [](const Candidate& x, const Candidate& y) { return x.score > y.score; });
  std::vector<Candidate> distinct;
  for (const Candidate& c : out) {
    const bool same = std::any_of(distinct.begin(), distinct.end(), [&](const Candidate& d) {
      const Eigen::Isometry3d delta = d.icp.pose.inverse() * c.icp.pose;
      return delta.translation().norm() < 0.3 && rotation_angle(delta) < M_PI / 180.0;
    });
    if (!same) distinct.push_back(c);
  }
  return distinct;
}

bool search_pose(const PointMap& coarse, const PointMap& fine, const std::vector<Eigen::Vector3f>& scan,
                 const Eigen::Isometry3d& guess, const PoseSearch& search, const IcpConfig& icp, Eigen::Isometry3d& pose_out) {
  const std::vector<Candidate> found = search_poses(coarse, fine, scan, guess, search, icp);
  if (found.empty()) return false;
  pose_out = found.front().icp.pose;
  return true;
}

}  // namespace pl::registration
