// Pose graph over keyframes: odometry chain + robust GPS position edges, solved with Ceres.
#include "pl/maps/pose_graph.hpp"

#include <ceres/ceres.h>

#include <Eigen/Cholesky>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>

#include "pl/common/error.hpp"

namespace pl::maps {
namespace {

constexpr double kDeg = M_PI / 180.0;

// A keyframe's state: translation and unit quaternion (Eigen's x, y, z, w order).
struct Node {
  double t[3];
  double q[4];
};

Node node_from(const Pose& p) {
  Node n;
  Eigen::Map<Eigen::Vector3d>(n.t) = p.translation();
  Eigen::Quaterniond q(p.linear());
  q.normalize();
  Eigen::Map<Eigen::Quaterniond>(n.q) = q;
  return n;
}

Pose pose_from(const Node& n) {
  Pose p = Pose::Identity();
  p.linear() = Eigen::Map<const Eigen::Quaterniond>(n.q).normalized().toRotationMatrix();
  p.translation() = Eigen::Map<const Eigen::Vector3d>(n.t);
  return p;
}

// Relative pose a^-1 b against its measurement z, as (translation, 2 * quaternion vector) in b's frame
// (the perturbation b * exp(d) to first order), whitened by the square root of the edge's information.
struct OdometryResidual {
  Eigen::Vector3d zt;
  Eigen::Quaterniond zq;
  Eigen::Matrix<double, 6, 6> sqrt_info;

  template <typename T>
  bool operator()(const T* ta, const T* qa, const T* tb, const T* qb, T* out) const {
    Eigen::Map<const Eigen::Matrix<T, 3, 1>> pa(ta), pb(tb);
    Eigen::Map<const Eigen::Quaternion<T>> ra(qa), rb(qb);
    const Eigen::Quaternion<T> ra_inv = ra.conjugate();
    const Eigen::Quaternion<T> rel_q = ra_inv * rb;
    const Eigen::Matrix<T, 3, 1> rel_t = ra_inv * (pb - pa);
    const Eigen::Quaternion<T> zq_inv = zq.conjugate().cast<T>();
    Eigen::Quaternion<T> eq = zq_inv * rel_q;
    const Eigen::Matrix<T, 3, 1> et = zq_inv * (rel_t - zt.cast<T>());
    if (eq.w() < T(0)) eq.coeffs() = -eq.coeffs();
    Eigen::Matrix<T, 6, 1> r;
    r << et, T(2) * eq.vec();
    Eigen::Map<Eigen::Matrix<T, 6, 1>> res(out);
    res = sqrt_info.cast<T>() * r;
    return true;
  }
};

// The antenna (a fixed point in the keyframe's frame) against a GPS position, per axis over sigma.
struct GpsResidual {
  Eigen::Vector3d body, world, inv_sigma;

  template <typename T>
  bool operator()(const T* t, const T* q, T* out) const {
    Eigen::Map<const Eigen::Matrix<T, 3, 1>> p(t);
    Eigen::Map<const Eigen::Quaternion<T>> r(q);
    const Eigen::Matrix<T, 3, 1> e = r * body.cast<T>() + p - world.cast<T>();
    for (int k = 0; k < 3; ++k) out[k] = e[k] * T(inv_sigma[k]);
    return true;
  }
};

double gps_sigma(const GpsEdge& g, const PoseGraphConfig& cfg) {
  double s = std::max(g.std_m, cfg.min_gps_std_m);
  if (g.status == kGpsFloat) s = std::max(s, cfg.float_min_std_m);
  if (g.status == kGpsDgps) s = std::max(s, cfg.dgps_min_std_m);
  if (g.status == kGpsSingle) s = std::max(s, cfg.single_min_std_m);
  return s;
}

// A GPS edge resolved onto a keyframe.
struct GpsOnKeyframe {
  std::size_t keyframe;
  Eigen::Vector3d body, world, sigma;
};

// Yaw about z and a translation taking the odometry antenna positions onto the GPS ones (weighted
// least squares, then again without the fixes far off the first fit). Translation only when the
// fixes spread less than 10 m horizontally.
Pose align_to_gps(const std::vector<Node>& nodes, const std::vector<GpsOnKeyframe>& gps) {
  std::vector<Eigen::Vector3d> from(gps.size());
  for (std::size_t j = 0; j < gps.size(); ++j) from[j] = pose_from(nodes[gps[j].keyframe]) * gps[j].body;
  std::vector<double> w(gps.size());
  for (std::size_t j = 0; j < gps.size(); ++j) w[j] = 1.0 / (gps[j].sigma.x() * gps[j].sigma.x());
  Pose a = Pose::Identity();
  for (int pass = 0; pass < 2; ++pass) {
    double sw = 0;
    Eigen::Vector3d cf = Eigen::Vector3d::Zero(), cg = Eigen::Vector3d::Zero();
    for (std::size_t j = 0; j < gps.size(); ++j) sw += w[j], cf += w[j] * from[j], cg += w[j] * gps[j].world;
    if (!(sw > 0)) return a;
    cf /= sw, cg /= sw;
    double sxx = 0, sxy = 0, spread = 0;  // 2D cross-covariance terms
    for (std::size_t j = 0; j < gps.size(); ++j) {
      const Eigen::Vector2d f = (from[j] - cf).head<2>(), g = (gps[j].world - cg).head<2>();
      sxx += w[j] * f.dot(g);
      sxy += w[j] * (f.x() * g.y() - f.y() * g.x());
      spread += w[j] * f.squaredNorm();
    }
    const double yaw = std::sqrt(spread / sw) > 10.0 ? std::atan2(sxy, sxx) : 0.0;
    a = Pose::Identity();
    a.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    a.translation() = cg - a.linear() * cf;
    if (pass == 1) break;
    std::vector<double> res(gps.size());
    for (std::size_t j = 0; j < gps.size(); ++j) res[j] = (a * from[j] - gps[j].world).norm();
    std::vector<double> sorted = res;
    std::nth_element(sorted.begin(), sorted.begin() + static_cast<long>(sorted.size() / 2), sorted.end());
    const double keep = std::max(3.0 * sorted[sorted.size() / 2], 0.5);
    for (std::size_t j = 0; j < gps.size(); ++j)
      if (res[j] > keep) w[j] = 0;
  }
  return a;
}

}  // namespace

PoseList optimize_trajectory(const PoseList& odometry_poses, const std::vector<Information6>& information,
                             const std::vector<GpsEdge>& gps, const Eigen::Vector3d& lever_arm, const PoseGraphConfig& cfg,
                             PoseGraphReport* report) {
  const std::size_t n = odometry_poses.size();
  if (!information.empty() && information.size() != n)
    throw Error("pose graph: " + std::to_string(information.size()) + " information matrices for " + std::to_string(n) + " poses");
  for (const GpsEdge& g : gps)
    if (g.scan >= n) throw Error("pose graph: a GPS edge names scan " + std::to_string(g.scan) + " of " + std::to_string(n));
  PoseGraphReport rep;
  if (n == 0) {
    rep.termination = "skipped";
    if (report) *report = rep;
    return {};
  }

  // Keyframes, and for every scan the keyframe it hangs from.
  std::vector<std::size_t> keyframes{0}, owner(n, 0);
  for (std::size_t i = 1; i < n; ++i) {
    const Pose d = odometry_poses[keyframes.back()].inverse() * odometry_poses[i];
    if (d.translation().norm() >= cfg.keyframe_m || rotation_angle(d) >= cfg.keyframe_deg * kDeg) keyframes.push_back(i);
    owner[i] = keyframes.size() - 1;
  }
  rep.keyframes = keyframes.size();
  std::vector<Node> nodes(keyframes.size());
  for (std::size_t k = 0; k < keyframes.size(); ++k) nodes[k] = node_from(odometry_poses[keyframes[k]]);

  // GPS edges onto keyframes: the antenna at the fix's time as a point in its keyframe's frame.
  std::vector<GpsOnKeyframe> fixes;
  for (const GpsEdge& g : gps) {
    if (g.status == kGpsNone) continue;
    const std::size_t i = g.scan;
    Eigen::Vector3d p = lever_arm;
    if (g.fraction > 0 && i + 1 < n) {
      const Pose at = interpolate(odometry_poses[i], odometry_poses[i + 1], std::min(g.fraction, 1.0));
      p = odometry_poses[i].inverse() * (at * lever_arm);
    }
    const std::size_t k = owner[i];
    const Pose offset = odometry_poses[keyframes[k]].inverse() * odometry_poses[i];
    const double s = gps_sigma(g, cfg);
    fixes.push_back({k, offset * p, g.antenna_world, Eigen::Vector3d(s, s, s * cfg.gps_vertical_factor)});
  }
  rep.gps_edges = fixes.size();
  if (!fixes.empty()) {
    const Pose a = align_to_gps(nodes, fixes);
    for (Node& node : nodes) node = node_from(a * pose_from(node));
  }

  ceres::Problem problem;
  for (Node& node : nodes) {
    problem.AddParameterBlock(node.t, 3);
    problem.AddParameterBlock(node.q, 4, new ceres::EigenQuaternionManifold);
  }
  if (fixes.empty()) problem.SetParameterBlockConstant(nodes[0].t), problem.SetParameterBlockConstant(nodes[0].q);

  // Odometry edges: per-scan covariances summed along the edge, plus the drift floor.
  Information6 fallback = Information6::Zero();
  fallback.diagonal() << Eigen::Vector3d::Constant(1.0 / (cfg.fallback_sigma_m * cfg.fallback_sigma_m)),
      Eigen::Vector3d::Constant(1.0 / std::pow(cfg.fallback_sigma_deg * kDeg, 2));
  const double info_scale = 1.0 / (cfg.odometry_sigma_m * cfg.odometry_sigma_m);
  for (std::size_t k = 1; k < keyframes.size(); ++k) {
    const std::size_t a = keyframes[k - 1], b = keyframes[k];
    const Pose z = odometry_poses[a].inverse() * odometry_poses[b];
    Information6 cov = Information6::Zero();
    if (!information.empty())
      for (std::size_t i = a + 1; i <= b; ++i) {
        Information6 info = information[i] * info_scale + fallback;
        info = 0.5 * (info + info.transpose());
        cov += info.ldlt().solve(Information6::Identity());
      }
    const double len = z.translation().norm();
    const double st = std::max(cfg.min_drift_ratio * len, 1e-4), sr = std::max(cfg.min_drift_deg_per_m * kDeg * len, 1e-6);
    cov.diagonal() += (Eigen::Matrix<double, 6, 1>() << st * st, st * st, st * st, sr * sr, sr * sr, sr * sr).finished();
    cov = 0.5 * (cov + cov.transpose());
    Information6 info = cov.ldlt().solve(Information6::Identity());
    info = 0.5 * (info + info.transpose());
    Eigen::LLT<Information6> llt(info);
    auto* f = new OdometryResidual{z.translation(), Eigen::Quaterniond(z.linear()).normalized(), llt.matrixU()};
    problem.AddResidualBlock(new ceres::AutoDiffCostFunction<OdometryResidual, 6, 3, 4, 3, 4>(f), nullptr, nodes[k - 1].t,
                             nodes[k - 1].q, nodes[k].t, nodes[k].q);
  }
  for (const GpsOnKeyframe& g : fixes) {
    auto* f = new GpsResidual{g.body, g.world, g.sigma.cwiseInverse()};
    problem.AddResidualBlock(new ceres::AutoDiffCostFunction<GpsResidual, 3, 3, 4>(f), new ceres::CauchyLoss(cfg.gps_kernel_sigmas),
                             nodes[g.keyframe].t, nodes[g.keyframe].q);
  }

  ceres::Solver::Options opt;
  opt.minimizer_type = ceres::TRUST_REGION;
  opt.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  opt.linear_solver_type = ceres::IsSparseLinearAlgebraLibraryTypeAvailable(opt.sparse_linear_algebra_library_type)
                               ? ceres::SPARSE_NORMAL_CHOLESKY
                               : ceres::DENSE_QR;
  opt.max_num_iterations = cfg.max_iterations;
  opt.num_threads = 1;
  opt.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  const auto t0 = std::chrono::steady_clock::now();
  ceres::Solve(opt, &problem, &summary);
  rep.solve_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  rep.iterations = static_cast<int>(summary.iterations.size() > 0 ? summary.iterations.size() - 1 : 0);
  rep.termination = fixes.empty() ? "no gps" : ceres::TerminationTypeToString(summary.termination_type);

  // Outliers and GPS residuals before (the input trajectory) and after.
  double before = 0, after = 0;
  std::size_t inliers = 0;
  for (const GpsOnKeyframe& g : fixes) {
    const Eigen::Vector3d e_after = pose_from(nodes[g.keyframe]) * g.body - g.world;
    if (e_after.cwiseQuotient(g.sigma).norm() > cfg.gps_outlier_sigmas) {
      ++rep.gps_outliers;
      continue;
    }
    const Eigen::Vector3d e_before = odometry_poses[keyframes[g.keyframe]] * g.body - g.world;
    before += e_before.squaredNorm(), after += e_after.squaredNorm();
    ++inliers;
  }
  if (inliers > 0) rep.gps_rms_before_m = std::sqrt(before / inliers), rep.gps_rms_after_m = std::sqrt(after / inliers);

  PoseList out(n);
  for (std::size_t i = 0; i < n; ++i) {
    const std::size_t k = owner[i];
    out[i] = pose_from(nodes[k]) * (odometry_poses[keyframes[k]].inverse() * odometry_poses[i]);
  }
  if (report) *report = rep;
  return out;
}

std::vector<GpsEdge> gps_edges_from_dataset(const Dataset& ds, double max_dt_s) {
  std::vector<GpsEdge> out;
  const std::vector<double>& t = ds.times;
  if (t.empty()) return out;
  for (const GpsFix& fix : ds.gps) {
    if (fix.status == kGpsNone) continue;
    const std::size_t j = static_cast<std::size_t>(std::lower_bound(t.begin(), t.end(), fix.t) - t.begin());
    double nearest = std::numeric_limits<double>::infinity();
    if (j < t.size()) nearest = t[j] - fix.t;
    if (j > 0) nearest = std::min(nearest, fix.t - t[j - 1]);
    if (!(nearest <= max_dt_s + 1e-9)) continue;
    GpsEdge e;
    if (j == 0) {
      e.scan = 0;
    } else if (j == t.size()) {
      e.scan = t.size() - 1;
    } else {
      e.scan = j - 1;
      const double span = t[j] - t[j - 1];
      e.fraction = span > 0 ? std::clamp((fix.t - t[j - 1]) / span, 0.0, 1.0) : 0.0;
    }
    e.antenna_world = ds.to_world(fix.position);
    e.std_m = fix.std_m;
    e.status = fix.status;
    out.push_back(e);
  }
  return out;
}

}  // namespace pl::maps
