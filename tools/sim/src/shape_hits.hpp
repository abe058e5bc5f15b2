// The ray tests of single shapes, shared by intersect() and the BVH (raycast.cpp, bvh.cpp).
//
// The hot path (Bvh::intersect) works on Bvh::Prepared records: the yaw is stored as cos/sin, the
// ellipsoid radii as their inverses and triangles as a vertex plus two edges, so a query makes no
// libm calls apart from square roots and allocates nothing. The per-shape tests return the distance
// and which part of the shape was hit; the normal is worked out once, for the closest hit only.
#pragma once

#include <cmath>
#include <cstdint>
#include <limits>
#include <utility>

#include "pl/sim/raycast.hpp"

namespace pl::sim::raycast_detail {

constexpr float kMinT = 1e-5f;  // hits closer than this are ignored (self-intersection guard)

// Prepared layouts (Bvh::Prepared::v):
//   Box:       centre v0..2, half extents v3..5, cos(yaw) v6, sin(yaw) v7
//   Cylinder:  bottom centre v0..2, radius v3, height v4, radius^2 v5
//   Ellipsoid: centre v0..2, 1/radii v3..5, cos(yaw) v6, sin(yaw) v7
//   Triangle:  vertex a v0..2, b-a v3..5, c-a v6..8
template <class P>
P prepare(const Primitive& p) {
  P q{};
  q.shape = static_cast<std::uint32_t>(p.shape);
  float* v = q.v;
  switch (p.shape) {
    case Shape::Box:
      v[0] = p.a.x(), v[1] = p.a.y(), v[2] = p.a.z();
      v[3] = std::abs(p.b.x()), v[4] = std::abs(p.b.y()), v[5] = std::abs(p.b.z());
      v[6] = std::cos(p.yaw), v[7] = std::sin(p.yaw);
      break;
    case Shape::Cylinder:  // a negative height hangs down from `a`
      v[0] = p.a.x(), v[1] = p.a.y(), v[2] = std::min(p.a.z(), p.a.z() + p.b.z());
      v[3] = std::abs(p.b.x()), v[4] = std::abs(p.b.z()), v[5] = p.b.x() * p.b.x();
      break;
    case Shape::Ellipsoid:
      v[0] = p.a.x(), v[1] = p.a.y(), v[2] = p.a.z();
      v[3] = 1.0f / std::abs(p.b.x()), v[4] = 1.0f / std::abs(p.b.y()), v[5] = 1.0f / std::abs(p.b.z());
      v[6] = std::cos(p.yaw), v[7] = std::sin(p.yaw);
      break;
    case Shape::Triangle:
      v[0] = p.a.x(), v[1] = p.a.y(), v[2] = p.a.z();
      v[3] = p.b.x() - p.a.x(), v[4] = p.b.y() - p.a.y(), v[5] = p.b.z() - p.a.z();
      v[6] = p.c.x() - p.a.x(), v[7] = p.c.y() - p.a.y(), v[8] = p.c.z() - p.a.z();
      break;
  }
  return q;
}

struct RayData {
  float ox, oy, oz;
  float dx, dy, dz;
  float ix, iy, iz;  // 1/dir, with zero components replaced by a tiny value (no 0*inf NaNs)
};

inline float safe_inverse(float d) {
  constexpr float kTiny = 1e-30f;
  return 1.0f / (d == 0.0f ? (std::signbit(d) ? -kTiny : kTiny) : d);
}

inline RayData ray_data(const Ray& r) {
  RayData q;
  q.ox = r.origin.x(), q.oy = r.origin.y(), q.oz = r.origin.z();
  q.dx = r.dir.x(), q.dy = r.dir.y(), q.dz = r.dir.z();
  q.ix = safe_inverse(q.dx), q.iy = safe_inverse(q.dy), q.iz = safe_inverse(q.dz);
  return q;
}

// One slab of a (local) box: updates the entry/exit interval and the axes that set them; false
// when a ray parallel to the slab lies outside it. Points on the faces count as inside (closed box).
inline bool box_slab(float o, float d, float h, int axis, float& tn, float& tf, int& an, int& af) {
  if (d == 0.0f) return o >= -h && o <= h;
  const float inv = 1.0f / d;
  float a = (-h - o) * inv, b = (h - o) * inv;
  if (a > b) std::swap(a, b);
  if (a > tn) tn = a, an = axis;
  if (b < tf) tf = b, af = axis;
  return true;
}

template <class P>
inline bool hit_box(const P& p, const RayData& r, float tmax, float& t, int& part) {
  const float* v = p.v;
  const float c = v[6], s = v[7];
  const float px = r.ox - v[0], py = r.oy - v[1], pz = r.oz - v[2];
  const float lox = c * px + s * py, loy = c * py - s * px;
  const float ldx = c * r.dx + s * r.dy, ldy = c * r.dy - s * r.dx;
  float tn = -std::numeric_limits<float>::infinity(), tf = std::numeric_limits<float>::infinity();
  int an = 2, af = 2;
  if (!box_slab(lox, ldx, v[3], 0, tn, tf, an, af)) return false;
  if (!box_slab(loy, ldy, v[4], 1, tn, tf, an, af)) return false;
  if (!box_slab(pz, r.dz, v[5], 2, tn, tf, an, af)) return false;
  if (!(tn <= tf)) return false;
  if (tn > kMinT) {
    if (!(tn < tmax)) return false;
    t = tn, part = an;
    return true;
  }
  if (tf > kMinT && tf < tmax) {  // origin inside: the exit point
    t = tf, part = af;
    return true;
  }
  return false;
}

template <class P>
inline bool hit_cylinder(const P& p, const RayData& r, float tmax, float& t, int& part) {
  const float* v = p.v;
  const float px = r.ox - v[0], py = r.oy - v[1], pz = r.oz - v[2];
  const float height = v[4], r2 = v[5];
  float best = tmax;
  bool found = false;
  const float a = r.dx * r.dx + r.dy * r.dy;
  if (a > 0.0f) {
    // Side: |p + t d|^2 = r^2 in the plane. The discriminant via the 2-D cross product
    // (Lagrange's identity) avoids cancelling two large squares for distant origins.
    const float b = px * r.dx + py * r.dy;
    const float cross = px * r.dy - py * r.dx;
    const float disc = a * r2 - cross * cross;
    if (disc >= 0.0f) {
      const float sq = std::sqrt(disc);
      const float inv_a = 1.0f / a;
      const float t0 = (-b - sq) * inv_a, t1 = (-b + sq) * inv_a;
      for (float tc : {t0, t1}) {
        if (tc > kMinT && tc < best) {
          const float z = pz + tc * r.dz;
          if (z >= 0.0f && z <= height) {
            best = tc, part = 0, found = true;
            break;  // t0 <= t1: the first valid root is the closer one
          }
        }
      }
    }
  }
  if (r.dz != 0.0f) {
    const float inv = 1.0f / r.dz;
    for (float zc : {0.0f, height}) {
      const float tc = (zc - pz) * inv;
      if (tc > kMinT && tc < best) {
        const float x = px + tc * r.dx, y = py + tc * r.dy;
        if (x * x + y * y <= r2) best = tc, part = 1, found = true;
      }
    }
  }
  if (found) t = best;
  return found;
}

template <class P>
inline bool hit_ellipsoid(const P& p, const RayData& r, float tmax, float& t) {
  const float* v = p.v;
  const float c = v[6], s = v[7];
  const float px = r.ox - v[0], py = r.oy - v[1], pz = r.oz - v[2];
  // Into the yawed frame, then scaled to the unit sphere.
  const float ox = (c * px + s * py) * v[3], oy = (c * py - s * px) * v[4], oz = pz * v[5];
  const float dx = (c * r.dx + s * r.dy) * v[3], dy = (c * r.dy - s * r.dx) * v[4], dz = r.dz * v[5];
  const float a = dx * dx + dy * dy + dz * dz;
  const float b = ox * dx + oy * dy + oz * dz;
  const float cx = oy * dz - oz * dy, cy = oz * dx - ox * dz, cz = ox * dy - oy * dx;
  const float disc = a - (cx * cx + cy * cy + cz * cz);  // = b^2 - a(|o|^2 - 1), better conditioned
  if (!(disc >= 0.0f)) return false;
  const float sq = std::sqrt(disc);
  const float inv_a = 1.0f / a;
  const float t0 = (-b - sq) * inv_a;
  if (t0 > kMinT) {
    if (!(t0 < tmax)) return false;
    t = t0;
    return true;
  }
  const float t1 = (-b + sq) * inv_a;
  if (t1 > kMinT && t1 < tmax) {
    t = t1;
    return true;
  }
  return false;
}

template <class P>
inline bool hit_triangle(const P& p, const RayData& r, float tmax, float& t) {
  // Möller–Trumbore, two-sided; edges and vertices count as inside.
  const float* v = p.v;
  const float e1x = v[3], e1y = v[4], e1z = v[5];
  const float e2x = v[6], e2y = v[7], e2z = v[8];
  const float pvx = r.dy * e2z - r.dz * e2y, pvy = r.dz * e2x - r.dx * e2z, pvz = r.dx * e2y - r.dy * e2x;
  const float det = e1x * pvx + e1y * pvy + e1z * pvz;
  if (det == 0.0f) return false;
  const float inv = 1.0f / det;
  const float tx = r.ox - v[0], ty = r.oy - v[1], tz = r.oz - v[2];
  const float u = (tx * pvx + ty * pvy + tz * pvz) * inv;
  if (!(u >= 0.0f && u <= 1.0f)) return false;
  const float qx = ty * e1z - tz * e1y, qy = tz * e1x - tx * e1z, qz = tx * e1y - ty * e1x;
  const float w = (r.dx * qx + r.dy * qy + r.dz * qz) * inv;
  if (!(w >= 0.0f && u + w <= 1.0f)) return false;
  const float tc = (e2x * qx + e2y * qy + e2z * qz) * inv;
  if (!(tc > kMinT && tc < tmax)) return false;
  t = tc;
  return true;
}

template <class P>
inline bool hit_prepared(const P& p, const RayData& r, float tmax, float& t, int& part) {
  switch (static_cast<Shape>(p.shape)) {
    case Shape::Triangle: return hit_triangle(p, r, tmax, t);
    case Shape::Box: return hit_box(p, r, tmax, t, part);
    case Shape::Cylinder: return hit_cylinder(p, r, tmax, t, part);
    case Shape::Ellipsoid: return hit_ellipsoid(p, r, tmax, t);
  }
  return false;
}

// Unit normal at distance t along the ray, facing the ray's origin.
template <class P>
Eigen::Vector3f normal_at(const P& p, const RayData& r, float t, int part) {
  const float* v = p.v;
  float nx = 0.0f, ny = 0.0f, nz = 1.0f;
  switch (static_cast<Shape>(p.shape)) {
    case Shape::Box: {
      const float c = v[6], s = v[7];
      if (part == 0) nx = c, ny = s, nz = 0.0f;
      else if (part == 1) nx = -s, ny = c, nz = 0.0f;
      break;
    }
    case Shape::Cylinder:
      if (part == 0) nx = r.ox + t * r.dx - v[0], ny = r.oy + t * r.dy - v[1], nz = 0.0f;
      break;
    case Shape::Ellipsoid: {
      const float c = v[6], s = v[7];
      const float px = r.ox + t * r.dx - v[0], py = r.oy + t * r.dy - v[1], pz = r.oz + t * r.dz - v[2];
      // Gradient of |S R^T p|^2 in the local frame is p_local / radii^2; rotate it back.
      const float lx = (c * px + s * py) * v[3] * v[3], ly = (c * py - s * px) * v[4] * v[4];
      nx = c * lx - s * ly, ny = s * lx + c * ly, nz = pz * v[5] * v[5];
      break;
    }
    case Shape::Triangle:
      nx = v[4] * v[8] - v[5] * v[7], ny = v[5] * v[6] - v[3] * v[8], nz = v[3] * v[7] - v[4] * v[6];
      break;
  }
  const float len2 = nx * nx + ny * ny + nz * nz;
  if (!(len2 > 0.0f)) return Eigen::Vector3f(-r.dx, -r.dy, -r.dz);  // degenerate; face the origin
  float k = 1.0f / std::sqrt(len2);
  if (nx * r.dx + ny * r.dy + nz * r.dz > 0.0f) k = -k;
  return Eigen::Vector3f(nx * k, ny * k, nz * k);
}

}  // namespace pl::sim::raycast_detail
