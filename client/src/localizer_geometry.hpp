// Distances between poses the localizer's parts share (localizer.cpp, localizer_integrity.cpp).
// Private to pl_client.
#pragma once

#include <Eigen/Geometry>

#include <cmath>

#include "pl/common/pose.hpp"

namespace pl::client {

constexpr double kDeg = M_PI / 180.0;

inline double horizontal_distance(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return (a.translation() - b.translation()).head<2>().norm();
}

// How far b is turned from a about the vertical, radians (>= 0).
inline double turn_between(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) { return std::abs(yaw_of(a.inverse() * b)); }

}  // namespace pl::client
