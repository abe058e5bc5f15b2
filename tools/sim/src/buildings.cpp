// Buildings and what stands between them: facades with bays and windows, walls and fences, and
// the backdrop row.
#include "buildings.hpp"

#include <algorithm>
#include <cmath>

namespace pl::sim::worldgen {

// A building whose street facade faces the path: recesses, bays and windows.
double building(Site& site, const Frame& f, float side, bool warehouse) {
  float road = static_cast<float>(site.cfg.road_half_width);
  float len = warehouse ? site.uniform(30.f, 70.f) : site.uniform(9.f, 28.f);
  float depth = warehouse ? site.uniform(20.f, 40.f) : site.uniform(10.f, 18.f);
  float height = warehouse ? site.uniform(8.f, 14.f) : site.uniform(7.f, 21.f);
  float setback = warehouse ? site.uniform(12.f, 30.f) : site.uniform(3.f, 9.f);
  Vec2 c = at(f, len * 0.5f, side * (road + setback + depth * 0.5f));
  float yaw = yaw_of(f);
  Vec2 half(len * 0.5f, depth * 0.5f);
  if (!site.occ.free(c, half, yaw, Occupancy::kRoad, 0.5f)) {
    // Curves and junctions: try a shorter building before giving up.
    half.x() *= 0.5f;
    c = at(f, half.x(), side * (road + setback + depth * 0.5f));
    if (!site.occ.free(c, half, yaw, Occupancy::kRoad, 0.5f)) return 3.0;
    len = half.x() * 2;
  }
  site.occ.take(c, half, yaw);
  WorldObject& o = site.new_object(ObjectClass::Building, c, half, yaw, height);
  Material wall = warehouse ? Material::Metal : (site.chance(0.5f) ? Material::Brick : Material::Concrete);
  add_box(o, c, o.base, Vec3(half.x(), half.y(), height * 0.5f), yaw, wall);
  float facade = road + setback;  // lateral offset of the facade from the path
  // Bays standing out of the facade and recessed entrances (a box set back hides nothing, so a
  // recess is a gap between two bays).
  int bays = warehouse ? 0 : static_cast<int>(site.uniform(0.f, 2.99f));
  for (int k = 0; k < bays; ++k) {
    float bl = site.uniform(2.f, std::max(2.5f, len * 0.35f)), bz0 = site.uniform(0.f, 3.f);
    float along = site.uniform(bl * 0.5f, std::max(bl * 0.5f + 0.1f, len - bl * 0.5f));
    float proud = site.uniform(0.4f, 1.2f);
    Vec2 bc = at(f, along, side * (facade - proud * 0.5f));
    add_box(o, bc, o.base + bz0, Vec3(bl * 0.5f, proud * 0.5f, (height - bz0) * 0.5f * site.uniform(0.6f, 1.0f)), yaw, wall);
  }
  // Windows: glass panes 3 cm proud of the facade on a grid (loading doors on warehouses).
  float wx = warehouse ? 6.0f : 2.6f, wz = warehouse ? 100.f : 3.1f;
  for (float a = 1.5f; a < len - 1.0f; a += wx) {
    for (float z = warehouse ? 0.0f : 1.2f; z + 1.5f < height; z += wz) {
      if (site.chance(0.15f)) continue;
      Vec2 wc = at(f, a + 0.6f, side * (facade - 0.015f));
      Vec3 whalf = warehouse ? Vec3(2.0f, 0.02f, 2.2f) : Vec3(0.6f, 0.02f, 0.75f);
      o.shapes.push_back(make_box(Vec3(wc.x(), wc.y(), o.base + z + whalf.z()), whalf, yaw, 0));
      o.materials.push_back(warehouse ? Material::Metal : Material::Glass);
    }
  }
  return len;
}

// Between buildings: a wall or a fence along the pavement's back edge.
double boundary(Site& site, const Frame& f, float side, float length, bool fence_only) {
  float road = static_cast<float>(site.cfg.road_half_width);
  Vec2 c = at(f, length * 0.5f, side * (road + 3.2f));
  float yaw = yaw_of(f);
  Vec2 half(length * 0.5f, 0.15f);
  if (!site.occ.free(c, half, yaw, Occupancy::kRoad, 0.2f)) return 2.0;
  site.occ.take(c, half, yaw);
  bool fence = fence_only || site.chance(0.5f);
  WorldObject& o = site.new_object(fence ? ObjectClass::Fence : ObjectClass::Wall, c, half, yaw, fence ? 1.8f : 2.0f);
  if (!fence) {
    add_box(o, c, o.base, Vec3(half.x(), 0.15f, site.uniform(0.8f, 1.2f)), yaw, Material::Concrete);
    return length;
  }
  // Posts every 2.5 m and two rails: a sparse, see-through structure.
  Vec2 fwd(std::cos(yaw), std::sin(yaw));
  for (float a = -half.x(); a <= half.x() + 1e-3f; a += 2.5f) {
    Vec2 pc = c + fwd * a;
    o.shapes.push_back(make_cylinder(Vec3(pc.x(), pc.y(), o.base), 0.05f, 1.8f, 0));
    o.materials.push_back(Material::Metal);
  }
  for (float z : {0.5f, 1.6f}) {
    add_box(o, c, o.base + z, Vec3(half.x(), 0.03f, 0.05f), yaw, Material::Metal);
  }
  return length;
}

// The next street's houses behind the back gardens, seen over and between the first row: a real
// town goes on behind its street. Without them a simulated scan had half the real share of returns
// at 30-80 m and above the sensor, and two thirds of the real drive's points after preparation
// (docs/benchmarks.md, the simulator against the street). Placed last, so the worlds before them
// are unchanged object for object.
void second_row(Site& site) {
  const float road = static_cast<float>(site.cfg.road_half_width);
  site.walk(1.0, 4.0, [&](const Frame& f, float side, double) {
    const float len = site.uniform(25.f, 60.f), depth = site.uniform(9.f, 15.f), height = site.uniform(8.f, 22.f);
    const Vec2 c = at(f, len * 0.5f, side * (road + site.uniform(30.f, 45.f) + depth * 0.5f));
    const float yaw = yaw_of(f);
    const Vec2 half(len * 0.5f, depth * 0.5f);
    if (!site.occ.free(c, half, yaw, Occupancy::kRoad, 0.5f)) return 4.0;
    site.occ.take(c, half, yaw);
    WorldObject& o = site.new_object(ObjectClass::Building, c, half, yaw, height);
    add_box(o, c, o.base, Vec3(half.x(), half.y(), height * 0.5f), yaw, site.chance(0.5f) ? Material::Brick : Material::Concrete);
    return static_cast<double>(len);
  });
}

}  // namespace pl::sim::worldgen
