#include "pl/client/fusion.hpp"

#include <algorithm>
#include <cmath>

#include "pl/common/pose.hpp"

namespace pl::client {

std::array<double, 6> steady_state_gain(const FusionConfig& cfg) {
  std::array<double, 6> k{};
  for (int i = 0; i < 6; ++i) {
    const double q = cfg.odometry_sigma[i] * cfg.odometry_sigma[i];
    const double r = cfg.lidar_sigma[i] * cfg.lidar_sigma[i];
    if (r <= 0) {
      k[i] = 1.0;
      continue;
    }
    // Predicted variance P- solves P-^2 - q P- - q r = 0.
    const double p = 0.5 * (q + std::sqrt(q * q + 4.0 * q * r));
    k[i] = p / (p + r);
  }
  return k;
}

Fusion::Fusion(const FusionConfig& cfg)
    : gain_(steady_state_gain(cfg)),
      window_(std::max(1, cfg.momentum_window)),
      plane_s_(std::max(0.0, cfg.momentum_plane_s)) {}

void Fusion::reset(const Eigen::Isometry3d& pose, double t, const OdometryBuffer* odometry) {
  odometry_ = odometry;
  initialized_ = true;
  times_.assign(1, t);
  poses_.assign(1, pose);
  have_correction_ = false;
  if (auto o = odometry_ ? odometry_->at(t) : std::nullopt) {
    correction_ = pose * o->inverse();
    have_correction_ = true;
  }
}

bool Fusion::odometry_covers(double t) const {
  return odometry_ && have_correction_ && odometry_->at(t).has_value();
}

Eigen::Isometry3d Fusion::predict(double t) const {
  if (odometry_ && have_correction_)
    if (auto o = odometry_->at(t)) return correction_ * *o;
  // Momentum: odometry increments are missing, keep the recent velocity -- the window's motion
  // continued past its last pose at its constant twist.
  const std::size_t n = poses_.size();
  if (n < 2 || times_.back() <= times_.front()) return poses_.back();
  // The motion of the last w intervals continued past the last pose.
  const auto continued = [&](std::size_t w) {
    const std::size_t a = n - 1 - std::min(w, n - 1);
    return Eigen::Isometry3d(poses_.back() * scale_motion(poses_[a].inverse() * poses_.back(), (t - times_.back()) / (times_.back() - times_[a])));
  };
  const Eigen::Isometry3d slow = continued(static_cast<std::size_t>(window_));
  // In the ground plane the last intervals within plane_s_ (at least one).
  const double last = times_.back() - times_[n - 2];
  const int plane_window = std::clamp(static_cast<int>(std::lround(plane_s_ / std::max(last, 1e-6))), 1, window_);
  if (plane_window == window_) return slow;
  return in_ground_plane(slow, continued(static_cast<std::size_t>(plane_window)));
}

void Fusion::remember(double ts, const Eigen::Isometry3d& x) {
  if (ts <= times_.back()) {  // the same scan time again: replace
    times_.back() = ts;
    poses_.back() = x;
    return;
  }
  times_.push_back(ts);
  poses_.push_back(x);
  if (static_cast<int>(poses_.size()) > window_ + 1) {
    times_.erase(times_.begin());
    poses_.erase(poses_.begin());
  }
}

Eigen::Isometry3d Fusion::correct(double ts, const Eigen::Isometry3d& measured) {
  const Eigen::Isometry3d predicted = predict(ts);
  Eigen::Isometry3d fused = measured;
  const auto o = odometry_ ? odometry_->at(ts) : std::nullopt;
  if (o && have_correction_) {
    // Innovation in the vehicle frame at ts, scaled axis by axis.
    const Eigen::Isometry3d d = predicted.inverse() * measured;
    Eigen::Vector3d v = d.translation();
    Eigen::Vector3d w = rotation_vector(d.linear());
    // Rotation vector components about x, y, z are roll, pitch, yaw for small angles.
    for (int i = 0; i < 3; ++i) {
      v[i] *= gain_[i];
      w[i] *= gain_[3 + i];
    }
    Eigen::Isometry3d step = Eigen::Isometry3d::Identity();
    step.linear() = rotation_from_vector(w);
    step.translation() = v;
    fused = predicted * step;
  }
  // Without odometry the measurement is the only information about the motion: it is taken whole.
  if (o) {
    correction_ = fused * o->inverse();
    have_correction_ = true;
  }
  remember(ts, fused);
  return fused;
}

void Fusion::coast(double ts) { remember(ts, predict(ts)); }

void Fusion::coast(double ts, const Eigen::Isometry3d& pose) { remember(ts, pose); }

}  // namespace pl::client
