// The world generator's occupancy grid: 0.5 m cells marking the road, its driving lanes and what
// placed things took, so that a new thing goes only where it fits.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <unordered_map>

#include "pl/sim/world.hpp"

namespace pl::sim::worldgen {

using Vec2 = Eigen::Vector2f;

// Occupancy of 0.5 m cells: what the road needs and what objects took.
class Occupancy {
 public:
  enum : std::uint8_t { kFree = 0, kRoad = 1, kLane = 2, kTaken = 3 };
  static constexpr float kCell = 0.5f;

  std::uint8_t at(int cx, int cy) const {
    auto it = cells_.find(key(cx, cy));
    return it == cells_.end() ? static_cast<std::uint8_t>(kFree) : it->second;
  }
  void raise(int cx, int cy, std::uint8_t v) {
    auto& c = cells_[key(cx, cy)];
    c = std::max(c, v);
  }
  void mark_disc(Vec2 c, float r, std::uint8_t v) {
    int x0 = cell(c.x() - r), x1 = cell(c.x() + r), y0 = cell(c.y() - r), y1 = cell(c.y() + r);
    for (int x = x0; x <= x1; ++x)
      for (int y = y0; y <= y1; ++y) {
        Vec2 q((x + 0.5f) * kCell, (y + 0.5f) * kCell);
        if ((q - c).norm() <= r) raise(x, y, v);
      }
  }
  // Cells whose centre lies in the rectangle (grown by `margin`); `fn(x, y)` for each.
  template <typename Fn>
  void for_rect(Vec2 centre, Vec2 half, float yaw, float margin, Fn&& fn) const {
    float c = std::cos(yaw), s = std::sin(yaw);
    float ex = std::abs(c) * (half.x() + margin) + std::abs(s) * (half.y() + margin);
    float ey = std::abs(s) * (half.x() + margin) + std::abs(c) * (half.y() + margin);
    int x0 = cell(centre.x() - ex), x1 = cell(centre.x() + ex), y0 = cell(centre.y() - ey), y1 = cell(centre.y() + ey);
    for (int x = x0; x <= x1; ++x)
      for (int y = y0; y <= y1; ++y) {
        Vec2 q = Vec2((x + 0.5f) * kCell, (y + 0.5f) * kCell) - centre;
        float u = c * q.x() + s * q.y(), v = -s * q.x() + c * q.y();
        if (std::abs(u) <= half.x() + margin && std::abs(v) <= half.y() + margin) fn(x, y);
      }
  }
  // True when no cell of the rectangle is at or above `blocking`.
  bool free(Vec2 centre, Vec2 half, float yaw, std::uint8_t blocking, float margin = 0.3f) const {
    bool ok = true;
    for_rect(centre, half, yaw, margin, [&](int x, int y) { ok = ok && at(x, y) < blocking; });
    return ok;
  }
  void take(Vec2 centre, Vec2 half, float yaw) {
    for_rect(centre, half, yaw, 0.0f, [&](int x, int y) { raise(x, y, kTaken); });
  }
  void release(Vec2 centre, Vec2 half, float yaw) {
    for_rect(centre, half, yaw, 0.0f, [&](int x, int y) {
      auto it = cells_.find(key(x, y));
      if (it != cells_.end() && it->second == kTaken) it->second = kFree;
    });
  }

 private:
  static int cell(float v) { return static_cast<int>(std::floor(v / kCell)); }
  static std::int64_t key(int x, int y) { return grid_key(x, y); }
  std::unordered_map<std::int64_t, std::uint8_t> cells_;
};

}  // namespace pl::sim::worldgen
