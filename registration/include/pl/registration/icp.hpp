// Point-to-plane ICP of a scan against a point map. Gauss-Newton on SE(3) with the rotation taken
// about the sensor, pairs farther than delta dropped (trucks, people, anything the map does not
// have), a robust kernel on the plane distance, and the checks that decide whether a result may be
// trusted: enough inliers, a well-conditioned problem, convergence.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <vector>

#include "pl/registration/point_map.hpp"

namespace pl::registration {

struct IcpConfig {
  int max_iterations = 30;
  double max_pair_m = 1.0;         // delta: pairs farther apart than this are dropped (at most the map's cell)
  double kernel_m = 0.1;           // Geman-McClure scale on the point-to-plane distance, reached after
  double kernel_start_m = 1.0;     // starting this wide and halving each iteration (a prediction off by
                                   // a metre must not have its informative pairs weighted away)
  double converged_m = 1e-3;       // stop when the step moves the sensor less than this
  double converged_rad = 1.5e-4;   // and turns it less than this (0.01 deg)
  double max_boost = 4.0;          // over-relaxation of steps that repeat the previous one's direction
                                   // (1: off; drive 0005: 0.057 m mean APE with, 0.059 m without)
  double unsettled_factor = 10;    // out of iterations with a last step this many times the above: rejected
  double min_inlier_share = 0.25;  // share of scan points paired within delta, below: rejected
  int min_inliers = 100;
  double min_conditioning = 0.02;  // smallest / largest eigenvalue of the translation information, below: degenerate
};

struct IcpResult {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();  // map frame (double)
  int iterations = 0;
  bool converged = false;
  bool accepted = false;    // passed the inlier and conditioning checks
  int pairs = 0;            // pairs within delta at the last iteration
  double inlier_share = 0;  // pairs / scan points
  double rms_m = 0;         // plane-distance RMS of the pairs (weighted)
  double conditioning = 0;  // smallest / largest eigenvalue of the translation information
  Eigen::Matrix<double, 6, 6> covariance = Eigen::Matrix<double, 6, 6>::Identity();  // (v, w) proxy: s^2 H^-1
  const char* reject_reason = "";
};

// Registers `scan` (sensor frame) starting from `guess` (map frame). The scan is taken as given:
// prepare and downsample it before.
IcpResult register_scan(const PointMap& map, const std::vector<Eigen::Vector3f>& scan, const Eigen::Isometry3d& guess,
                        const IcpConfig& cfg = {});

}  // namespace pl::registration
