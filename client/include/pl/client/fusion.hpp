// Fusion of odometry and the late-arriving LiDAR results: a steady-state Kalman filter.
//
// The state is the correction C that takes the odometry frame into the map: the pose at any time t
// is X(t) = C * O(t), O the odometry's pose at t. A LiDAR result belongs to its scan's time ts, not
// to the time it is ready: the innovation is taken against X(ts) (the odometry buffer is kept for
// that), a constant gain per axis of the vehicle frame moves X(ts) toward the measurement, and C is
// re-derived from it -- every later pose, already-buffered odometry included, is re-propagated by that.
// The gain is the steady state of the Riccati recursion for a random walk of the odometry error per
// scan interval (process noise) observed by LiDAR (measurement noise), axis by axis.
// Without odometry (or where it has a gap) the prediction is constant-velocity "momentum" from the
// last corrected scan poses: in the ground plane over the last fraction of a second, height, roll
// and pitch over a few scan intervals (FusionConfig).
#pragma once

#include <Eigen/Geometry>

#include <array>
#include <optional>
#include <vector>

#include "pl/client/odometry.hpp"

namespace pl::client {

struct FusionConfig {
  // Standard deviations per scan interval, vehicle frame: x (along), y (across), z, roll, pitch, yaw.
  // Wheel odometry knows nothing of z, roll and pitch: large process noise, the LiDAR rules them.
  std::array<double, 6> odometry_sigma = {0.03, 0.02, 1.0, 0.1, 0.1, 0.004};
  std::array<double, 6> lidar_sigma = {0.02, 0.02, 0.02, 0.003, 0.003, 0.002};
  // Momentum: the velocity over this many scan intervals (more smooths the registration noise that
  // a two-pose velocity would double, fewer follows acceleration sooner) -- for height, roll and
  // pitch, which follow the road slowly and which a 16-beam scan fixes least well.
  int momentum_window = 3;
  // ... and for the motion in the ground plane (along, across, yaw), which the driver changes: the
  // last intervals within this many seconds (at least one, at most momentum_window). Braking at
  // 1.7 m/s2 with scans 0.83 s apart (pl-sim's KITTI 00, LiDAR only, every 4th odd scan), a
  // three-interval velocity was 2-3.5 m off, past the LiDAR odometry's basin, and the scan was lost;
  // from the last interval alone the every-3rd drive's APE mean fell from 0.106 to 0.040 m. With
  // scans 0.2 s apart one interval's registration noise made drive 0005's motion-compensated scans
  // worse (0.121 against 0.087 m): 0.4 s takes two there. Height, roll and pitch from one interval
  // as well made drive 0005 at four times the speed worse (0.065 against 0.057 m).
  double momentum_plane_s = 0.4;
};

// Steady-state gain per axis: K = P / (P + R), P the predicted variance solving P = (1 - K) P + Q.
std::array<double, 6> steady_state_gain(const FusionConfig& cfg);

class Fusion {
 public:
  explicit Fusion(const FusionConfig& cfg = {});
  // Starts at `pose` at time t. `odometry` may be nullptr (momentum only); it must outlive this.
  void reset(const Eigen::Isometry3d& pose, double t, const OdometryBuffer* odometry);
  bool initialized() const { return initialized_; }
  // Starts again at `pose` at t with the same odometry (momentum forgets the poses before).
  void restart(const Eigen::Isometry3d& pose, double t) { reset(pose, t, odometry_); }
  // The pose at t: odometry when it covers t, else momentum.
  Eigen::Isometry3d predict(double t) const;
  bool odometry_covers(double t) const;
  // A LiDAR result for the scan taken at ts. Returns the fused pose at ts.
  Eigen::Isometry3d correct(double ts, const Eigen::Isometry3d& measured);
  // Marks a scan time where no LiDAR result was fused (keeps momentum going from the prediction).
  void coast(double ts);
  // ... where another measurement of the motion (LiDAR odometry) put the vehicle at ts.
  void coast(double ts, const Eigen::Isometry3d& pose);
  const std::array<double, 6>& gain() const { return gain_; }

 private:
  std::array<double, 6> gain_;
  const OdometryBuffer* odometry_ = nullptr;
  bool initialized_ = false;
  bool have_correction_ = false;
  Eigen::Isometry3d correction_ = Eigen::Isometry3d::Identity();  // map_from_odometry
  int window_;      // intervals kept: momentum_window
  double plane_s_;  // momentum_plane_s
  // The last scan-time poses, oldest first, for momentum.
  std::vector<double> times_;
  std::vector<Eigen::Isometry3d, Eigen::aligned_allocator<Eigen::Isometry3d>> poses_;
  void remember(double ts, const Eigen::Isometry3d& x);
};

}  // namespace pl::client
