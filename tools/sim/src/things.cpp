// Single things and their shapes: parked vehicles, containers, trees, poles and signs.
#include "things.hpp"

#include <cmath>

namespace pl::sim::worldgen {

namespace {

void vehicle_shapes(WorldObject& o, bool truck) {
  Vec2 fwd(std::cos(o.yaw), std::sin(o.yaw));
  if (truck) {
    // Cab at the front, box body behind.
    add_box(o, o.centre + fwd * 3.9f, o.base + 0.4f, Vec3(1.1f, 1.2f, 1.35f), o.yaw, Material::Metal);
    add_box(o, o.centre - fwd * 1.0f, o.base + 0.9f, Vec3(3.9f, 1.25f, 1.45f), o.yaw, Material::Metal);
  } else {
    add_box(o, o.centre, o.base + 0.25f, Vec3(o.half.x(), o.half.y(), 0.38f), o.yaw, Material::Metal);
    add_box(o, o.centre - fwd * 0.25f, o.base + 1.01f, Vec3(o.half.x() * 0.55f, o.half.y() * 0.9f, 0.24f), o.yaw,
            Material::Glass);
  }
}

}  // namespace

bool parked_vehicle(Site& site, const Frame& f, float side, float along, bool truck) {
  float road = static_cast<float>(site.cfg.road_half_width);
  Vec2 half = truck ? Vec2(5.0f, 1.25f) : Vec2(site.uniform(2.1f, 2.45f), site.uniform(0.86f, 0.95f));
  // Cars stand in the parking lane; trucks, 2.5 m wide, half up on the pavement.
  Vec2 c = at(f, along + half.x(), side * (truck ? road - half.y() + 1.0f : road - half.y() - 0.2f));
  float yaw = yaw_of(f) + (site.chance(0.5f) ? 0.0f : static_cast<float>(M_PI));
  if (!site.occ.free(c, half, yaw, Occupancy::kLane, 0.0f)) return false;
  site.occ.take(c, half, yaw);
  ObjectClass cls = truck ? ObjectClass::ParkedTruck : ObjectClass::ParkedCar;
  WorldObject& o = site.new_object(cls, c, half, yaw, truck ? 3.8f : 1.5f);
  vehicle_shapes(o, truck);
  return true;
}

void container(Site& site, Vec2 c, float yaw, float base_lift, bool forty) {
  Vec2 half = forty ? Vec2(6.1f, 1.22f) : Vec2(3.03f, 1.22f);
  WorldObject& o = site.new_object(ObjectClass::Container, c, half, yaw, 2.6f + base_lift);
  add_box(o, c, o.base + base_lift, Vec3(half.x(), half.y(), 1.3f), yaw, Material::Metal);
}

void tree(Site& site, Vec2 c, float scale) {
  float trunk = site.uniform(2.0f, 3.2f) * scale, canopy = site.uniform(1.8f, 3.2f) * scale;
  WorldObject& o = site.new_object(ObjectClass::Tree, c, Vec2(canopy, canopy), 0.f, trunk + 2 * canopy);
  o.shapes.push_back(make_cylinder(Vec3(c.x(), c.y(), o.base), site.uniform(0.12f, 0.28f), trunk + canopy * 0.5f, 0));
  o.materials.push_back(Material::Vegetation);
  // An irregular canopy: a main ellipsoid and a few lobes.
  int lobes = 2 + static_cast<int>(site.uniform(0.f, 2.99f));
  o.shapes.push_back(make_ellipsoid(Vec3(c.x(), c.y(), o.base + trunk + canopy),
                                    Vec3(canopy, canopy * site.uniform(0.8f, 1.0f), canopy * 0.85f), site.uniform(0.f, 3.14f),
                                    0));
  o.materials.push_back(Material::Vegetation);
  for (int k = 0; k < lobes; ++k) {
    float a = site.uniform(0.f, 6.28f), r = canopy * site.uniform(0.4f, 0.7f);
    Vec3 lc(c.x() + std::cos(a) * r, c.y() + std::sin(a) * r, o.base + trunk + canopy * site.uniform(0.7f, 1.3f));
    o.shapes.push_back(make_ellipsoid(lc, Vec3::Constant(canopy * site.uniform(0.45f, 0.65f)), 0.f, 0));
    o.materials.push_back(Material::Vegetation);
  }
}

void pole(Site& site, Vec2 c, bool with_sign, float yaw) {
  float h = with_sign ? 2.6f : site.uniform(5.0f, 8.0f);
  ObjectClass cls = with_sign ? ObjectClass::Sign : ObjectClass::Pole;
  WorldObject& o = site.new_object(cls, c, Vec2(0.3f, 0.3f), yaw, h + (with_sign ? 0.7f : 0.f));
  o.shapes.push_back(make_cylinder(Vec3(c.x(), c.y(), o.base), with_sign ? 0.04f : site.uniform(0.07f, 0.14f), h, 0));
  o.materials.push_back(Material::Metal);
  if (with_sign) {
    add_box(o, c, o.base + h, Vec3(0.03f, 0.32f, 0.32f), yaw, Material::Retroreflector);
  } else if (site.chance(0.6f)) {  // a lamp arm reaching over the pavement
    Vec2 arm(std::cos(yaw) * 0.8f, std::sin(yaw) * 0.8f);
    add_box(o, c + arm, o.base + h - 0.1f, Vec3(0.8f, 0.06f, 0.06f), yaw, Material::Metal);
  }
}

}  // namespace pl::sim::worldgen
