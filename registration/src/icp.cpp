#include "pl/registration/icp.hpp"

#include <Eigen/Cholesky>

#include <algorithm>
#include <array>
#include <cmath>

#include "pl/common/pose.hpp"
#include "pl/registration/gauss_newton.hpp"

namespace pl::registration {
namespace {

// blocks[i]: the cells scan point i read in the previous iteration, read again while it stays in
// their block.
NormalEquations accumulate(const PointMap& map, const std::vector<Eigen::Vector3f>& scan, const Eigen::Matrix3f& R,
                           const Eigen::Vector3f& t, float max_d2, float k2, std::vector<CellBlock>& blocks) {
  NormalEquations eq;
  // Each point is rotated once, `ahead` queries before its lookup: its cell's slot is prefetched
  // then (unless it has a block from the previous iteration), the cell's points halfway.
  constexpr std::size_t ahead = 8;
  std::array<Eigen::Vector3f, ahead> rotated;  // R s of points i .. i + ahead - 1, at slot index % ahead
  const std::size_t n = scan.size();
  for (std::size_t j = 0; j < std::min(ahead, n); ++j) {
    rotated[j] = R * scan[j];
    if (!blocks[j].looked) map.prefetch(rotated[j] + t);
  }
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3f qr = rotated[i % ahead];
    if (i + ahead < n) {
      rotated[i % ahead] = R * scan[i + ahead];
      if (!blocks[i + ahead].looked) map.prefetch(rotated[i % ahead] + t);
    }
    if (i + ahead / 2 < n) {
      const CellBlock& b = blocks[i + ahead / 2];
      if (b.looked)
        PointMap::prefetch_points(b);
      else
        map.prefetch_points(rotated[(i + ahead / 2) % ahead] + t);
    }
    const Eigen::Vector3f q = qr + t;
    const Neighbour nb = map.nearest(q, max_d2, blocks[i]);
    if (!nb.point) continue;
    const float r = nb.point->n.dot(q - nb.point->p);
    eq.add(nb.point->n, qr, r, geman_mcclure_weight(r * r, k2));
  }
  return eq;
}

}  // namespace

IcpResult register_scan(const PointMap& map, const std::vector<Eigen::Vector3f>& scan, const Eigen::Isometry3d& guess,
                        const IcpConfig& cfg) {
  IcpResult res;
  Eigen::Matrix3d R = guess.linear();
  Eigen::Vector3d t = guess.translation() - map.anchor();
  const float max_d = static_cast<float>(std::min(cfg.max_pair_m, map.cell_m()));
  const float max_d2 = max_d * max_d;
  NormalEquations eq;
  Vector6d last_step = Vector6d::Zero();
  std::vector<CellBlock> blocks(scan.size());
  for (int it = 0; it < cfg.max_iterations; ++it) {
    const double k = std::max(cfg.kernel_m, cfg.kernel_start_m * std::ldexp(1.0, -it));
    eq = accumulate(map, scan, R.cast<float>(), t.cast<float>(), max_d2, static_cast<float>(k * k), blocks);
    res.iterations = it + 1;
    if (eq.rows() < 6) break;
    const Vector6d step = solve_step(eq.H(), eq.g());
    if (!step.allFinite()) break;
    // Over-relaxation: correspondences that change little from one iteration to the next make the
    // steps a geometric series along a weakly held direction; when two steps point the same way,
    // take more of the series at once (bounded).
    double boost = 1.0;
    if (cfg.max_boost > 1.0 && it > 0) {
      Vector6d a6 = step, b6 = last_step;
      a6.tail<3>() *= 10.0;  // radians weighed as 10 m lever arms
      b6.tail<3>() *= 10.0;
      const double na = a6.norm(), nb = b6.norm();
      if (na > 0 && nb > 0 && a6.dot(b6) > 0.9 * na * nb && na < nb) boost = std::min(cfg.max_boost, 1.0 / (1.0 - na / nb));
    }
    last_step = step;
    R = rotation_from_vector(boost * step.tail<3>()) * R;
    t += boost * step.head<3>();
    if (k <= cfg.kernel_m && step.head<3>().norm() < cfg.converged_m && step.tail<3>().norm() < cfg.converged_rad) {
      res.converged = true;
      break;
    }
  }
  // Re-orthonormalise (many small rotations multiplied).
  Eigen::Quaterniond qn(R);
  qn.normalize();
  res.pose.linear() = qn.toRotationMatrix();
  res.pose.translation() = t + map.anchor();
  res.pairs = eq.rows();
  res.inlier_share = scan.empty() ? 0.0 : static_cast<double>(eq.rows()) / static_cast<double>(scan.size());
  res.rms_m = eq.weighted_rms();

  if (eq.rows() >= 6) {
    const Matrix6d& H = eq.H();
    res.conditioning = translation_conditioning(H);
    const Matrix6d Hinv = H.ldlt().solve(Matrix6d::Identity());
    if (Hinv.allFinite()) res.covariance = res.rms_m * res.rms_m * Hinv;
  }
  if (eq.rows() < cfg.min_inliers) {
    res.reject_reason = "too few pairs";
  } else if (res.inlier_share < cfg.min_inlier_share) {
    res.reject_reason = "too few scan points near the map";
  } else if (res.conditioning < cfg.min_conditioning) {
    res.reject_reason = "degenerate geometry";
  } else if (!res.converged && (last_step.head<3>().norm() > cfg.unsettled_factor * cfg.converged_m ||
                                last_step.tail<3>().norm() > cfg.unsettled_factor * cfg.converged_rad)) {
    res.reject_reason = "did not converge";
  } else {
    res.accepted = true;
  }
  return res;
}

}  // namespace pl::registration
