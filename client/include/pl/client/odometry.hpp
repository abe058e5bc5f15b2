// Odometry for the localizer: a time-ordered buffer of cumulative poses in the odometry's own frame,
// from wheel encoders (differential drive) or from any pose odometry (odometry.csv). The localizer
// only uses increments between two times, interpolated between samples.
#pragma once

#include <Eigen/Geometry>

#include <deque>
#include <optional>
#include <vector>

#include "pl/recordings/dataset.hpp"

namespace pl::client {

class OdometryBuffer {
 public:
  void add(double t, const Eigen::Isometry3d& pose);  // times must increase; throws pl::Error otherwise
  std::size_t size() const { return times_.size(); }
  bool empty() const { return times_.empty(); }
  double first_time() const { return times_.front(); }
  double last_time() const { return times_.back(); }
  double time(std::size_t i) const { return times_[i]; }
  const Eigen::Isometry3d& pose(std::size_t i) const { return poses_[i]; }
  // The pose at t, interpolated; nullopt outside [first, last] (no extrapolation).
  std::optional<Eigen::Isometry3d> at(double t) const;
  // Index of the first sample with time > t (size() when none).
  std::size_t upper_bound(double t) const;
  // Drops the oldest samples until at most `max_samples` remain (a live buffer stays bounded).
  void keep_last(std::size_t max_samples);

 private:
  std::deque<double> times_;
  std::deque<Eigen::Isometry3d, Eigen::aligned_allocator<Eigen::Isometry3d>> poses_;
};

// Differential drive from cumulative wheel travel, one sample at a time: d = (dl + dr) / 2,
// dtheta = (dr - dl) / L, integrated exactly along each step's arc (its chord, at the heading of the
// arc's middle). The pose starts at the identity with the first sample.
class DiffDrive {
 public:
  explicit DiffDrive(double wheel_base_m);  // throws pl::Error unless the wheel base is positive
  Eigen::Isometry3d add(double left_m, double right_m);

 private:
  double wheel_base_;
  bool first_ = true;
  double left_ = 0, right_ = 0, x_ = 0, y_ = 0, th_ = 0;
};

// A whole encoder log through DiffDrive. Throws pl::Error for a wheel base that is not positive.
OdometryBuffer odometry_from_encoders(const std::vector<EncoderSample>& samples, double wheel_base_m);

// The dataset's odometry.csv poses as they are.
OdometryBuffer odometry_from_poses(const std::vector<OdometrySample, Eigen::aligned_allocator<OdometrySample>>& samples);

}  // namespace pl::client
