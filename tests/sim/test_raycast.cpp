#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <random>
#include <thread>
#include <vector>

#include "pl/sim/raycast.hpp"

namespace {

using pl::sim::Aabb;
using pl::sim::Bvh;
using pl::sim::Hit;
using pl::sim::Primitive;
using pl::sim::Ray;
using pl::sim::Shape;
using Eigen::Vector3f;

constexpr float kPi = 3.14159265358979f;

Ray make_ray(const Vector3f& origin, const Vector3f& dir, float t_max = INFINITY) {
  Ray r;
  r.origin = origin;
  r.dir = dir.normalized();
  r.t_max = t_max;
  return r;
}

// Hit with t and normal checked; the normal must be unit and face the origin.
void expect_hit(const Primitive& p, const Ray& r, float t, const Vector3f& normal, float tol = 1e-5f) {
  Hit h;
  ASSERT_TRUE(pl::sim::intersect(p, r, h)) << "expected a hit at t=" << t;
  EXPECT_NEAR(h.t, t, tol);
  EXPECT_NEAR(h.normal.norm(), 1.0f, 1e-5f);
  EXPECT_LE(h.normal.dot(r.dir), 0.0f);
  EXPECT_TRUE(h.normal.isApprox(normal, 1e-4f)) << "normal " << h.normal.transpose() << " expected " << normal.transpose();
}

void expect_miss(const Primitive& p, const Ray& r) {
  Hit h;
  EXPECT_FALSE(pl::sim::intersect(p, r, h)) << "unexpected hit at t=" << h.t;
}

bool inside(const Aabb& b, const Vector3f& p, float tol) {
  return (p.array() >= b.min.array() - tol).all() && (p.array() <= b.max.array() + tol).all();
}

// Closest hit by testing every primitive; same tie rule as the BVH (strictly closer wins). A
// generously padded bounding-box test in double precision (independent of the BVH's) skips most
// primitives, only to keep the sanitizer build fast.
class BruteForce {
 public:
  explicit BruteForce(const std::vector<Primitive>& prims) : prims_(prims) {
    for (const auto& p : prims) {
      const Aabb b = pl::sim::bounds_of(p);
      std::array<double, 6> box{};
      for (int k = 0; k < 3; ++k) box[k] = b.min[k] - 1e-3, box[k + 3] = b.max[k] + 1e-3;
      boxes_.push_back(box);
    }
  }

  bool intersect(const Ray& ray, Hit& hit) const {
    Ray r = ray;
    const double o[3] = {r.origin.x(), r.origin.y(), r.origin.z()}, d[3] = {r.dir.x(), r.dir.y(), r.dir.z()};
    bool found = false;
    for (std::size_t i = 0; i < prims_.size(); ++i) {
      if (!may_hit(boxes_[i], o, d, r.t_max)) continue;
      Hit h;
      if (pl::sim::intersect(prims_[i], r, h)) {
        hit = h;
        hit.primitive = static_cast<std::uint32_t>(i);
        r.t_max = h.t;
        found = true;
      }
    }
    return found;
  }

 private:
  static bool may_hit(const std::array<double, 6>& box, const double* o, const double* d, float t_max) {
    double lo = 0.0, hi = static_cast<double>(t_max) + 1e-3;
    for (int k = 0; k < 3; ++k) {
      if (d[k] == 0.0) {
        if (o[k] < box[k] || o[k] > box[k + 3]) return false;
        continue;
      }
      double a = (box[k] - o[k]) / d[k], b = (box[k + 3] - o[k]) / d[k];
      if (a > b) std::swap(a, b);
      if (a > lo) lo = a;
      if (b < hi) hi = b;
    }
    return lo <= hi;
  }

  const std::vector<Primitive>& prims_;
  std::vector<std::array<double, 6>> boxes_;
};

Vector3f rand_unit(std::mt19937& rng) {
  std::normal_distribution<float> g(0.0f, 1.0f);
  Vector3f v;
  do v = Vector3f(g(rng), g(rng), g(rng));
  while (v.norm() < 1e-3f);
  return v.normalized();
}

std::vector<Primitive> random_scene(std::size_t n, float extent, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> pos(-extent, extent), size(0.1f, 3.0f), yaw(-kPi, kPi), u01(0.0f, 1.0f);
  std::vector<Primitive> prims;
  prims.reserve(n);
  for (std::size_t i = 0; i < n; ++i) {
    const Vector3f c(pos(rng), pos(rng), 0.2f * pos(rng));
    const auto object = static_cast<std::uint32_t>(i);
    const float ty = u01(rng);
    if (ty < 0.3f) {
      prims.push_back(pl::sim::make_box(c, Vector3f(size(rng), size(rng), size(rng)), u01(rng) < 0.3f ? 0.0f : yaw(rng), object));
    } else if (ty < 0.5f) {
      prims.push_back(pl::sim::make_cylinder(c, 0.5f * size(rng), 2.0f * size(rng), object));
    } else if (ty < 0.7f) {
      prims.push_back(pl::sim::make_ellipsoid(c, Vector3f(size(rng), size(rng), size(rng)), yaw(rng), object));
    } else {
      const float s = size(rng);
      prims.push_back(pl::sim::make_triangle(c, c + s * rand_unit(rng), c + s * rand_unit(rng), object));
    }
  }
  return prims;
}

// Random rays; about a third have one or two zero direction components.
std::vector<Ray> random_rays(std::size_t n, float extent, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> pos(-extent, extent), u01(0.0f, 1.0f);
  std::vector<Ray> rays(n);
  for (auto& r : rays) {
    r.origin = Vector3f(pos(rng), pos(rng), 0.3f * pos(rng));
    Vector3f d = rand_unit(rng);
    const float k = u01(rng);
    if (k < 0.15f) {
      d[static_cast<int>(rng() % 3)] = 0.0f;
    } else if (k < 0.3f) {
      const int keep = static_cast<int>(rng() % 3);
      for (int j = 0; j < 3; ++j)
        if (j != keep) d[j] = 0.0f;
    }
    r.dir = d.normalized();
    r.t_max = u01(rng) < 0.5f ? INFINITY : 5.0f + 100.0f * u01(rng);
  }
  return rays;
}

void compare_with_brute_force(const std::vector<Primitive>& input, const std::vector<Ray>& rays) {
  const Bvh bvh(input);
  const auto& prims = bvh.primitives();
  ASSERT_EQ(prims.size(), input.size());
  const BruteForce brute_force(prims);
  std::size_t hits = 0, failures = 0;
  for (const Ray& r : rays) {
    Hit hb, hr;
    const bool b = bvh.intersect(r, hb);
    const bool f = brute_force.intersect(r, hr);
    if (b != f) {
      ADD_FAILURE() << "hit mismatch: bvh " << b << " brute force " << f << " (t " << hr.t << ") origin " << r.origin.transpose()
                    << " dir " << r.dir.transpose();
      if (++failures > 10) return;
      continue;
    }
    if (!b) continue;
    ++hits;
    EXPECT_NEAR(hb.t, hr.t, 1e-4f);
    ASSERT_LT(hb.primitive, prims.size());
    if (hb.primitive != hr.primitive) {
      // A tie: the BVH's primitive must itself be hit at (nearly) the same distance.
      Hit h;
      ASSERT_TRUE(pl::sim::intersect(prims[hb.primitive], r, h));
      EXPECT_NEAR(h.t, hr.t, 1e-4f);
    } else {
      EXPECT_EQ(hb.t, hr.t);
      EXPECT_TRUE(hb.normal.isApprox(hr.normal, 1e-5f));
    }
    EXPECT_LE(hb.normal.dot(r.dir), 0.0f);
    if (::testing::Test::HasFailure() && ++failures > 10) return;
  }
  EXPECT_GT(hits, rays.size() / 20) << "scene too sparse to be a useful test";
}

}  // namespace

TEST(Raycast, MakersFillPrimitive) {
  const Primitive b = pl::sim::make_box(Vector3f(1, 2, 3), Vector3f(4, 5, 6), 0.5f, 7);
  EXPECT_EQ(b.shape, Shape::Box);
  EXPECT_EQ(b.object, 7u);
  EXPECT_EQ(b.a, Vector3f(1, 2, 3));
  EXPECT_EQ(b.b, Vector3f(4, 5, 6));
  EXPECT_EQ(b.yaw, 0.5f);
  const Primitive c = pl::sim::make_cylinder(Vector3f(1, 2, 3), 0.5f, 4.0f, 8);
  EXPECT_EQ(c.shape, Shape::Cylinder);
  EXPECT_EQ(c.b.x(), 0.5f);
  EXPECT_EQ(c.b.z(), 4.0f);
  const Primitive e = pl::sim::make_ellipsoid(Vector3f(1, 2, 3), Vector3f(3, 2, 1), -0.25f, 9);
  EXPECT_EQ(e.shape, Shape::Ellipsoid);
  EXPECT_EQ(e.b, Vector3f(3, 2, 1));
  EXPECT_EQ(e.yaw, -0.25f);
  const Primitive t = pl::sim::make_triangle(Vector3f(0, 0, 0), Vector3f(1, 0, 0), Vector3f(0, 1, 0), 10);
  EXPECT_EQ(t.shape, Shape::Triangle);
  EXPECT_EQ(t.c, Vector3f(0, 1, 0));
  EXPECT_EQ(t.object, 10u);
}

TEST(Raycast, AxisAlignedBox) {
  const Primitive box = pl::sim::make_box(Vector3f(10, 0, 0), Vector3f(1, 2, 3), 0.0f, 0);
  expect_hit(box, make_ray(Vector3f(0, 0, 0), Vector3f(1, 0, 0)), 9.0f, Vector3f(-1, 0, 0));
  expect_hit(box, make_ray(Vector3f(20, 1, 1), Vector3f(-1, 0, 0)), 9.0f, Vector3f(1, 0, 0));
  expect_hit(box, make_ray(Vector3f(10, 10, 0), Vector3f(0, -1, 0)), 8.0f, Vector3f(0, 1, 0));
  expect_hit(box, make_ray(Vector3f(10.5f, -1, 10), Vector3f(0, 0, -1)), 7.0f, Vector3f(0, 0, 1));
  expect_hit(box, make_ray(Vector3f(10, 0, -5), Vector3f(0, 0, 1)), 2.0f, Vector3f(0, 0, -1));
  // Diagonal: from (0, -9, 0) towards (9, 0, 0) enters the -x face at (9, 0, 0): t = 9 * sqrt(2).
  expect_hit(box, make_ray(Vector3f(0, -9, 0), Vector3f(1, 1, 0)), 9.0f * std::sqrt(2.0f), Vector3f(-1, 0, 0));
  expect_miss(box, make_ray(Vector3f(0, 0, 0), Vector3f(-1, 0, 0)));
  expect_miss(box, make_ray(Vector3f(0, 2.01f, 0), Vector3f(1, 0, 0)));
  expect_miss(box, make_ray(Vector3f(0, 0, 3.01f), Vector3f(1, 0, 0)));
}

TEST(Raycast, YawedBox) {
  // Yawed 90 degrees: the local x half extent (2) lies along world y.
  const Primitive box90 = pl::sim::make_box(Vector3f(10, 0, 0), Vector3f(2, 1, 1), kPi / 2, 0);
  expect_hit(box90, make_ray(Vector3f(0, 0, 0), Vector3f(1, 0, 0)), 9.0f, Vector3f(-1, 0, 0));
  expect_hit(box90, make_ray(Vector3f(0, 1.9f, 0), Vector3f(1, 0, 0)), 9.0f, Vector3f(-1, 0, 0));
  expect_hit(box90, make_ray(Vector3f(10, 10, 0), Vector3f(0, -1, 0)), 8.0f, Vector3f(0, 1, 0));
  expect_miss(box90, make_ray(Vector3f(0, 2.1f, 0), Vector3f(1, 0, 0)));
  // Yawed 45 degrees, unit cube: the face with outward normal (-1, 1, 0)/sqrt(2) is the line
  // x = 10 + y - sqrt(2); a ray along +x at y = 0.3 meets it at x = 10.3 - sqrt(2).
  const Primitive box45 = pl::sim::make_box(Vector3f(10, 0, 0), Vector3f(1, 1, 1), kPi / 4, 0);
  const float r2 = std::sqrt(2.0f);
  expect_hit(box45, make_ray(Vector3f(0, 0.3f, 0), Vector3f(1, 0, 0)), 10.3f - r2, Vector3f(-1, 1, 0).normalized());
  expect_hit(box45, make_ray(Vector3f(0, -0.3f, 0), Vector3f(1, 0, 0)), 10.3f - r2, Vector3f(-1, -1, 0).normalized());
  expect_hit(box45, make_ray(Vector3f(10, 0, 5), Vector3f(0, 0, -1)), 4.0f, Vector3f(0, 0, 1));
  expect_miss(box45, make_ray(Vector3f(0, r2 + 0.01f, 0), Vector3f(1, 0, 0)));
}

TEST(Raycast, RayAlongBoxEdgeAndFace) {
  const Primitive box = pl::sim::make_box(Vector3f(0, 0, 0), Vector3f(1, 1, 1), 0.0f, 0);
  // Along the edge y = 1, z = 1: the closed box is touched, first at the -x face.
  expect_hit(box, make_ray(Vector3f(-5, 1, 1), Vector3f(1, 0, 0)), 4.0f, Vector3f(-1, 0, 0));
  expect_hit(box, make_ray(Vector3f(-5, -1, 1), Vector3f(1, 0, 0)), 4.0f, Vector3f(-1, 0, 0));
  // Lying in the face y = 1.
  expect_hit(box, make_ray(Vector3f(-5, 1, 0.5f), Vector3f(1, 0, 0)), 4.0f, Vector3f(-1, 0, 0));
  expect_miss(box, make_ray(Vector3f(-5, 1.0001f, 1), Vector3f(1, 0, 0)));
  expect_miss(box, make_ray(Vector3f(-5, 1, 1.0001f), Vector3f(1, 0, 0)));
}

TEST(Raycast, RayStartingInsideHitsTheExit) {
  const Primitive box = pl::sim::make_box(Vector3f(0, 0, 0), Vector3f(1, 2, 3), 0.0f, 0);
  expect_hit(box, make_ray(Vector3f(0, 0, 0), Vector3f(0, 1, 0)), 2.0f, Vector3f(0, -1, 0));
  expect_hit(box, make_ray(Vector3f(0.5f, 0, 0), Vector3f(-1, 0, 0)), 1.5f, Vector3f(1, 0, 0));
  expect_hit(box, make_ray(Vector3f(0, 0, 0), Vector3f(0, 0, -1)), 3.0f, Vector3f(0, 0, 1));
  const Primitive yawed = pl::sim::make_box(Vector3f(5, 5, 0), Vector3f(2, 1, 1), kPi / 2, 0);
  expect_hit(yawed, make_ray(Vector3f(5, 5, 0), Vector3f(0, 1, 0)), 2.0f, Vector3f(0, -1, 0));
  const Primitive cyl = pl::sim::make_cylinder(Vector3f(5, 0, 0), 1.0f, 4.0f, 0);
  expect_hit(cyl, make_ray(Vector3f(5, 0, 2), Vector3f(1, 0, 0)), 1.0f, Vector3f(-1, 0, 0));
  expect_hit(cyl, make_ray(Vector3f(5, 0, 1), Vector3f(0, 0, 1)), 3.0f, Vector3f(0, 0, -1));
  expect_hit(cyl, make_ray(Vector3f(5, 0, 1), Vector3f(0, 0, -1)), 1.0f, Vector3f(0, 0, 1));
  const Primitive ell = pl::sim::make_ellipsoid(Vector3f(0, 0, 0), Vector3f(3, 2, 1), 0.0f, 0);
  expect_hit(ell, make_ray(Vector3f(0, 0, 0), Vector3f(1, 0, 0)), 3.0f, Vector3f(-1, 0, 0));
  expect_hit(ell, make_ray(Vector3f(0, 0, 0), Vector3f(0, -1, 0)), 2.0f, Vector3f(0, 1, 0));
  expect_hit(ell, make_ray(Vector3f(0, 0, 0), Vector3f(0, 0, 1)), 1.0f, Vector3f(0, 0, -1));
}

TEST(Raycast, Cylinder) {
  const Primitive cyl = pl::sim::make_cylinder(Vector3f(5, 0, 0), 1.0f, 4.0f, 0);
  expect_hit(cyl, make_ray(Vector3f(0, 0, 2), Vector3f(1, 0, 0)), 4.0f, Vector3f(-1, 0, 0));
  expect_hit(cyl, make_ray(Vector3f(5, -10, 3), Vector3f(0, 1, 0)), 9.0f, Vector3f(0, -1, 0));
  // Off-centre: the ray y = 0.6 meets the circle at x = 5 - 0.8.
  expect_hit(cyl, make_ray(Vector3f(0, 0.6f, 1), Vector3f(1, 0, 0)), 4.2f, Vector3f(-0.8f, 0.6f, 0));
  expect_hit(cyl, make_ray(Vector3f(5, 0, 10), Vector3f(0, 0, -1)), 6.0f, Vector3f(0, 0, 1));  // top cap
  expect_hit(cyl, make_ray(Vector3f(5.5f, 0.5f, -3), Vector3f(0, 0, 1)), 3.0f, Vector3f(0, 0, -1));  // bottom cap
  // Down at 45 degrees from (0, 0, 9): reaches z = 4 at x = 5, the top cap's centre.
  expect_hit(cyl, make_ray(Vector3f(0, 0, 9), Vector3f(1, 0, -1)), 5.0f * std::sqrt(2.0f), Vector3f(0, 0, 1));
  expect_miss(cyl, make_ray(Vector3f(0, 0, 4.5f), Vector3f(1, 0, 0)));
  expect_miss(cyl, make_ray(Vector3f(0, 1.01f, 2), Vector3f(1, 0, 0)));
  expect_miss(cyl, make_ray(Vector3f(6.01f, 0, 10), Vector3f(0, 0, -1)));
  expect_miss(cyl, make_ray(Vector3f(0, 0, 2), Vector3f(-1, 0, 0)));
  // A negative height hangs down from the given centre: the same solid.
  const Primitive hanging = pl::sim::make_cylinder(Vector3f(5, 0, 4), 1.0f, -4.0f, 0);
  expect_hit(hanging, make_ray(Vector3f(0, 0, 2), Vector3f(1, 0, 0)), 4.0f, Vector3f(-1, 0, 0));
  expect_hit(hanging, make_ray(Vector3f(5, 0, 10), Vector3f(0, 0, -1)), 6.0f, Vector3f(0, 0, 1));
  EXPECT_EQ(pl::sim::bounds_of(hanging).min, pl::sim::bounds_of(cyl).min);
  EXPECT_EQ(pl::sim::bounds_of(hanging).max, pl::sim::bounds_of(cyl).max);
}

TEST(Raycast, EllipsoidAlongEachAxis) {
  const Vector3f c(1, 2, 3);
  const Primitive ell = pl::sim::make_ellipsoid(c, Vector3f(3, 2, 1), 0.0f, 0);
  expect_hit(ell, make_ray(c + Vector3f(10, 0, 0), Vector3f(-1, 0, 0)), 7.0f, Vector3f(1, 0, 0));
  expect_hit(ell, make_ray(c - Vector3f(10, 0, 0), Vector3f(1, 0, 0)), 7.0f, Vector3f(-1, 0, 0));
  expect_hit(ell, make_ray(c + Vector3f(0, 10, 0), Vector3f(0, -1, 0)), 8.0f, Vector3f(0, 1, 0));
  expect_hit(ell, make_ray(c - Vector3f(0, 10, 0), Vector3f(0, 1, 0)), 8.0f, Vector3f(0, -1, 0));
  expect_hit(ell, make_ray(c + Vector3f(0, 0, 10), Vector3f(0, 0, -1)), 9.0f, Vector3f(0, 0, 1));
  expect_hit(ell, make_ray(c - Vector3f(0, 0, 10), Vector3f(0, 0, 1)), 9.0f, Vector3f(0, 0, -1));
  // Yawed 90 degrees: the 3 m radius lies along world y.
  const Primitive yawed = pl::sim::make_ellipsoid(c, Vector3f(3, 2, 1), kPi / 2, 0);
  expect_hit(yawed, make_ray(c + Vector3f(10, 0, 0), Vector3f(-1, 0, 0)), 8.0f, Vector3f(1, 0, 0));
  expect_hit(yawed, make_ray(c + Vector3f(0, 10, 0), Vector3f(0, -1, 0)), 7.0f, Vector3f(0, 1, 0));
  // Sphere of radius 2, ray at height 1: enters at x = -sqrt(3), normal (-sqrt(3)/2, 1/2, 0).
  const Primitive sphere = pl::sim::make_ellipsoid(Vector3f(0, 0, 0), Vector3f(2, 2, 2), 0.3f, 0);
  expect_hit(sphere, make_ray(Vector3f(-10, 1, 0), Vector3f(1, 0, 0)), 10.0f - std::sqrt(3.0f),
             Vector3f(-std::sqrt(3.0f) / 2, 0.5f, 0));
  expect_miss(sphere, make_ray(Vector3f(-10, 2.01f, 0), Vector3f(1, 0, 0)));
  expect_miss(ell, make_ray(c + Vector3f(10, 0, 0), Vector3f(1, 0, 0)));
}

TEST(Raycast, TriangleBothSidesAndEdges) {
  const Primitive tri = pl::sim::make_triangle(Vector3f(0, 0, 5), Vector3f(1, 0, 5), Vector3f(0, 1, 5), 0);
  expect_hit(tri, make_ray(Vector3f(0.2f, 0.2f, 0), Vector3f(0, 0, 1)), 5.0f, Vector3f(0, 0, -1));
  expect_hit(tri, make_ray(Vector3f(0.2f, 0.2f, 10), Vector3f(0, 0, -1)), 5.0f, Vector3f(0, 0, 1));
  // Slanted: from (0.25, 0.25 - 5, 0) along (0, 1, 1) reaches z = 5 at y = 0.25.
  expect_hit(tri, make_ray(Vector3f(0.25f, -4.75f, 0), Vector3f(0, 1, 1)), 5.0f * std::sqrt(2.0f), Vector3f(0, 0, -1));
  expect_hit(tri, make_ray(Vector3f(0.49f, 0.49f, 0), Vector3f(0, 0, 1)), 5.0f, Vector3f(0, 0, -1));
  expect_miss(tri, make_ray(Vector3f(0.501f, 0.501f, 0), Vector3f(0, 0, 1)));  // just past the hypotenuse
  expect_miss(tri, make_ray(Vector3f(-0.001f, 0.5f, 0), Vector3f(0, 0, 1)));   // just past x = 0
  expect_miss(tri, make_ray(Vector3f(0.5f, -0.001f, 10), Vector3f(0, 0, -1)));  // just past y = 0
  expect_miss(tri, make_ray(Vector3f(0.2f, 0.2f, 0), Vector3f(0, 0, -1)));     // pointing away
  expect_miss(tri, make_ray(Vector3f(-1, 0.2f, 5), Vector3f(1, 0, 0)));        // in the plane
}

TEST(Raycast, TMaxCutsOff) {
  const Primitive box = pl::sim::make_box(Vector3f(10, 0, 0), Vector3f(1, 1, 1), 0.0f, 0);
  expect_miss(box, make_ray(Vector3f(0, 0, 0), Vector3f(1, 0, 0), 8.9f));
  expect_hit(box, make_ray(Vector3f(0, 0, 0), Vector3f(1, 0, 0), 9.1f), 9.0f, Vector3f(-1, 0, 0));
  const Primitive tri = pl::sim::make_triangle(Vector3f(-1, -1, 5), Vector3f(1, -1, 5), Vector3f(0, 1, 5), 0);
  expect_miss(tri, make_ray(Vector3f(0, 0, 0), Vector3f(0, 0, 1), 4.99f));
  const Primitive cyl = pl::sim::make_cylinder(Vector3f(5, 0, 0), 1.0f, 4.0f, 0);
  expect_miss(cyl, make_ray(Vector3f(0, 0, 2), Vector3f(1, 0, 0), 3.9f));
  const Primitive ell = pl::sim::make_ellipsoid(Vector3f(0, 0, 0), Vector3f(1, 1, 1), 0.0f, 0);
  expect_miss(ell, make_ray(Vector3f(-5, 0, 0), Vector3f(1, 0, 0), 3.9f));
  // Inside, the exit beyond t_max is no hit either.
  expect_miss(box, make_ray(Vector3f(10, 0, 0), Vector3f(1, 0, 0), 0.9f));

  Bvh bvh({box, pl::sim::make_box(Vector3f(20, 0, 0), Vector3f(1, 1, 1), 0.0f, 1)});
  Hit h;
  EXPECT_FALSE(bvh.intersect(make_ray(Vector3f(0, 0, 0), Vector3f(1, 0, 0), 8.9f), h));
  ASSERT_TRUE(bvh.intersect(make_ray(Vector3f(12, 0, 0), Vector3f(1, 0, 0), 7.1f), h));
  EXPECT_NEAR(h.t, 7.0f, 1e-5f);
  EXPECT_EQ(bvh.primitives()[h.primitive].object, 1u);
}

TEST(Raycast, BoundsContainSurfacePoints) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> pos(-500.0f, 500.0f), size(0.1f, 10.0f), yaw(-2 * kPi, 2 * kPi), u(-1.0f, 1.0f);
  for (int trial = 0; trial < 100; ++trial) {
    const Vector3f c(pos(rng), pos(rng), pos(rng) * 0.1f);
    const Vector3f half(size(rng), size(rng), size(rng));
    const float psi = yaw(rng);
    const float cs = std::cos(psi), sn = std::sin(psi);
    auto to_world = [&](const Vector3f& l) { return Vector3f(c.x() + cs * l.x() - sn * l.y(), c.y() + sn * l.x() + cs * l.y(), c.z() + l.z()); };
    const float tol = 1e-4f * (1.0f + c.norm());

    // Box: the corners are surface points, and the tight bounds are spanned by them.
    const Aabb bb = pl::sim::bounds_of(pl::sim::make_box(c, half, psi, 0));
    Aabb corners;
    for (int k = 0; k < 8; ++k) {
      const Vector3f l((k & 1 ? 1 : -1) * half.x(), (k & 2 ? 1 : -1) * half.y(), (k & 4 ? 1 : -1) * half.z());
      const Vector3f p = to_world(l);
      EXPECT_TRUE(inside(bb, p, tol));
      corners.min = corners.min.cwiseMin(p);
      corners.max = corners.max.cwiseMax(p);
    }
    EXPECT_TRUE((bb.min - corners.min).norm() < tol);
    EXPECT_TRUE((bb.max - corners.max).norm() < tol);
    for (int k = 0; k < 100; ++k) {
      Vector3f l(u(rng) * half.x(), u(rng) * half.y(), u(rng) * half.z());
      const int axis = k % 3;
      l[axis] = (k & 1 ? 1.0f : -1.0f) * half[axis];  // onto a face
      EXPECT_TRUE(inside(bb, to_world(l), tol));
    }

    // Ellipsoid: surface points inside, and the bounds are reached (tight) within a small margin.
    const Aabb eb = pl::sim::bounds_of(pl::sim::make_ellipsoid(c, half, psi, 0));
    Aabb seen;
    for (int k = 0; k < 2000; ++k) {
      const Vector3f s = rand_unit(rng);
      const Vector3f p = to_world(s.cwiseProduct(half));
      EXPECT_TRUE(inside(eb, p, tol));
      seen.min = seen.min.cwiseMin(p);
      seen.max = seen.max.cwiseMax(p);
    }
    EXPECT_LT((eb.max - seen.max).maxCoeff(), 0.1f * half.maxCoeff());
    EXPECT_LT((seen.min - eb.min).maxCoeff(), 0.1f * half.maxCoeff());

    // Cylinder: side and caps.
    const float radius = half.x(), height = half.z() * 2;
    const Aabb cb = pl::sim::bounds_of(pl::sim::make_cylinder(c, radius, height, 0));
    for (int k = 0; k < 200; ++k) {
      const float a = yaw(rng);
      const float rr = k % 3 == 0 ? radius * std::abs(u(rng)) : radius;
      const float z = k % 3 == 0 ? (k & 1 ? height : 0.0f) : height * 0.5f * (1 + u(rng));
      EXPECT_TRUE(inside(cb, c + Vector3f(rr * std::cos(a), rr * std::sin(a), z), tol));
    }
    EXPECT_NEAR(cb.min.z(), c.z(), tol);
    EXPECT_NEAR(cb.max.z(), c.z() + height, tol);
    EXPECT_NEAR(cb.max.x() - cb.min.x(), 2 * radius, tol);

    // Triangle: vertices span the bounds, barycentric points inside.
    const Vector3f a = c, b = c + half, d = c + Vector3f(u(rng), u(rng), u(rng)) * 5.0f;
    const Aabb tb = pl::sim::bounds_of(pl::sim::make_triangle(a, b, d, 0));
    EXPECT_EQ(tb.min, a.cwiseMin(b).cwiseMin(d));
    EXPECT_EQ(tb.max, a.cwiseMax(b).cwiseMax(d));
    for (int k = 0; k < 50; ++k) {
      float w1 = 0.5f * (1 + u(rng)), w2 = 0.5f * (1 + u(rng));
      if (w1 + w2 > 1) w1 = 1 - w1, w2 = 1 - w2;
      EXPECT_TRUE(inside(tb, a + w1 * (b - a) + w2 * (d - a), tol));
    }
  }
}

TEST(Raycast, HitPointsLieOnTheSurfaceAndInsideBounds) {
  // Every hit of a random ray lies inside the primitive's bounds (used by the BVH).
  const auto prims = random_scene(300, 20.0f, 3);
  const auto rays = random_rays(3000, 25.0f, 4);
  std::size_t hits = 0;
  for (const auto& p : prims) {
    const Aabb b = pl::sim::bounds_of(p);
    for (const auto& r : rays) {
      Hit h;
      if (!pl::sim::intersect(p, r, h)) continue;
      ++hits;
      EXPECT_TRUE(inside(b, r.origin + h.t * r.dir, 1e-4f));
      EXPECT_LE(h.normal.dot(r.dir), 0.0f);
      EXPECT_NEAR(h.normal.norm(), 1.0f, 1e-5f);
      EXPECT_GT(h.t, 0.0f);
      EXPECT_LT(h.t, r.t_max);
    }
  }
  EXPECT_GT(hits, 1000u);
}

TEST(Raycast, EmptyBvh) {
  const Bvh empty;
  Hit h;
  EXPECT_TRUE(empty.empty());
  EXPECT_EQ(empty.node_count(), 0u);
  EXPECT_FALSE(empty.intersect(make_ray(Vector3f(0, 0, 0), Vector3f(1, 0, 0)), h));
  const Bvh built(std::vector<Primitive>{});
  EXPECT_TRUE(built.empty());
  EXPECT_FALSE(built.intersect(make_ray(Vector3f(0, 0, 0), Vector3f(0, 0, 1)), h));
}

TEST(Raycast, SinglePrimitiveBvh) {
  const Bvh bvh({pl::sim::make_cylinder(Vector3f(5, 0, 0), 1.0f, 4.0f, 42)});
  EXPECT_FALSE(bvh.empty());
  EXPECT_EQ(bvh.node_count(), 1u);
  ASSERT_EQ(bvh.primitives().size(), 1u);
  Hit h;
  ASSERT_TRUE(bvh.intersect(make_ray(Vector3f(0, 0, 2), Vector3f(1, 0, 0)), h));
  EXPECT_NEAR(h.t, 4.0f, 1e-5f);
  EXPECT_EQ(h.primitive, 0u);
  EXPECT_TRUE(h.normal.isApprox(Vector3f(-1, 0, 0), 1e-5f));
  EXPECT_EQ(bvh.primitives()[h.primitive].object, 42u);
  EXPECT_FALSE(bvh.intersect(make_ray(Vector3f(0, 0, 2), Vector3f(-1, 0, 0)), h));
  EXPECT_FALSE(bvh.intersect(make_ray(Vector3f(0, 0, 2), Vector3f(1, 0, 0), 3.0f), h));
}

TEST(Raycast, BvhReordersAPermutation) {
  const auto input = random_scene(5000, 100.0f, 21);
  const Bvh bvh(input);
  std::vector<std::uint32_t> ids;
  for (const auto& p : bvh.primitives()) ids.push_back(p.object);
  std::sort(ids.begin(), ids.end());
  for (std::size_t i = 0; i < ids.size(); ++i) ASSERT_EQ(ids[i], i);
  for (const auto& p : bvh.primitives()) {
    const auto& q = input[p.object];
    EXPECT_EQ(p.shape, q.shape);
    EXPECT_EQ(p.a, q.a);
    EXPECT_EQ(p.b, q.b);
    EXPECT_EQ(p.c, q.c);
    EXPECT_EQ(p.yaw, q.yaw);
  }
  EXPECT_GE(bvh.node_count(), 2 * (input.size() / 4) - 1);
  EXPECT_LE(bvh.node_count(), 2 * input.size() - 1);
}

TEST(Raycast, BvhMatchesBruteForceMixedScene) {
  compare_with_brute_force(random_scene(3000, 60.0f, 1), random_rays(10000, 70.0f, 2));
}

TEST(Raycast, BvhMatchesBruteForceDenseScene) {
  compare_with_brute_force(random_scene(2000, 15.0f, 7), random_rays(10000, 20.0f, 8));
}

TEST(Raycast, BvhMatchesBruteForceGroundGridAndObjects) {
  // A flat triangulated ground (shared edges and vertices, ties between neighbours) under objects,
  // far from the origin of the frame, and sensor-like rays from 1.7 m above it.
  std::vector<Primitive> prims;
  const Vector3f base(1500.0f, -800.0f, 30.0f);
  const int nx = 60, ny = 20;
  const float cell = 4.0f;
  for (int i = 0; i < nx; ++i)
    for (int j = 0; j < ny; ++j) {
      const Vector3f p00 = base + Vector3f(i * cell, j * cell, 0), p10 = p00 + Vector3f(cell, 0, 0);
      const Vector3f p01 = p00 + Vector3f(0, cell, 0), p11 = p00 + Vector3f(cell, cell, 0);
      prims.push_back(pl::sim::make_triangle(p00, p10, p11, 0));
      prims.push_back(pl::sim::make_triangle(p00, p11, p01, 0));
    }
  auto objects = random_scene(1500, 100.0f, 9);
  for (auto& o : objects) {
    o.a += base + Vector3f(120.0f, 40.0f, 0.0f);
    if (o.shape == Shape::Triangle) o.b += base + Vector3f(120.0f, 40.0f, 0.0f), o.c += base + Vector3f(120.0f, 40.0f, 0.0f);
    prims.push_back(o);
  }
  std::mt19937 rng(10);
  std::uniform_real_distribution<float> ux(0.0f, nx * cell), uy(0.0f, ny * cell), az(-kPi, kPi), el(-25.0f * kPi / 180, 2.0f * kPi / 180);
  std::vector<Ray> rays;
  for (int s = 0; s < 20; ++s) {
    const Vector3f o = base + Vector3f(ux(rng), uy(rng), 1.7f);
    for (int k = 0; k < 500; ++k) {
      const float a = az(rng), e = el(rng);
      rays.push_back(make_ray(o, Vector3f(std::cos(e) * std::cos(a), std::cos(e) * std::sin(a), std::sin(e)), 120.0f));
    }
    // Axis-aligned: horizontal along the grid lines' directions, and straight down.
    for (const Vector3f& d : {Vector3f(1, 0, 0), Vector3f(-1, 0, 0), Vector3f(0, 1, 0), Vector3f(0, -1, 0), Vector3f(0, 0, -1)})
      rays.push_back(make_ray(o, d, 120.0f));
  }
  // Rays straight down through grid vertices and along grid lines (exact ties between triangles).
  for (int i = 1; i < 10; ++i) rays.push_back(make_ray(base + Vector3f(i * cell, 2 * cell, 1.7f), Vector3f(0, 0, -1)));
  for (int i = 1; i < 10; ++i) rays.push_back(make_ray(base + Vector3f(i * cell, 1.0f, 1.7f), Vector3f(0, 0, -1)));
  compare_with_brute_force(prims, rays);
}

TEST(Raycast, BvhCoincidentCentroids) {
  // All centroids equal: SAH binning has nothing to split on, the build falls back to the median.
  std::vector<Primitive> prims;
  for (int i = 0; i < 100; ++i)
    prims.push_back(pl::sim::make_box(Vector3f(0, 0, 0), Vector3f(1.0f + 0.01f * i, 1.0f, 1.0f), 0.0f, static_cast<std::uint32_t>(i)));
  const Bvh bvh(prims);
  EXPECT_GT(bvh.node_count(), 1u);
  Hit h;
  ASSERT_TRUE(bvh.intersect(make_ray(Vector3f(-10, 0, 0), Vector3f(1, 0, 0)), h));
  EXPECT_NEAR(h.t, 10.0f - 1.99f, 1e-5f);
  EXPECT_EQ(bvh.primitives()[h.primitive].object, 99u);
  compare_with_brute_force(prims, random_rays(2000, 5.0f, 3));
}

TEST(Raycast, BvhConcurrentQueries) {
  const auto prims = random_scene(3000, 60.0f, 11);
  const auto rays = random_rays(4000, 70.0f, 12);
  const Bvh bvh(prims);
  std::vector<Hit> expected(rays.size());
  std::vector<char> expected_hit(rays.size());
  for (std::size_t i = 0; i < rays.size(); ++i) expected_hit[i] = bvh.intersect(rays[i], expected[i]);
  std::vector<std::size_t> mismatches(4, 0);
  std::vector<std::thread> threads;
  for (std::size_t k = 0; k < 4; ++k)
    threads.emplace_back([&, k] {
      for (std::size_t i = 0; i < rays.size(); ++i) {
        Hit h;
        const bool b = bvh.intersect(rays[(i + k * 997) % rays.size()], h);
        const std::size_t j = (i + k * 997) % rays.size();
        if (b != static_cast<bool>(expected_hit[j]) || (b && (h.t != expected[j].t || h.primitive != expected[j].primitive))) ++mismatches[k];
      }
    });
  for (auto& t : threads) t.join();
  for (std::size_t m : mismatches) EXPECT_EQ(m, 0u);
}
