// Motion compensation of a spinning LiDAR's sweep: a scan's points are taken over the sweep while
// the sensor moves, and each is moved to where the sensor was at the scan's time, with the motion
// over the sweep taken as constant (from the prediction, or neighbouring poses of a drive).
#pragma once

#include <Eigen/Geometry>

#include <cmath>
#include <vector>

namespace pl::registration {

// A point's time within the sweep from its azimuth, as a share of the sweep: a counter-clockwise spin
// seen from above, timed when facing straight ahead: -0.5 just past the back on the right, 0 ahead,
// +0.5 back on the left. Of the six ways to time a sweep from its azimuth this one fitted KITTI's
// drive 0005 (HDL-64E) best: map and scans compensated this way gave 0.055 / 0.061 / 0.070 / 0.071 m
// APE at one to four times its speed, taken clockwise 0.076 / 0.109 / 0.131 / 0.129 m, and the other
// four ways (starting or ending the sweep ahead) 0.059 to 0.086 m at 1x (docs/benchmarks.md). One
// drive's evidence: a sensor whose driver gives its points' times should give them.
inline float sweep_share_from_azimuth(const Eigen::Vector3f& p) {
  return static_cast<float>(std::atan2(static_cast<double>(p.y()), static_cast<double>(p.x())) / (2.0 * M_PI));
}

// Each point (sensor frame) moved by its share of `sweep`, the sensor's motion over one whole sweep
// in its own frame: p -> R(s) p + s t. Shares from the azimuth when `shares` is empty.
void compensate_motion(std::vector<Eigen::Vector3f>& points, const Eigen::Isometry3d& sweep, const std::vector<float>& shares = {});

}  // namespace pl::registration
