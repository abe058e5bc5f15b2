// The world's shapes: their constructors, bounds and the test of one shape against a ray (the tests
// themselves are in shape_hits.hpp, shared with the BVH in bvh.cpp).
#include "pl/sim/raycast.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "shape_hits.hpp"

namespace pl::sim {

using namespace raycast_detail;

namespace {

struct FreePrepared {  // same layout as Bvh::Prepared, for the free intersect()
  float v[9];
  std::uint32_t shape;
};

}  // namespace

Primitive make_box(const Eigen::Vector3f& centre, const Eigen::Vector3f& half_extents, float yaw, std::uint32_t object) {
  Primitive p;
  p.shape = Shape::Box;
  p.object = object;
  p.a = centre;
  p.b = half_extents;
  p.yaw = yaw;
  return p;
}

Primitive make_cylinder(const Eigen::Vector3f& bottom_centre, float radius, float height, std::uint32_t object) {
  Primitive p;
  p.shape = Shape::Cylinder;
  p.object = object;
  p.a = bottom_centre;
  p.b = Eigen::Vector3f(radius, 0.0f, height);
  return p;
}

Primitive make_ellipsoid(const Eigen::Vector3f& centre, const Eigen::Vector3f& radii, float yaw, std::uint32_t object) {
  Primitive p;
  p.shape = Shape::Ellipsoid;
  p.object = object;
  p.a = centre;
  p.b = radii;
  p.yaw = yaw;
  return p;
}

Primitive make_triangle(const Eigen::Vector3f& a, const Eigen::Vector3f& b, const Eigen::Vector3f& c, std::uint32_t object) {
  Primitive p;
  p.shape = Shape::Triangle;
  p.object = object;
  p.a = a;
  p.b = b;
  p.c = c;
  return p;
}

Aabb bounds_of(const Primitive& p) {
  Aabb box;
  switch (p.shape) {
    case Shape::Box: {
      const float c = std::abs(std::cos(p.yaw)), s = std::abs(std::sin(p.yaw));
      const Eigen::Vector3f h = p.b.cwiseAbs();
      const Eigen::Vector3f e(c * h.x() + s * h.y(), s * h.x() + c * h.y(), h.z());
      box.min = p.a - e;
      box.max = p.a + e;
      break;
    }
    case Shape::Cylinder: {
      const float r = std::abs(p.b.x());
      const float z0 = p.a.z(), z1 = p.a.z() + p.b.z();
      box.min = Eigen::Vector3f(p.a.x() - r, p.a.y() - r, std::min(z0, z1));
      box.max = Eigen::Vector3f(p.a.x() + r, p.a.y() + r, std::max(z0, z1));
      break;
    }
    case Shape::Ellipsoid: {
      // The yawed ellipse's extent along x is sqrt((rx cos)^2 + (ry sin)^2), along y likewise.
      const float c = std::cos(p.yaw), s = std::sin(p.yaw);
      const float rx = p.b.x(), ry = p.b.y();
      const Eigen::Vector3f e(std::sqrt(rx * rx * c * c + ry * ry * s * s), std::sqrt(rx * rx * s * s + ry * ry * c * c),
                              std::abs(p.b.z()));
      box.min = p.a - e;
      box.max = p.a + e;
      break;
    }
    case Shape::Triangle:
      box.min = p.a.cwiseMin(p.b).cwiseMin(p.c);
      box.max = p.a.cwiseMax(p.b).cwiseMax(p.c);
      break;
  }
  return box;
}

bool intersect(const Primitive& p, const Ray& ray, Hit& hit) {
  const FreePrepared q = prepare<FreePrepared>(p);
  const RayData r = ray_data(ray);
  float t = 0.0f;
  int part = 2;
  if (!hit_prepared(q, r, ray.t_max, t, part)) return false;
  hit.t = t;
  hit.normal = normal_at(q, r, t, part);
  return true;
}

}  // namespace pl::sim
