// The procedural world along a trajectory (see world.hpp): the two presets, town and estate, and
// the order a world is built in. Its parts, each in its own header:
//   site.hpp       the world under construction: frames on the path, random draws, placed objects
//   occupancy.hpp  the 0.5 m grid that keeps things off the road and off each other
//   street.hpp     the road and its lanes, the ground mesh and the curbs
//   things.hpp     parked vehicles, containers, trees, poles and signs
//   buildings.hpp  houses and warehouses, walls and fences, the town's backdrop
//   roadside.hpp   the town's poles, avenue trees and gardens
//   epoch.hpp      six months later: things moved, removed, grown or added
#include <utility>

#include "buildings.hpp"
#include "epoch.hpp"
#include "pl/common/error.hpp"
#include "pl/sim/world.hpp"
#include "roadside.hpp"
#include "site.hpp"
#include "street.hpp"
#include "things.hpp"

namespace pl::sim {

namespace worldgen {
namespace {

void town(Site& site) {
  curbs(site);
  // Parking lane: runs of parked cars with driveways between them.
  site.walk(1.0, 6.0, [&](const Frame& f, float side, double) {
    if (site.chance(0.25f)) return 8.0;  // a driveway or no-parking stretch
    return parked_vehicle(site, f, side, 0.f, site.chance(0.04f)) ? 4.8 : 1.0;
  });
  street_furniture(site, 0.45f);
  // Buildings with gaps; walls, fences and the odd container in the gaps.
  site.walk(0.0, 6.0, [&](const Frame& f, float side, double) {
    float r = site.uniform(0.f, 1.f);
    if (r < 0.72f) return building(site, f, side, false);
    if (r < 0.92f) return boundary(site, f, side, site.uniform(6.f, 20.f), false);
    float road = static_cast<float>(site.cfg.road_half_width);
    Vec2 c = at(f, 4.f, side * (road + site.uniform(4.f, 8.f)));
    Vec2 half(3.1f, 1.3f);
    if (site.occ.free(c, half, yaw_of(f), Occupancy::kRoad)) {
      site.occ.take(c, half, yaw_of(f));
      container(site, c, yaw_of(f), 0.f, false);
    }
    return 8.0;
  });
  gardens(site);
  if (site.cfg.backdrop) second_row(site);
}

void estate(Site& site) {
  curbs(site);
  double s0 = site.path.distance_at(site.t0), s1 = site.path.distance_at(site.t1);
  double square_from = s0 + 0.55 * (s1 - s0), square_to = s0 + 0.72 * (s1 - s0);  // the open square
  auto in_square = [&](double s, float side) { return side > 0 && s > square_from && s < square_to; };
  // Trucks and cars parked in front of the loading bays.
  site.walk(2.0, 14.0, [&](const Frame& f, float side, double s) {
    if (in_square(s, side) || site.chance(0.35f)) return 10.0;
    bool truck = site.chance(0.45f);
    return parked_vehicle(site, f, side, 0.f, truck) ? (truck ? 10.0 : 4.8) : 1.0;
  });
  site.walk(30.0, 60.0, [&](const Frame& f, float side, double s) {
    if (in_square(s, side)) return 0.0;
    float road = static_cast<float>(site.cfg.road_half_width);
    Vec2 c = at(f, 0.f, side * (road + 0.9f));
    if (!site.occ.free(c, Vec2(0.3f, 0.3f), 0.f, Occupancy::kRoad, 0.0f)) return 0.0;
    site.occ.take(c, Vec2(0.3f, 0.3f), 0.f);
    pole(site, c, site.chance(0.2f), yaw_of(f));
    return 0.0;
  });
  // Warehouses, fenced yards with stacked containers; the square stays open.
  site.walk(4.0, 15.0, [&](const Frame& f, float side, double s) {
    if (in_square(s, side)) return 20.0;
    if (site.chance(0.65f)) return building(site, f, side, true);
    float len = site.uniform(20.f, 45.f);
    double used = boundary(site, f, side, len, true);
    float road = static_cast<float>(site.cfg.road_half_width);
    for (float a = 4.f; a + 6.f < len; a += site.uniform(6.5f, 9.f)) {
      Vec2 c = at(f, a, side * (road + site.uniform(7.f, 10.f)));
      float yaw = yaw_of(f) + (site.chance(0.3f) ? 1.5708f : 0.f);
      Vec2 half(3.1f, 1.3f);
      if (!site.occ.free(c, half, yaw, Occupancy::kRoad)) continue;
      site.occ.take(c, half, yaw);
      container(site, c, yaw, 0.f, false);
      if (site.chance(0.4f)) container(site, c, yaw, 2.6f, false);
    }
    return used;
  });
  // A few trees at the square's edge.
  site.walk(20.0, 40.0, [&](const Frame& f, float side, double) {
    float road = static_cast<float>(site.cfg.road_half_width);
    Vec2 c = at(f, 0.f, side * (road + 2.0f));
    if (!site.chance(0.3f) || !site.occ.free(c, Vec2(0.5f, 0.5f), 0.f, Occupancy::kRoad, 0.0f)) return 0.0;
    site.occ.take(c, Vec2(0.5f, 0.5f), 0.f);
    tree(site, c, 1.1f);
    return 0.0;
  });
}

}  // namespace
}  // namespace worldgen

World build_world(const SimTrajectory& path, double t0, double t1, const WorldConfig& cfg) {
  if (cfg.preset != "town" && cfg.preset != "estate") throw Error("unknown world preset \"" + cfg.preset + "\" (town or estate)");
  if (cfg.epoch < 0 || cfg.epoch > 1) throw Error("--epoch takes 0 or 1");
  if (!(cfg.change_share >= 0.0 && cfg.change_share <= 1.0)) throw Error("the change share must be between 0 and 1");
  using namespace worldgen;
  Site site(path, t0, t1, cfg);
  mark_roads(site);
  add_ground(site);
  if (site.cfg.preset == "estate")
    estate(site);
  else
    town(site);
  site.world.config = site.cfg;
  if (site.cfg.epoch >= 1) six_months_later(site);
  return std::move(site.world);
}

}  // namespace pl::sim
