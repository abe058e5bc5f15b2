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
#include "pl/common/stats.hpp"

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

// The world's up direction seen from a keyframe (R^T z) against where the odometry had it, in
// radians over sigma: roll and pitch, not yaw.
struct TiltResidual {
  Eigen::Vector3d up_body;
  double inv_sigma;

  template <typename T>
  bool operator()(const T* q, T* out) const {
    Eigen::Map<const Eigen::Quaternion<T>> r(q);
    const Eigen::Matrix<T, 3, 1> up = r.conjugate() * Eigen::Matrix<T, 3, 1>(T(0), T(0), T(1));
    for (int k = 0; k < 3; ++k) out[k] = (up[k] - T(up_body[k])) * T(inv_sigma);
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
    const double keep = std::max(3.0 * median(res), 0.5);
    for (std::size_t j = 0; j < gps.size(); ++j)
      if (res[j] > keep) w[j] = 0;
  }
  return a;
}

}  // namespace

bool is_new_keyframe(const Pose& last, const Pose& pose, const PoseGraphConfig& cfg) {
  const Pose d = last.inverse() * pose;
  return d.translation().norm() >= cfg.keyframe_m || rotation_angle(d) >= cfg.keyframe_deg * kDeg;
}

struct PoseGraph::Impl {
  PoseGraphConfig cfg;
  struct Drive {
    PoseList odometry;                // one per scan, as given
    std::vector<std::size_t> owner;   // per scan: the keyframe (graph-wide) it hangs from
    std::size_t first = 0, end = 0;   // its keyframes
    bool fixed = false, joined = false, held = false;  // held: its first keyframe constant until joined
    std::size_t gps_begin = 0, gps_end = 0;  // its fixes in `fixes`
  };
  std::vector<Drive> drives;
  std::vector<std::size_t> keyframes, keyframe_drive;  // per keyframe: its scan within its drive, its drive
  PoseList keyframe_odometry;
  std::vector<Node> nodes;                 // the estimate (stable addresses: Ceres holds pointers)
  std::vector<GpsOnKeyframe> fixes;
  ceres::Problem problem;
  std::vector<ceres::ResidualBlockId> loops;  // nullptr once removed
  std::vector<ceres::ResidualBlockId> gps_blocks;
  PoseGraphReport rep;

  void hold(std::size_t k, bool constant) {
    if (constant) problem.SetParameterBlockConstant(nodes[k].t), problem.SetParameterBlockConstant(nodes[k].q);
    else problem.SetParameterBlockVariable(nodes[k].t), problem.SetParameterBlockVariable(nodes[k].q);
  }
};

namespace {

std::vector<GraphDrive> one_drive(const PoseList& odometry_poses, const std::vector<Information6>& information,
                                  const std::vector<GpsEdge>& gps, const Eigen::Vector3d& lever_arm) {
  std::vector<GraphDrive> d(1);
  d[0].odometry = odometry_poses;
  d[0].information = information;
  d[0].gps = gps;
  d[0].lever_arm = lever_arm;
  return d;
}

}  // namespace

PoseGraph::PoseGraph(const PoseList& odometry_poses, const std::vector<Information6>& information, const std::vector<GpsEdge>& gps,
                     const Eigen::Vector3d& lever_arm, const PoseGraphConfig& cfg)
    : PoseGraph(one_drive(odometry_poses, information, gps, lever_arm), cfg) {}

PoseGraph::PoseGraph(const std::vector<GraphDrive>& input, const PoseGraphConfig& cfg) : impl_(std::make_unique<Impl>()) {
  Impl& g = *impl_;
  g.cfg = cfg;
  g.rep.termination = "skipped";
  for (std::size_t d = 0; d < input.size(); ++d) {
    const GraphDrive& in = input[d];
    const std::string which = input.size() > 1 ? " of drive " + std::to_string(d + 1) : "";
    const std::size_t n = in.odometry.size();
    if (!in.information.empty() && in.information.size() != n)
      throw Error("pose graph: " + std::to_string(in.information.size()) + " information matrices for " + std::to_string(n) +
                  " poses" + which);
    for (const GpsEdge& e : in.gps)
      if (e.scan >= n) throw Error("pose graph: a GPS edge names scan " + std::to_string(e.scan) + " of " + std::to_string(n) + which);
  }

  // Keyframes of each drive, and for every scan the keyframe it hangs from; GPS edges onto them.
  for (const GraphDrive& in : input) {
    Impl::Drive dr;
    dr.odometry = in.odometry;
    dr.fixed = in.fixed;
    dr.first = dr.end = g.keyframes.size();
    dr.gps_begin = dr.gps_end = g.fixes.size();
    const std::size_t n = in.odometry.size();
    if (n > 0) {
      const std::size_t d = g.drives.size();
      std::size_t last = 0;
      g.keyframes.push_back(0), g.keyframe_drive.push_back(d);
      dr.owner.assign(n, dr.first);
      for (std::size_t i = 1; i < n; ++i) {
        if (is_new_keyframe(in.odometry[last], in.odometry[i], cfg)) {
          last = i;
          g.keyframes.push_back(i), g.keyframe_drive.push_back(d);
        }
        dr.owner[i] = g.keyframes.size() - 1;
      }
      dr.end = g.keyframes.size();
      for (std::size_t k = dr.first; k < dr.end; ++k) g.keyframe_odometry.push_back(in.odometry[g.keyframes[k]]);
      for (const GpsEdge& e : in.gps) {
        if (e.status == kGpsNone || in.fixed) continue;
        const std::size_t i = e.scan;
        Eigen::Vector3d p = in.lever_arm;  // the antenna at the fix's time, in its keyframe's frame
        if (e.fraction > 0 && i + 1 < n) {
          const Pose at = interpolate(in.odometry[i], in.odometry[i + 1], std::min(e.fraction, 1.0));
          p = in.odometry[i].inverse() * (at * in.lever_arm);
        }
        const std::size_t k = dr.owner[i];
        const Pose offset = in.odometry[g.keyframes[k]].inverse() * in.odometry[i];
        const double s = gps_sigma(e, cfg);
        g.fixes.push_back({k, offset * p, e.antenna_world, Eigen::Vector3d(s, s, s * cfg.gps_vertical_factor)});
      }
      dr.gps_end = g.fixes.size();
    }
    g.drives.push_back(std::move(dr));
  }
  g.rep.keyframes = g.keyframes.size();
  g.rep.gps_edges = g.fixes.size();
  if (g.keyframes.empty()) return;
  g.nodes.resize(g.keyframes.size());
  for (std::size_t k = 0; k < g.keyframes.size(); ++k) g.nodes[k] = node_from(g.keyframe_odometry[k]);

  // Each drive with fixes aligned to them (yaw and translation).
  for (Impl::Drive& dr : g.drives) {
    if (dr.gps_begin == dr.gps_end) continue;
    const std::vector<GpsOnKeyframe> own(g.fixes.begin() + static_cast<long>(dr.gps_begin), g.fixes.begin() + static_cast<long>(dr.gps_end));
    const Pose a = align_to_gps(g.nodes, own);
    for (std::size_t k = dr.first; k < dr.end; ++k) g.nodes[k] = node_from(a * pose_from(g.nodes[k]));
  }

  for (Node& node : g.nodes) {
    g.problem.AddParameterBlock(node.t, 3);
    g.problem.AddParameterBlock(node.q, 4, new ceres::EigenQuaternionManifold);
  }
  // What holds the frame: fixed drives, else the fixes, else the first drive's first keyframe. A
  // drive tied by none of these floats, its first keyframe held, until a loop joins it.
  bool anchored = false;
  for (const Impl::Drive& dr : g.drives) anchored = anchored || dr.fixed || dr.gps_end > dr.gps_begin;
  for (std::size_t d = 0; d < g.drives.size(); ++d) {
    Impl::Drive& dr = g.drives[d];
    if (dr.first == dr.end) continue;
    const bool has_gps = dr.gps_end > dr.gps_begin;
    if (dr.fixed) {
      for (std::size_t k = dr.first; k < dr.end; ++k) g.hold(k, true);
      dr.joined = true;
    } else if (has_gps) {
      dr.joined = true;
      if (cfg.tilt_prior_deg > 0) {
        const Eigen::Vector3d up_body = pose_from(g.nodes[dr.first]).linear().transpose() * Eigen::Vector3d::UnitZ();
        g.problem.AddResidualBlock(
            new ceres::AutoDiffCostFunction<TiltResidual, 3, 4>(new TiltResidual{up_body, 1.0 / (cfg.tilt_prior_deg * kDeg)}), nullptr,
            g.nodes[dr.first].q);
      }
    } else {
      g.hold(dr.first, true);
      dr.held = true;
      dr.joined = !anchored && !g.drives.empty() && d == 0;  // the frame's own drive
      if (dr.joined) anchored = true;
    }
  }

  // Odometry edges: per-scan covariances summed along the edge, plus the drift floor.
  Information6 fallback = Information6::Zero();
  fallback.diagonal() << Eigen::Vector3d::Constant(1.0 / (cfg.fallback_sigma_m * cfg.fallback_sigma_m)),
      Eigen::Vector3d::Constant(1.0 / std::pow(cfg.fallback_sigma_deg * kDeg, 2));
  const double info_scale = 1.0 / (cfg.odometry_sigma_m * cfg.odometry_sigma_m);
  for (std::size_t d = 0; d < g.drives.size(); ++d) {
    const Impl::Drive& dr = g.drives[d];
    if (dr.fixed) continue;  // held as given
    const std::vector<Information6>& information = input[d].information;
    for (std::size_t k = dr.first + 1; k < dr.end; ++k) {
      const std::size_t a = g.keyframes[k - 1], b = g.keyframes[k];
      const Pose z = dr.odometry[a].inverse() * dr.odometry[b];
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
      g.problem.AddResidualBlock(new ceres::AutoDiffCostFunction<OdometryResidual, 6, 3, 4, 3, 4>(f), nullptr, g.nodes[k - 1].t,
                                 g.nodes[k - 1].q, g.nodes[k].t, g.nodes[k].q);
    }
  }
  for (const GpsOnKeyframe& e : g.fixes) {
    auto* f = new GpsResidual{e.body, e.world, e.sigma.cwiseInverse()};
    g.gps_blocks.push_back(g.problem.AddResidualBlock(new ceres::AutoDiffCostFunction<GpsResidual, 3, 3, 4>(f),
                                                      new ceres::CauchyLoss(cfg.gps_kernel_sigmas), g.nodes[e.keyframe].t,
                                                      g.nodes[e.keyframe].q));
  }
}

PoseGraph::~PoseGraph() = default;

const std::vector<std::size_t>& PoseGraph::keyframes() const { return impl_->keyframes; }
std::size_t PoseGraph::drives() const { return impl_->drives.size(); }
std::size_t PoseGraph::drive_of(std::size_t keyframe) const { return impl_->keyframe_drive.at(keyframe); }
std::size_t PoseGraph::first_keyframe(std::size_t drive) const { return impl_->drives.at(drive).first; }
bool PoseGraph::fixed(std::size_t drive) const { return impl_->drives.at(drive).fixed; }
bool PoseGraph::joined(std::size_t drive) const { return impl_->drives.at(drive).joined; }

void PoseGraph::join_drive(std::size_t drive, const Pose& correction) {
  Impl& g = *impl_;
  Impl::Drive& dr = g.drives.at(drive);
  if (dr.joined) throw Error("pose graph: drive " + std::to_string(drive + 1) + " is joined already");
  for (std::size_t k = dr.first; k < dr.end; ++k) g.nodes[k] = node_from(correction * pose_from(g.nodes[k]));
  if (dr.held && dr.first < dr.end) g.hold(dr.first, false);
  dr.held = false;
  dr.joined = true;
}
Pose PoseGraph::keyframe_pose(std::size_t k) const { return pose_from(impl_->nodes.at(k)); }
const Pose& PoseGraph::odometry_pose(std::size_t k) const { return impl_->keyframe_odometry.at(k); }

std::size_t PoseGraph::add_loop(std::size_t a, std::size_t b, const Pose& relative, const Information6& information) {
  Impl& g = *impl_;
  if (a >= g.nodes.size() || b >= g.nodes.size() || a == b)
    throw Error("pose graph: a loop edge between keyframes " + std::to_string(a) + " and " + std::to_string(b) + " of " +
                std::to_string(g.nodes.size()));
  Information6 info = 0.5 * (information + information.transpose());
  Eigen::LLT<Information6> llt(info);
  if (llt.info() != Eigen::Success) throw Error("pose graph: a loop edge's information is not positive definite");
  auto* f = new OdometryResidual{relative.translation(), Eigen::Quaterniond(relative.linear()).normalized(), llt.matrixU()};
  ceres::LossFunction* loss = g.cfg.loop_kernel_sigmas > 0 ? new ceres::CauchyLoss(g.cfg.loop_kernel_sigmas) : nullptr;
  g.loops.push_back(g.problem.AddResidualBlock(new ceres::AutoDiffCostFunction<OdometryResidual, 6, 3, 4, 3, 4>(f), loss, g.nodes[a].t,
                                               g.nodes[a].q, g.nodes[b].t, g.nodes[b].q));
  ++g.rep.loop_edges;
  return g.loops.size() - 1;
}

void PoseGraph::remove_loop(std::size_t id) {
  Impl& g = *impl_;
  if (id >= g.loops.size() || g.loops[id] == nullptr) throw Error("pose graph: no loop edge " + std::to_string(id) + " to remove");
  g.problem.RemoveResidualBlock(g.loops[id]);
  g.loops[id] = nullptr;
  --g.rep.loop_edges;
}

std::vector<double> PoseGraph::save() const {
  std::vector<double> out;
  out.reserve(impl_->nodes.size() * 7);
  for (const Node& n : impl_->nodes) out.insert(out.end(), {n.t[0], n.t[1], n.t[2], n.q[0], n.q[1], n.q[2], n.q[3]});
  return out;
}

void PoseGraph::restore(const std::vector<double>& state) {
  Impl& g = *impl_;
  if (state.size() != g.nodes.size() * 7) throw Error("pose graph: a saved state of another graph");
  for (std::size_t k = 0; k < g.nodes.size(); ++k) {
    std::copy(state.begin() + static_cast<long>(7 * k), state.begin() + static_cast<long>(7 * k + 3), g.nodes[k].t);
    std::copy(state.begin() + static_cast<long>(7 * k + 3), state.begin() + static_cast<long>(7 * k + 7), g.nodes[k].q);
  }
}

double PoseGraph::gps_cost() const {
  Impl& g = *impl_;
  if (g.gps_blocks.empty()) return 0.0;
  ceres::Problem::EvaluateOptions opt;
  opt.residual_blocks = g.gps_blocks;
  opt.apply_loss_function = true;
  opt.num_threads = 1;
  double cost = 0.0;
  g.problem.Evaluate(opt, &cost, nullptr, nullptr, nullptr);
  return cost;
}

void PoseGraph::optimize(int max_iterations) {
  Impl& g = *impl_;
  if (g.nodes.empty()) return;
  // Nothing to solve: a lone chain without GPS or loops stays as the odometry gave it.
  if (g.fixes.empty() && g.rep.loop_edges == 0 && g.rep.solves == 0) {
    g.rep.termination = "no gps or loops";
    return;
  }
  ceres::Solver::Options opt;
  opt.minimizer_type = ceres::TRUST_REGION;
  opt.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  opt.linear_solver_type = ceres::IsSparseLinearAlgebraLibraryTypeAvailable(opt.sparse_linear_algebra_library_type)
                               ? ceres::SPARSE_NORMAL_CHOLESKY
                               : ceres::DENSE_QR;
  opt.max_num_iterations = max_iterations > 0 ? max_iterations : g.cfg.max_iterations;
  opt.num_threads = 1;
  opt.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  const auto t0 = std::chrono::steady_clock::now();
  ceres::Solve(opt, &g.problem, &summary);
  g.rep.solve_ms += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  g.rep.iterations += static_cast<int>(summary.iterations.size() > 0 ? summary.iterations.size() - 1 : 0);
  ++g.rep.solves;
  g.rep.termination = ceres::TerminationTypeToString(summary.termination_type);
}

PoseList PoseGraph::poses(std::size_t drive) const {
  const Impl& g = *impl_;
  if (g.drives.empty()) return {};
  const Impl::Drive& dr = g.drives.at(drive);
  PoseList out(dr.odometry.size());
  for (std::size_t i = 0; i < dr.odometry.size(); ++i) {
    const std::size_t k = dr.owner[i];
    out[i] = pose_from(g.nodes[k]) * (g.keyframe_odometry[k].inverse() * dr.odometry[i]);
  }
  return out;
}

PoseGraphReport PoseGraph::report() const {
  const Impl& g = *impl_;
  PoseGraphReport rep = g.rep;
  // Outliers and GPS residuals before (the input trajectory) and now, per drive and in all.
  double before = 0, after = 0;
  std::size_t inliers = 0;
  for (const Impl::Drive& dr : g.drives) {
    PoseGraphDriveReport d;
    d.keyframes = dr.end - dr.first;
    d.gps_edges = dr.gps_end - dr.gps_begin;
    d.fixed = dr.fixed;
    double b = 0, a = 0;
    std::size_t in = 0;
    for (std::size_t j = dr.gps_begin; j < dr.gps_end; ++j) {
      const GpsOnKeyframe& e = g.fixes[j];
      const Eigen::Vector3d e_after = pose_from(g.nodes[e.keyframe]) * e.body - e.world;
      if (e_after.cwiseQuotient(e.sigma).norm() > g.cfg.gps_outlier_sigmas) {
        ++d.gps_outliers;
        continue;
      }
      const Eigen::Vector3d e_before = g.keyframe_odometry[e.keyframe] * e.body - e.world;
      b += e_before.squaredNorm(), a += e_after.squaredNorm();
      ++in;
    }
    if (in > 0) d.gps_rms_before_m = std::sqrt(b / in), d.gps_rms_after_m = std::sqrt(a / in);
    before += b, after += a, inliers += in;
    rep.gps_outliers += d.gps_outliers;
    rep.drives.push_back(d);
  }
  if (inliers > 0) rep.gps_rms_before_m = std::sqrt(before / inliers), rep.gps_rms_after_m = std::sqrt(after / inliers);
  return rep;
}

PoseList optimize_trajectory(const PoseList& odometry_poses, const std::vector<Information6>& information,
                             const std::vector<GpsEdge>& gps, const Eigen::Vector3d& lever_arm, const PoseGraphConfig& cfg,
                             PoseGraphReport* report) {
  PoseGraph graph(odometry_poses, information, gps, lever_arm, cfg);
  graph.optimize();
  if (report) *report = graph.report();
  return graph.poses();
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
