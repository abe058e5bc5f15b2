// The street itself: the road and lanes in the occupancy grid, the ground mesh and the curbs.
#include "street.hpp"

#include <cmath>
#include <cstdint>
#include <unordered_map>
#include <utility>
#include <vector>

namespace pl::sim::worldgen {

void mark_roads(Site& site) {
  double s0 = site.path.distance_at(site.t0), s1 = site.path.distance_at(site.t1);
  for (double s = s0; s <= s1; s += 1.0) {
    Frame f = site.frame_at(s);
    site.occ.mark_disc(f.pos, static_cast<float>(site.cfg.road_half_width) + 0.3f, Occupancy::kRoad);
    // The two driving lanes: the ego lane on the path and the oncoming one 3 m to its left
    // (vehicles 1.8-2.5 m wide); parked cars stand from 4.0 m out.
    site.occ.mark_disc(f.pos, 3.95f, Occupancy::kLane);
  }
}

void add_ground(Site& site) {
  // Two triangles per cell within the band; the material follows the distance to the path.
  float cell = static_cast<float>(site.cfg.ground_cell), band = static_cast<float>(site.cfg.ground_band);
  std::unordered_map<std::int64_t, bool> cells;
  std::vector<std::pair<int, int>> order;
  double s0 = site.path.distance_at(site.t0), s1 = site.path.distance_at(site.t1);
  int reach = static_cast<int>(std::ceil(band / cell));
  for (double s = s0; s <= s1; s += cell) {
    Frame f = site.frame_at(s);
    int cx = static_cast<int>(std::floor(f.pos.x() / cell)), cy = static_cast<int>(std::floor(f.pos.y() / cell));
    for (int dx = -reach; dx <= reach; ++dx)
      for (int dy = -reach; dy <= reach; ++dy) {
        if ((dx * dx + dy * dy) * cell * cell > band * band) continue;
        std::int64_t k = grid_key(cx + dx, cy + dy);
        if (cells.emplace(k, true).second) order.emplace_back(cx + dx, cy + dy);
      }
  }
  std::unordered_map<std::int64_t, float> heights;
  auto h = [&](int x, int y) {
    std::int64_t k = grid_key(x, y);
    auto it = heights.find(k);
    if (it != heights.end()) return it->second;
    float v = site.ground.height_at(x * cell, y * cell);
    heights.emplace(k, v);
    return v;
  };
  site.new_object(ObjectClass::Ground, site.frame_at(s0).pos, Vec2(band, band), 0.f, 0.f);
  std::size_t gi = site.world.objects.size() - 1;
  float road = static_cast<float>(site.cfg.road_half_width);
  for (auto [x, y] : order) {
    Vec3 a(x * cell, y * cell, h(x, y)), b((x + 1) * cell, y * cell, h(x + 1, y));
    Vec3 c((x + 1) * cell, (y + 1) * cell, h(x + 1, y + 1)), d(x * cell, (y + 1) * cell, h(x, y + 1));
    float dist = site.ground.distance_to_path((x + 0.5f) * cell, (y + 0.5f) * cell, 20.f);
    Material m = dist < road ? Material::Asphalt : dist < road + 3.5f ? Material::Pavement : Material::Grass;
    WorldObject& go = site.world.objects[gi];
    go.shapes.push_back(make_triangle(a, b, c, 0));
    go.shapes.push_back(make_triangle(a, c, d, 0));
    go.materials.push_back(m);
    go.materials.push_back(m);
  }
}

void curbs(Site& site) {
  float off = static_cast<float>(site.cfg.road_half_width);
  site.walk(0.0, 0.0, [&](const Frame& f, float side, double) {
    Vec2 c = at(f, 1.0f, side * off);
    Vec2 half(1.05f, 0.15f);
    if (!site.occ.free(c, half, yaw_of(f), Occupancy::kLane, 0.0f)) return 2.0;
    WorldObject& o = site.new_object(ObjectClass::Curb, c, half, yaw_of(f), 0.15f);
    add_box(o, c, o.base, Vec3(half.x(), half.y(), 0.075f), o.yaw, Material::Concrete);
    return 2.0;
  });
}

}  // namespace pl::sim::worldgen
