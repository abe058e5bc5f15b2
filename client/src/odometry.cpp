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

OdometryBuffer odometry_from_encoders(const std::vector<EncoderSample>& samples, double wheel_base_m) {
  if (!(wheel_base_m > 0))
    throw Error("encoder odometry needs vehicle.wheel_base_m > 0 in meta.json (got " + std::to_string(wheel_base_m) + ")");
  OdometryBuffer out;
  double x = 0, y = 0, th = 0;
  for (std::size_t i = 0; i < samples.size(); ++i) {
    if (i > 0) {
      const double dl = samples[i].left_m - samples[i - 1].left_m;
      const double dr = samples[i].right_m - samples[i - 1].right_m;
      const double d = 0.5 * (dl + dr);
      const double dth = (dr - dl) / wheel_base_m;
      // The chord of the arc, along the heading at its middle.
      const double half = 0.5 * dth;
      const double chord = std::abs(half) < 1e-9 ? d : d * std::sin(half) / half;
      x += chord * std::cos(th + half);
      y += chord * std::sin(th + half);
      th += dth;
    }
    out.add(samples[i].t, make_pose(x, y, 0.0, 0.0, 0.0, th));
  }
  return out;
}

OdometryBuffer odometry_from_poses(const std::vector<OdometrySample, Eigen::aligned_allocator<OdometrySample>>& samples) {
  OdometryBuffer out;
  for (const auto& s : samples) out.add(s.t, s.pose);
  return out;
}

}  // namespace pl::client
