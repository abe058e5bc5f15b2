// Point-to-plane Gauss-Newton. The pose is kept as a rotation and a translation from the map's
// anchor; a step (v, w) moves a transformed point q = R s + t to q + w x (R s) + v, so the rotation
// turns about the sensor and stays well conditioned however far the anchor is.
#include "pl/client/icp.hpp"

#include "pl/common/pose.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>

namespace pl::client {
namespace {

using Mat6 = Eigen::Matrix<double, 6, 6>;
using Vec6 = Eigen::Matrix<double, 6, 1>;

struct Accumulated {
  Mat6 H = Mat6::Zero();
  Vec6 g = Vec6::Zero();
  double wr2 = 0, w = 0;
  int pairs = 0;
};

Accumulated accumulate(const RoiMap& map, const std::vector<Eigen::Vector3f>& scan, const Eigen::Matrix3f& R,
                       const Eigen::Vector3f& t, float max_d2, float k2) {
  Accumulated a;
  // Float accumulation in blocks, flushed to double: fast and still exact enough for a 6x6 system.
  Eigen::Matrix<float, 6, 6> Hf = Eigen::Matrix<float, 6, 6>::Zero();
  Eigen::Matrix<float, 6, 1> gf = Eigen::Matrix<float, 6, 1>::Zero();
  int in_block = 0;
  for (const Eigen::Vector3f& s : scan) {
    const Eigen::Vector3f qr = R * s;
    const Eigen::Vector3f q = qr + t;
    const Neighbour nb = map.nearest(q, max_d2);
    if (!nb.point) continue;
    const Eigen::Vector3f& n = nb.point->n;
    const float r = n.dot(q - nb.point->p);
    const float d = k2 + r * r;
    const float w = k2 * k2 / (d * d);  // Geman-McClure
    Eigen::Matrix<float, 6, 1> J;
    J.head<3>() = n;
    J.tail<3>() = qr.cross(n);
    Hf.noalias() += (w * J) * J.transpose();
    gf.noalias() += (w * r) * J;
    a.wr2 += static_cast<double>(w * r * r);
    a.w += static_cast<double>(w);
    ++a.pairs;
    if (++in_block == 256) {
      a.H += Hf.cast<double>();
      a.g += gf.cast<double>();
      Hf.setZero();
      gf.setZero();
      in_block = 0;
    }
  }
  a.H += Hf.cast<double>();
  a.g += gf.cast<double>();
  return a;
}


}  // namespace

IcpResult register_scan(const RoiMap& map, const std::vector<Eigen::Vector3f>& scan, const Eigen::Isometry3d& guess,
                        const IcpConfig& cfg) {
  IcpResult res;
  Eigen::Matrix3d R = guess.linear();
  Eigen::Vector3d t = guess.translation() - map.anchor();
  const float max_d = static_cast<float>(std::min(cfg.max_pair_m, map.cell_m()));
  const float max_d2 = max_d * max_d;
  Accumulated a;
  Vec6 last_step = Vec6::Zero();
  for (int it = 0; it < cfg.max_iterations; ++it) {
    const double k = std::max(cfg.kernel_m, cfg.kernel_start_m * std::ldexp(1.0, -it));
    a = accumulate(map, scan, R.cast<float>(), t.cast<float>(), max_d2, static_cast<float>(k * k));
    res.iterations = it + 1;
    if (a.pairs < 6) break;
    const Vec6 step = a.H.ldlt().solve(-a.g);
    if (!step.allFinite()) break;
    // Over-relaxation: correspondences that change little from one iteration to the next make the
    // steps a geometric series along a weakly held direction; when two steps point the same way,
    // take more of the series at once (bounded).
    double boost = 1.0;
    if (cfg.max_boost > 1.0 && it > 0) {
      Vec6 a6 = step, b6 = last_step;
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
  res.pairs = a.pairs;
  res.inlier_share = scan.empty() ? 0.0 : static_cast<double>(a.pairs) / static_cast<double>(scan.size());
  res.rms_m = a.w > 0 ? std::sqrt(a.wr2 / a.w) : 0.0;

  // Translation information once rotation is marginalised out (Schur complement): a corridor with
  // nothing along it shows as a near-zero eigenvalue even when the rotations are well fixed.
  if (a.pairs >= 6) {
    const Eigen::Matrix3d Hww = a.H.block<3, 3>(3, 3);
    const Eigen::Matrix3d Hvw = a.H.block<3, 3>(0, 3);
    const Eigen::Matrix3d Hvv = a.H.block<3, 3>(0, 0) - Hvw * Hww.ldlt().solve(Hvw.transpose());
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(Hvv);
    const Eigen::Vector3d ev = es.eigenvalues();
    res.conditioning = ev(2) > 0 ? std::max(0.0, ev(0)) / ev(2) : 0.0;
    const double s2 = res.rms_m * res.rms_m;
    const Mat6 Hinv = a.H.ldlt().solve(Mat6::Identity());
    if (Hinv.allFinite()) res.covariance = s2 * Hinv;
  }
  if (a.pairs < cfg.min_inliers) {
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

}  // namespace pl::client
