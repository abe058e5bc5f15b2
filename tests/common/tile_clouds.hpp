// Clouds for the tile codec tests (test_tile_codec*.cpp) and the check of a round trip: a realistic
// 20 m map tile, random clouds, and the worst errors between a cloud and its decoding.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <unordered_map>
#include <vector>

#include <Eigen/Geometry>

#include "pl/common/tile_codec.hpp"

namespace pl::test {

inline Eigen::Vector3f perturbed(Eigen::Vector3f n, std::mt19937& rng, double sigma_deg) {
  std::normal_distribution<float> g(0.f, static_cast<float>(sigma_deg * M_PI / 180.0));
  return (n + Eigen::Vector3f(g(rng), g(rng), g(rng))).normalized();
}

// A 20 m map tile as the voxel map (0.2 m) stores it: voxel centroids on the ground (with road
// markings), on a facade, on poles, and some clutter, with noisy normals and intensity. `corner` is
// the tile's low corner in ENU.
inline TileCloud realistic_tile(const Eigen::Vector3d& corner, unsigned seed, double normal_sigma_deg = 2.0) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  std::normal_distribution<double> g(0, 1);
  TileCloud t;
  auto add = [&](const Eigen::Vector3d& p, const Eigen::Vector3f& n, double intensity) {
    t.points.push_back(corner + p);
    t.normals.push_back(perturbed(n, rng, normal_sigma_deg));
    t.intensity.push_back(static_cast<float>(std::clamp(intensity, 0.0, 1.0)));
  };
  const double v = 0.2;
  for (int ix = 0; ix < 100; ++ix)  // ground, 20 m x 10 m, partly occluded
    for (int iy = 0; iy < 50; ++iy) {
      if (u(rng) > 0.6) continue;
      const double x = (ix + 0.5) * v + 0.02 * g(rng), y = (iy + 0.5) * v + 0.02 * g(rng);
      const bool marking = (iy == 20 || iy == 21) && ix % 10 < 5;
      add({x, y, 0.3 + 0.01 * x + 0.005 * g(rng)}, {0, 0, 1}, marking ? 0.8 + 0.05 * g(rng) : 0.2 + 0.04 * g(rng));
    }
  for (int ix = 0; ix < 100; ++ix)  // facade at y = 12 m, 5 m high
    for (int iz = 0; iz < 25; ++iz) {
      if (u(rng) > 0.7) continue;
      const double x = (ix + 0.5) * v + 0.02 * g(rng), z = 0.4 + (iz + 0.5) * v + 0.02 * g(rng);
      add({x, 12.0 + 0.005 * g(rng), z}, {0, -1, 0}, 0.5 + 0.1 * g(rng));
    }
  for (int k = 0; k < 6; ++k)  // poles
    for (int iz = 0; iz < 20; ++iz)
      for (int a = 0; a < 4; ++a) {
        const double angle = a * M_PI / 2 + 0.3 * g(rng);
        const Eigen::Vector3f n(static_cast<float>(std::cos(angle)), static_cast<float>(std::sin(angle)), 0.f);
        add({1.5 + 3.2 * k + 0.12 * std::cos(angle), 10.5 + 0.12 * std::sin(angle), 0.4 + iz * v + 0.03 * g(rng)}, n,
            0.6 + 0.1 * g(rng));
      }
  for (int k = 0; k < 300; ++k) {  // clutter
    const Eigen::Vector3f n = Eigen::Vector3f(g(rng), g(rng), g(rng)).normalized();
    add({u(rng) * 20, 10 + u(rng) * 1.5, 0.4 + u(rng) * 1.2}, n, 0.3 + 0.1 * g(rng));
  }
  return t;
}

// `n` random points in a box, with unit normals and intensity.
inline TileCloud random_cloud(std::size_t n, const Eigen::Vector3d& lo, const Eigen::Vector3d& size, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  std::normal_distribution<float> g(0.f, 1.f);
  TileCloud t;
  for (std::size_t i = 0; i < n; ++i) {
    t.points.push_back(lo + Eigen::Vector3d(u(rng) * size.x(), u(rng) * size.y(), u(rng) * size.z()));
    t.normals.push_back(Eigen::Vector3f(g(rng), g(rng), g(rng)).normalized());
    t.intensity.push_back(static_cast<float>(u(rng)));
  }
  return t;
}

inline double angle_between(const Eigen::Vector3f& a, const Eigen::Vector3f& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b));
}

// Largest angular error of a normal quantized with `bits` (octahedral in Draco's sequential coder,
// per component in its k-d tree coder): a few quantization steps of 2 / 2^bits.
inline double normal_tolerance(int bits) { return 4.5 / (std::ldexp(1.0, bits) - 2); }

// Worst errors between an input cloud and its decoding, after pairing each input point with a
// decoded one (decoding may reorder the points).
struct Errors {
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  // per axis
  double normal_rad = 0;
  double intensity = 0;
};

inline Errors compare(const TileCloud& in, const TileCloud& out, double pos_tol, double normal_tol, double intensity_tol) {
  Errors e;
  EXPECT_EQ(out.points.size(), in.points.size());
  EXPECT_EQ(out.normals.size(), in.normals.size());
  EXPECT_EQ(out.intensity.size(), in.intensity.size());
  if (out.points.size() != in.points.size() || out.normals.size() != in.normals.size() ||
      out.intensity.size() != in.intensity.size())
    return e;
  // Hash the decoded points on a grid of cells 2 * pos_tol wide; a partner lies in the 27 cells around.
  const double cell = 2 * pos_tol;
  auto key = [&](const Eigen::Vector3d& p, int dx, int dy, int dz) {
    const auto ix = static_cast<int64_t>(std::floor(p.x() / cell)) + dx;
    const auto iy = static_cast<int64_t>(std::floor(p.y() / cell)) + dy;
    const auto iz = static_cast<int64_t>(std::floor(p.z() / cell)) + dz;
    return (static_cast<uint64_t>(ix) * 73856093u) ^ (static_cast<uint64_t>(iy) * 19349663u) ^
           (static_cast<uint64_t>(iz) * 83492791u);
  };
  std::unordered_multimap<uint64_t, std::size_t> grid;
  for (std::size_t j = 0; j < out.points.size(); ++j) grid.emplace(key(out.points[j], 0, 0, 0), j);
  std::vector<bool> used(out.points.size(), false);
  std::size_t unmatched = 0;
  for (std::size_t i = 0; i < in.points.size(); ++i) {
    std::size_t best = SIZE_MAX;
    double best_cost = std::numeric_limits<double>::infinity();
    for (int dx = -1; dx <= 1; ++dx)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dz = -1; dz <= 1; ++dz) {
          auto range = grid.equal_range(key(in.points[i], dx, dy, dz));
          for (auto it = range.first; it != range.second; ++it) {
            const std::size_t j = it->second;
            if (used[j]) continue;
            const Eigen::Vector3d d = (out.points[j] - in.points[i]).cwiseAbs();
            if (d.maxCoeff() > pos_tol) continue;
            double cost = d.maxCoeff() / pos_tol;
            if (!in.normals.empty()) cost += angle_between(in.normals[i], out.normals[j]) / normal_tol;
            if (!in.intensity.empty()) cost += std::abs(in.intensity[i] - out.intensity[j]) / intensity_tol;
            if (cost < best_cost) {
              best_cost = cost;
              best = j;
            }
          }
        }
    if (best == SIZE_MAX) {
      if (++unmatched <= 5) ADD_FAILURE() << "input point " << i << " has no decoded point within " << pos_tol << " m";
      continue;
    }
    used[best] = true;
    e.position = e.position.cwiseMax((out.points[best] - in.points[i]).cwiseAbs());
    if (!in.normals.empty()) e.normal_rad = std::max(e.normal_rad, angle_between(in.normals[i], out.normals[best]));
    if (!in.intensity.empty())
      e.intensity = std::max(e.intensity, static_cast<double>(std::abs(in.intensity[i] - out.intensity[best])));
  }
  EXPECT_EQ(unmatched, 0u);
  return e;
}

// Encodes, decodes and checks every bound of `cfg`.
inline Errors round_trip(const TileCloud& in, const TileCodecConfig& cfg = {}) {
  const std::string bytes = pl::encode_tile(in, cfg);
  const TileCloud out = pl::decode_tile(bytes);
  const double normal_tol = normal_tolerance(cfg.normal_bits);
  const double intensity_tol = 1.0 / std::ldexp(1.0, cfg.intensity_bits);
  const Errors e = compare(in, out, cfg.max_error_m, normal_tol, intensity_tol);
  for (int c = 0; c < 3; ++c) EXPECT_LE(e.position[c], cfg.max_error_m) << "axis " << c;
  EXPECT_LE(e.normal_rad, normal_tol);
  EXPECT_LE(e.intensity, intensity_tol);
  for (const auto& n : out.normals) EXPECT_NEAR(n.norm(), 1.0f, 1e-5f);
  const pl::TileSummary s = pl::inspect_tile(bytes);
  EXPECT_EQ(s.points, in.size());
  EXPECT_EQ(s.has_normals, !in.normals.empty());
  EXPECT_EQ(s.has_intensity, !in.intensity.empty());
  return e;
}

}  // namespace pl::test
