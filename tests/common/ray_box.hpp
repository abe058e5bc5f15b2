// Where a ray enters an axis-aligned box (the slab test), for the scenes tests cast by hand.
#pragma once

#include <Eigen/Core>

#include <algorithm>
#include <cmath>
#include <optional>

namespace pl::test {

// The distance along the ray from `o` in direction `d` at which it enters the box [lo, hi], when
// that is within (0, limit); none otherwise (a ray starting inside the box does not enter it).
inline std::optional<double> ray_enters_box(const Eigen::Vector3d& o, const Eigen::Vector3d& d, const Eigen::Vector3d& lo,
                                            const Eigen::Vector3d& hi, double limit) {
  double t0 = 0, t1 = limit;
  for (int k = 0; k < 3; ++k) {
    if (std::abs(d[k]) < 1e-12) {
      if (o[k] < lo[k] || o[k] > hi[k]) return std::nullopt;
      continue;
    }
    double a = (lo[k] - o[k]) / d[k], c = (hi[k] - o[k]) / d[k];
    if (a > c) std::swap(a, c);
    t0 = std::max(t0, a);
    t1 = std::min(t1, c);
    if (t0 > t1) return std::nullopt;
  }
  if (t0 > 0 && t0 < limit) return t0;
  return std::nullopt;
}

}  // namespace pl::test
