// The world under construction, shared by the generator's steps: the driven part of the path and
// frames on it, the seeded random draws, the occupancy grid and the objects placed so far.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>

#include "occupancy.hpp"
#include "pl/sim/world.hpp"

namespace pl::sim::worldgen {

using Vec3 = Eigen::Vector3f;

// A frame on the path: position on the road surface, forward and left directions.
struct Frame {
  Vec2 pos, fwd, left;
  float z;
};

// A point `along` metres ahead and `lateral` to the left (negative: right) of the frame.
inline Vec2 at(const Frame& f, float along, float lateral) { return f.pos + f.fwd * along + f.left * lateral; }
inline float yaw_of(const Frame& f) { return std::atan2(f.fwd.y(), f.fwd.x()); }

// A box standing on `base` at `c`, added to the object's shapes with its material.
void add_box(WorldObject& o, Vec2 c, float base, Vec3 half, float yaw, Material m);

// The steps draw from `rng` in turn, so the order they run in is part of the world.
struct Site {
  Site(const SimTrajectory& path, double t0, double t1, const WorldConfig& cfg);

  float uniform(float a, float b) { return std::uniform_real_distribution<float>(a, b)(rng); }
  bool chance(float p) { return uniform(0.f, 1.f) < p; }
  Frame frame_at(double s) const;  // `s` metres along the path
  // A new object with the next id, standing on the ground at its centre; the caller adds its shapes.
  WorldObject& new_object(ObjectClass cls, Vec2 centre, Vec2 half, float yaw, float height);

  // Walks both sides of the path, calling place(frame, side, s) where `side` is +1 (left) or -1.
  template <typename Place>
  void walk(double step_min, double step_max, Place&& place) {
    double s0 = path.distance_at(t0), s1 = path.distance_at(t1);
    for (int side : {1, -1}) {
      for (double s = s0 + uniform(0.f, static_cast<float>(step_max)); s <= s1;) {
        double used = place(frame_at(s), static_cast<float>(side), s);
        s += std::max(used, 0.0) + uniform(static_cast<float>(step_min), static_cast<float>(step_max));
      }
    }
  }

  const SimTrajectory& path;
  double t0, t1;
  WorldConfig cfg;
  GroundModel ground;
  std::mt19937_64 rng;
  Occupancy occ;
  World world;
  std::uint32_t next_id = 0;
};

}  // namespace pl::sim::worldgen
