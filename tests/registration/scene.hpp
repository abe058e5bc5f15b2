// Synthetic scenes for registration tests: rectangles with normals (a street with buildings, bays,
// parked vans and recesses; a corridor), sampled as map points and as LiDAR-like scans.
#pragma once

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <random>
#include <map>
#include <vector>

#include "pl/common/tile_codec.hpp"
#include "pl/common/tile_key.hpp"

namespace pl::test {

struct Surface {
  Eigen::Vector3d origin, u, v;  // a rectangle origin + a u + b v, a, b in [0, 1]
};

// A street: ground, two building fronts with doorways and bays, a few boxes (parked cars, kiosks)
// and poles, sampled every `step` metres, with normals.
inline std::vector<Surface> street(bool with_cross_structure = true) {
  std::vector<Surface> s;
  s.push_back({{-60, -12, 0}, {120, 0, 0}, {0, 24, 0}});  // ground
  for (double side : {-8.0, 8.0})
    for (double x = -60; x < 60; x += 12) {
      const double depth = std::fmod(std::abs(x), 24.0) < 1 ? 1.5 : 0.0;  // bays every other block
      s.push_back({{x, side + (side > 0 ? depth : -depth), 0}, {10, 0, 0}, {0, 0, 8}});
      if (with_cross_structure) s.push_back({{x + 10, side, 0}, {0, side > 0 ? 3.0 : -3.0, 0}, {0, 0, 8}});  // recesses
    }
  if (with_cross_structure)
    for (double x : {-35.0, -12.0, 7.0, 26.0, 44.0}) {  // boxes: parked vans
      const double y = (static_cast<int>(x) % 2 == 0) ? 4.5 : -5.5;
      s.push_back({{x, y, 0}, {4, 0, 0}, {0, 0, 2}});
      s.push_back({{x, y + 1.8, 0}, {4, 0, 0}, {0, 0, 2}});
      s.push_back({{x, y, 0}, {0, 1.8, 0}, {0, 0, 2}});
      s.push_back({{x + 4, y, 0}, {0, 1.8, 0}, {0, 0, 2}});
      s.push_back({{x, y, 2}, {4, 0, 0}, {0, 1.8, 0}});
    }
  return s;
}

// Points every `step` metres on the surfaces (map frame, shifted by offset) with their normals.
inline void sample_surfaces(const std::vector<Surface>& surfaces, double step, std::vector<Eigen::Vector3d>& points,
                            std::vector<Eigen::Vector3f>& normals, const Eigen::Vector3d& offset = Eigen::Vector3d::Zero()) {
  for (const Surface& s : surfaces) {
    const Eigen::Vector3f n = s.u.cross(s.v).normalized().cast<float>();
    const int nu = std::max(1, static_cast<int>(s.u.norm() / step)), nv = std::max(1, static_cast<int>(s.v.norm() / step));
    for (int i = 0; i <= nu; ++i)
      for (int j = 0; j <= nv; ++j) {
        points.push_back(offset + s.origin + s.u * (double(i) / nu) + s.v * (double(j) / nv));
        normals.push_back(n);
      }
  }
}

// A LiDAR-like scan of the surfaces from `sensor` (map frame): points every `step` metres on the
// surfaces within `range`, in the sensor frame, with 1 cm noise.
inline std::vector<Eigen::Vector3f> scan_of(const std::vector<Surface>& surfaces, const Eigen::Isometry3d& sensor, double step,
                                            double range, unsigned seed,
                                            const Eigen::Vector3d& offset = Eigen::Vector3d::Zero()) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, 0.01);
  std::uniform_real_distribution<double> jitter(0.0, 1.0);
  std::vector<Eigen::Vector3f> out;
  const Eigen::Isometry3d inv = sensor.inverse();
  for (const Surface& s : surfaces) {
    const int nu = std::max(1, static_cast<int>(s.u.norm() / step)), nv = std::max(1, static_cast<int>(s.v.norm() / step));
    for (int i = 0; i < nu; ++i)
      for (int j = 0; j < nv; ++j) {
        const Eigen::Vector3d p = offset + s.origin + s.u * ((i + jitter(rng)) / nu) + s.v * ((j + jitter(rng)) / nv);
        if ((p - sensor.translation()).norm() > range) continue;
        const Eigen::Vector3d q = inv * p + Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
        out.push_back(q.cast<float>());
      }
  }
  return out;
}

// The surfaces sampled every `step` metres, cut into the tiles of a `tile_size` grid.
inline std::map<pl::TileKey, pl::TileCloud> surface_tiles(const std::vector<Surface>& surfaces, double step, double tile_size) {
  std::vector<Eigen::Vector3d> points;
  std::vector<Eigen::Vector3f> normals;
  sample_surfaces(surfaces, step, points, normals);
  std::map<pl::TileKey, pl::TileCloud> tiles;
  const pl::TileGrid grid(tile_size);
  for (std::size_t i = 0; i < points.size(); ++i) {
    auto& t = tiles[grid.key_of(points[i].x(), points[i].y())];
    t.points.push_back(points[i]);
    t.normals.push_back(normals[i]);
  }
  return tiles;
}

}  // namespace pl::test
