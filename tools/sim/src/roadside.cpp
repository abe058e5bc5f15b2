// What stands beside the town's road: poles, signs and trees at the kerb, hedges, bushes and trees
// in the gardens.
#include "roadside.hpp"

#include "things.hpp"

namespace pl::sim::worldgen {

void street_furniture(Site& site, float tree_share) {
  float road = static_cast<float>(site.cfg.road_half_width);
  // Poles and signs at the pavement's kerb side.
  site.walk(18.0, 40.0, [&](const Frame& f, float side, double) {
    Vec2 c = at(f, 0.f, side * (road + 0.9f));
    if (!site.occ.free(c, Vec2(0.3f, 0.3f), 0.f, Occupancy::kRoad, 0.0f)) return 0.0;
    site.occ.take(c, Vec2(0.3f, 0.3f), 0.f);
    pole(site, c, site.chance(0.3f), yaw_of(f) + (side > 0 ? -1.5708f : 1.5708f));
    return 0.0;
  });
  // Trees in avenue stretches.
  site.walk(7.0, 13.0, [&](const Frame& f, float side, double) {
    if (!site.chance(tree_share)) return 10.0;
    Vec2 c = at(f, 0.f, side * (road + site.uniform(1.6f, 2.6f)));
    if (!site.occ.free(c, Vec2(0.5f, 0.5f), 0.f, Occupancy::kRoad, 0.0f)) return 0.0;
    site.occ.take(c, Vec2(0.5f, 0.5f), 0.f);
    tree(site, c, 1.0f);
    return 0.0;
  });
}

// Front gardens and back gardens, as residential streets have (drive 0005's is one): hedges and
// bushes behind the pavement where the buildings leave room, trees behind the first row. The
// first simulator's streets were bare planes; this clutter is what a real scan's voxels and
// conditioning come from (docs/pl-sim.md, the table against the real drive).
void gardens(Site& site) {
  const float road = static_cast<float>(site.cfg.road_half_width);
  site.walk(0.5, 3.0, [&](const Frame& f, float side, double) {
    const float yaw = yaw_of(f);
    if (site.chance(0.55f)) {  // a hedge along the pavement's back edge
      const float length = site.uniform(3.f, 9.f), depth = site.uniform(0.3f, 0.5f), height = site.uniform(0.8f, 1.7f);
      const Vec2 c = at(f, length * 0.5f, side * (road + 3.4f + depth));
      const Vec2 half(length * 0.5f, depth);
      if (!site.occ.free(c, half, yaw, Occupancy::kRoad, 0.1f)) return 1.0;
      site.occ.take(c, half, yaw);
      WorldObject& o = site.new_object(ObjectClass::Tree, c, half, yaw, height);
      add_box(o, c, o.base, Vec3(half.x(), half.y(), height * 0.5f), yaw, Material::Vegetation);
      return static_cast<double>(length);
    }
    // A bush or two in the garden.
    const Vec2 c = at(f, 1.0f, side * (road + site.uniform(3.6f, 6.0f)));
    const float r = site.uniform(0.5f, 1.2f);
    if (!site.occ.free(c, Vec2(r, r), 0.f, Occupancy::kRoad, 0.1f)) return 1.0;
    site.occ.take(c, Vec2(r, r), 0.f);
    WorldObject& o = site.new_object(ObjectClass::Tree, c, Vec2(r, r), 0.f, 1.6f * r);
    o.shapes.push_back(make_ellipsoid(Vec3(c.x(), c.y(), o.base + 0.75f * r), Vec3(r, r * site.uniform(0.7f, 1.0f), 0.8f * r),
                                      site.uniform(0.f, 3.14f), 0));
    o.materials.push_back(Material::Vegetation);
    return 2.0 * r;
  });
  site.walk(4.0, 12.0, [&](const Frame& f, float side, double) {  // back gardens: trees behind the first row
    const Vec2 c = at(f, 0.f, side * (road + site.uniform(14.f, 30.f)));
    if (!site.occ.free(c, Vec2(0.4f, 0.4f), 0.f, Occupancy::kRoad, 0.2f)) return 2.0;
    site.occ.take(c, Vec2(0.4f, 0.4f), 0.f);
    tree(site, c, site.uniform(1.0f, 1.5f));
    return 4.0;
  });
}

}  // namespace pl::sim::worldgen
