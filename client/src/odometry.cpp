#include "pl/client/odometry.hpp"

#include <algorithm>
#include <cmath>

#include "pl/common/error.hpp"

namespace pl::client {

void OdometryBuffer::add(double t, const Eigen::Isometry3d& pose) {
  if (!std::isfinite(t)) throw Error("odometry: time is not finite");
  if (!times_.empty() && !(t > times_.back()))
    throw Error("odometry: times must increase (" + std::to_string(t) + " after " + std::to_string(times_.back()) + ")");
  times_.push_back(t);
  poses_.push_back(pose);
}

std::size_t OdometryBuffer::upper_bound(double t) const {
  return static_cast<std::size_t>(std::upper_bound(times_.begin(), times_.end(), t) - times_.begin());
}

std::optional<Eigen::Isometry3d> OdometryBuffer::at(double t) const {
  if (times_.empty() || t < times_.front() || t > times_.back()) return std::nullopt;
  const std::size_t hi = upper_bound(t);
  if (hi == times_.size()) return poses_.back();
  const std::size_t lo = hi - 1;
  const double s = (t - times_[lo]) / (times_[hi] - times_[lo]);
  return interpolate(poses_[lo], poses_[hi], s);
}

void OdometryBuffer::keep_last(std::size_t max_samples) {
  while (times_.size() > max_samples) {
    times_.pop_front();
    poses_.pop_front();
  }
}

DiffDrive::DiffDrive(double wheel_base_m) : wheel_base_(wheel_base_m) {
  if (!(wheel_base_m > 0) || !std::isfinite(wheel_base_m))
    throw Error("encoder odometry needs a wheel base > 0 (vehicle.wheel_base_m in meta.json), got " + std::to_string(wheel_base_m));
}

Eigen::Isometry3d DiffDrive::add(double left_m, double right_m) {
  if (!std::isfinite(left_m) || !std::isfinite(right_m)) throw Error("encoder odometry: wheel travel is not finite");
  if (!first_) {
    const double dl = left_m - left_, dr = right_m - right_;
    const double d = 0.5 * (dl + dr);
    const double dth = (dr - dl) / wheel_base_;
    // The chord of the arc, along the heading at its middle.
    const double half = 0.5 * dth;
    const double chord = std::abs(half) < 1e-9 ? d : d * std::sin(half) / half;
    x_ += chord * std::cos(th_ + half);
    y_ += chord * std::sin(th_ + half);
    th_ += dth;
  }
  first_ = false;
  left_ = left_m;
  right_ = right_m;
  return make_pose(x_, y_, 0.0, 0.0, 0.0, th_);
}

OdometryBuffer odometry_from_encoders(const std::vector<EncoderSample>& samples, double wheel_base_m) {
  DiffDrive drive(wheel_base_m);
  OdometryBuffer out;
  for (const EncoderSample& s : samples) out.add(s.t, drive.add(s.left_m, s.right_m));
  return out;
}

OdometryBuffer odometry_from_poses(const std::vector<OdometrySample, Eigen::aligned_allocator<OdometrySample>>& samples) {
  OdometryBuffer out;
  for (const auto& s : samples) out.add(s.t, s.pose);
  return out;
}

}  // namespace pl::client
