// Ray casting for the simulator: the world's shapes and a bounding-volume hierarchy over them.
// Coordinates are float32 metres in the simulation's local ENU frame (a few kilometres at most).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <vector>

namespace pl::sim {

enum class Shape : std::uint8_t {
  Box,        // centre a, half extents b, rotated by `yaw` about the vertical axis
  Cylinder,   // vertical: bottom centre a, b.x() = radius, b.z() = height (b.y() unused)
  Ellipsoid,  // centre a, radii b (before the yaw), rotated by `yaw` about the vertical axis
  Triangle,   // vertices a, b, c
};

struct Primitive {
  Shape shape = Shape::Box;
  std::uint32_t object = 0;  // the world object this shape belongs to (material, class, id)
  Eigen::Vector3f a = Eigen::Vector3f::Zero();
  Eigen::Vector3f b = Eigen::Vector3f::Zero();
  Eigen::Vector3f c = Eigen::Vector3f::Zero();
  float yaw = 0.0f;
};

Primitive make_box(const Eigen::Vector3f& centre, const Eigen::Vector3f& half_extents, float yaw, std::uint32_t object);
Primitive make_cylinder(const Eigen::Vector3f& bottom_centre, float radius, float height, std::uint32_t object);
Primitive make_ellipsoid(const Eigen::Vector3f& centre, const Eigen::Vector3f& radii, float yaw, std::uint32_t object);
Primitive make_triangle(const Eigen::Vector3f& a, const Eigen::Vector3f& b, const Eigen::Vector3f& c, std::uint32_t object);

struct Aabb {
  Eigen::Vector3f min = Eigen::Vector3f::Constant(INFINITY);
  Eigen::Vector3f max = Eigen::Vector3f::Constant(-INFINITY);
};
Aabb bounds_of(const Primitive& p);

struct Ray {
  Eigen::Vector3f origin;
  Eigen::Vector3f dir;  // unit length
  float t_max = INFINITY;
};

struct Hit {
  float t = INFINITY;                            // distance along the ray
  Eigen::Vector3f normal = Eigen::Vector3f::Zero();  // unit, facing the ray's origin
  std::uint32_t primitive = 0;                   // index into Bvh::primitives()
};

// Closest intersection of one primitive with t in (0, ray.t_max); false when none. Hits closer
// than 1e-5 m are ignored (self-intersection guard). Writes hit.t and hit.normal, not hit.primitive.
bool intersect(const Primitive& p, const Ray& ray, Hit& hit);

// A bounding-volume hierarchy built once over a set of primitives (binned SAH), answering
// closest-hit queries. Thread-safe for concurrent queries after build.
class Bvh {
 public:
  Bvh() = default;
  explicit Bvh(std::vector<Primitive> primitives);
  bool intersect(const Ray& ray, Hit& hit) const;  // closest hit with t in (0, ray.t_max)
  const std::vector<Primitive>& primitives() const { return prims_; }
  std::size_t node_count() const { return nodes_.size(); }
  bool empty() const { return prims_.empty(); }

 private:
  struct Node {
    Eigen::Vector3f min, max;
    std::uint32_t first;  // leaf: first primitive; inner: index of the right child (left is next)
    std::uint32_t count;  // primitives in a leaf, 0 for an inner node
  };
  // A primitive in the form the hot loop wants (yaw as cos/sin, inverse radii, triangle edges),
  // in the same order as prims_. Layout per shape is private to shape_hits.hpp.
  struct Prepared {
    float v[9];
    std::uint32_t shape;
  };
  std::vector<Primitive> prims_;
  std::vector<Prepared> prep_;
  std::vector<Node> nodes_;
};

}  // namespace pl::sim
