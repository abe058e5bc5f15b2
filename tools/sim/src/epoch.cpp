// Epoch 1, six months later: movable things moved, removed or grown, and new ones added.
#include "epoch.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>
#include <utility>
#include <vector>

#include "buildings.hpp"
#include "things.hpp"

namespace pl::sim::worldgen {

// Epoch 1: a share of the movable things moved, removed or grown, and new ones added, so that
// (changed + added) / movable = change_share. Static structure is untouched.
void six_months_later(Site& site) {
  std::mt19937_64 rng(site.cfg.seed * 0xD1B54A32D192ED03ull + 0xE1);
  auto u = [&rng](float a, float b) { return std::uniform_real_distribution<float>(a, b)(rng); };
  std::vector<std::size_t> movable;
  for (std::size_t i = 0; i < site.world.objects.size(); ++i)
    if (is_movable(site.world.objects[i].cls)) movable.push_back(i);
  std::size_t total = static_cast<std::size_t>(std::lround(site.cfg.change_share * static_cast<double>(movable.size())));
  std::size_t to_add = total / 5, to_change = total - to_add;
  std::shuffle(movable.begin(), movable.end(), rng);
  std::vector<bool> remove(site.world.objects.size(), false);
  for (std::size_t k = 0; k < std::min(to_change, movable.size()); ++k) {
    WorldObject& o = site.world.objects[movable[k]];
    if (o.cls == ObjectClass::Tree) {  // vegetation grows
      float g = u(1.2f, 1.4f);
      if (o.shapes.size() == 1) {  // a hedge or a bush: all of it, standing where it stood
        Primitive& p = o.shapes[0];
        p.b *= g;
        p.a.z() = o.base + (p.a.z() - o.base) * g;
        o.half *= g;
        continue;
      }
      for (std::size_t j = 1; j < o.shapes.size(); ++j) {  // a tree: the canopy, not the trunk
        Primitive& p = o.shapes[j];
        p.b *= g;
        p.a.z() = o.base + (p.a.z() - o.base) * (1.0f + (g - 1.0f) * 0.5f);
      }
      o.half *= g;
      continue;
    }
    bool moved = false;
    if ((o.cls == ObjectClass::ParkedCar || o.cls == ObjectClass::ParkedTruck || o.cls == ObjectClass::Container) &&
        u(0.f, 1.f) < 0.5f) {
      // Move along its own axis by 2-6 m, if the new place is free.
      Vec2 fwd(std::cos(o.yaw), std::sin(o.yaw));
      Vec2 shift = fwd * (u(0.f, 1.f) < 0.5f ? -1.f : 1.f) * u(2.f, 6.f);
      site.occ.release(o.centre, o.half, o.yaw);
      std::uint8_t blocking = o.cls == ObjectClass::Container ? Occupancy::kRoad : Occupancy::kLane;
      if (site.occ.free(o.centre + shift, o.half, o.yaw, blocking, 0.0f)) {
        site.occ.take(o.centre + shift, o.half, o.yaw);
        o.centre += shift;
        for (auto& p : o.shapes) p.a.head<2>() += shift;
        moved = true;
      }
    }
    if (!moved) {
      site.occ.release(o.centre, o.half, o.yaw);
      remove[movable[k]] = true;
    }
  }
  std::vector<WorldObject> kept;
  for (std::size_t i = 0; i < site.world.objects.size(); ++i)
    if (!remove[i]) kept.push_back(std::move(site.world.objects[i]));
  site.world.objects = std::move(kept);
  // Additions: parked cars, containers, a fence and a small new building in free places.
  site.rng.seed(site.cfg.seed * 0x94D049BB133111EBull + 0xE2);
  std::size_t added = 0;
  double s0 = site.path.distance_at(site.t0), s1 = site.path.distance_at(site.t1);
  float road = static_cast<float>(site.cfg.road_half_width);
  for (int attempt = 0; added < to_add && attempt < 2000; ++attempt) {
    double s = s0 + site.uniform(0.f, 1.f) * (s1 - s0);
    Frame f = site.frame_at(s);
    float side = site.chance(0.5f) ? 1.f : -1.f;
    int kind = added == 0 ? 3 : (added == 1 ? 2 : static_cast<int>(site.uniform(0.f, 1.99f)));
    if (kind == 0) {
      added += parked_vehicle(site, f, side, 0.f, false);
    } else if (kind == 1) {
      Vec2 c = at(f, 0.f, side * (road + site.uniform(4.f, 8.f)));
      Vec2 half(3.1f, 1.3f);
      if (!site.occ.free(c, half, yaw_of(f), Occupancy::kRoad)) continue;
      site.occ.take(c, half, yaw_of(f));
      container(site, c, yaw_of(f), 0.f, false);
      ++added;
    } else if (kind == 2) {
      double before = site.world.objects.size();
      boundary(site, f, side, site.uniform(8.f, 16.f), true);
      added += site.world.objects.size() > before;
    } else {
      Vec2 half(site.uniform(2.f, 3.f), site.uniform(1.5f, 2.5f));
      Vec2 c = at(f, 0.f, side * (road + 4.f + half.y()));
      if (!site.occ.free(c, half, yaw_of(f), Occupancy::kRoad, 0.5f)) continue;
      site.occ.take(c, half, yaw_of(f));
      WorldObject& o = site.new_object(ObjectClass::SmallBuilding, c, half, yaw_of(f), 3.0f);
      add_box(o, c, o.base, Vec3(half.x(), half.y(), 1.5f), o.yaw, Material::Concrete);
      ++added;
    }
  }
}

}  // namespace pl::sim::worldgen
