// Ray casting for the simulator: primitive intersection tests and a binned-SAH BVH.
//
// The hot path (Bvh::intersect) works on Bvh::Prepared records: the yaw is stored as cos/sin, the
// ellipsoid radii as their inverses and triangles as a vertex plus two edges, so a query makes no
// libm calls apart from square roots and allocates nothing. The per-shape tests return the distance
// and which part of the shape was hit; the normal is worked out once, for the closest hit only.
#include "pl/sim/raycast.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <limits>
#include <stdexcept>
#include <utility>

namespace pl::sim {
namespace {

constexpr float kMinT = 1e-5f;  // hits closer than this are ignored (self-intersection guard)

// Node slab tests scale their exit distance by this (a few float ulps, after Ize's robust traversal
// bound) so that rounding never rejects a box the ray grazes.
constexpr float kRobustFar = 1.0f + 4.0f * std::numeric_limits<float>::epsilon();

constexpr int kMaxLeaf = 4;
constexpr int kBins = 16;
constexpr std::uint32_t kForceMedianDepth = 64;  // deeper than this, split at the median (bounds depth)
constexpr int kStackSize = 128;                   // > kForceMedianDepth + log2(2^32)
constexpr float kTraversalCost = 1.0f;            // relative to one primitive test

inline float fmin2(float a, float b) { return a < b ? a : b; }
inline float fmax2(float a, float b) { return a > b ? a : b; }

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

Bvh::Bvh(std::vector<Primitive> primitives) {
  const std::size_t n = primitives.size();
  if (n == 0) return;
  if (n >= std::numeric_limits<std::uint32_t>::max() / 2) throw std::length_error("Bvh: too many primitives");

  // Build records: padded bounds, centroid and original index, partitioned in place.
  struct Ref {
    float mn[3], mx[3], c[3];
    std::uint32_t id;
  };
  std::vector<Ref> refs(n);
  for (std::size_t i = 0; i < n; ++i) {
    const Aabb b = bounds_of(primitives[i]);
    Ref& r = refs[i];
    float scale = 1.0f;
    for (int k = 0; k < 3; ++k) scale = std::max({scale, std::abs(b.min[k]), std::abs(b.max[k])});
    // A few ulps of the coordinates' magnitude, so that rounding in the intersection tests never
    // puts a hit outside the box the traversal tests against.
    const float pad = 4.0f * std::numeric_limits<float>::epsilon() * scale;
    for (int k = 0; k < 3; ++k) {
      r.mn[k] = b.min[k] - pad;
      r.mx[k] = b.max[k] + pad;
      r.c[k] = 0.5f * (b.min[k] + b.max[k]);
    }
    r.id = static_cast<std::uint32_t>(i);
  }

  struct Task {
    std::uint32_t begin, end, patch, depth;  // patch: parent whose `first` is this node, or kNone
  };
  constexpr std::uint32_t kNone = std::numeric_limits<std::uint32_t>::max();
  struct Bin {
    float mn[3], mx[3];
    std::uint32_t count;
  };
  auto area = [](const float* mn, const float* mx) {
    const float x = mx[0] - mn[0], y = mx[1] - mn[1], z = mx[2] - mn[2];
    return x * y + y * z + z * x;  // half the surface area; only ratios matter
  };
  auto bin_of = [](float c, float lo, float scale) {
    const float f = (c - lo) * scale;  // clamped as a float: no out-of-range (or NaN) conversion
    return f > 0.0f ? (f < static_cast<float>(kBins - 1) ? static_cast<int>(f) : kBins - 1) : 0;
  };

  nodes_.reserve(2 * n);
  std::vector<Task> tasks;
  tasks.push_back({0, static_cast<std::uint32_t>(n), kNone, 0});
  while (!tasks.empty()) {
    const Task task = tasks.back();
    tasks.pop_back();
    const std::uint32_t me = static_cast<std::uint32_t>(nodes_.size());
    if (task.patch != kNone) nodes_[task.patch].first = me;

    float nmn[3] = {INFINITY, INFINITY, INFINITY}, nmx[3] = {-INFINITY, -INFINITY, -INFINITY};
    float cmn[3] = {INFINITY, INFINITY, INFINITY}, cmx[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (std::uint32_t i = task.begin; i < task.end; ++i) {
      const Ref& r = refs[i];
      for (int k = 0; k < 3; ++k) {
        nmn[k] = std::min(nmn[k], r.mn[k]), nmx[k] = std::max(nmx[k], r.mx[k]);
        cmn[k] = std::min(cmn[k], r.c[k]), cmx[k] = std::max(cmx[k], r.c[k]);
      }
    }
    Node node;
    node.min = Eigen::Vector3f(nmn[0], nmn[1], nmn[2]);
    node.max = Eigen::Vector3f(nmx[0], nmx[1], nmx[2]);
    node.first = task.begin;
    node.count = task.end - task.begin;
    nodes_.push_back(node);
    const std::uint32_t count = task.end - task.begin;
    if (count <= 1) continue;

    // Binned SAH over all three axes.
    int best_axis = -1, best_bin = -1;
    float best_cost = INFINITY;
    if (task.depth < kForceMedianDepth) {
      for (int axis = 0; axis < 3; ++axis) {
        const float extent = cmx[axis] - cmn[axis];
        if (!(extent > 0.0f) || !std::isfinite(extent)) continue;
        const float scale = static_cast<float>(kBins) / extent;
        std::array<Bin, kBins> bins;
        for (Bin& b : bins) {
          for (int k = 0; k < 3; ++k) b.mn[k] = INFINITY, b.mx[k] = -INFINITY;
          b.count = 0;
        }
        for (std::uint32_t i = task.begin; i < task.end; ++i) {
          const Ref& r = refs[i];
          Bin& b = bins[static_cast<std::size_t>(bin_of(r.c[axis], cmn[axis], scale))];
          ++b.count;
          for (int k = 0; k < 3; ++k) b.mn[k] = std::min(b.mn[k], r.mn[k]), b.mx[k] = std::max(b.mx[k], r.mx[k]);
        }
        // Right-to-left sweep: cost contribution of bins (k, kBins).
        std::array<float, kBins> right_cost{};
        {
          float mn[3] = {INFINITY, INFINITY, INFINITY}, mx[3] = {-INFINITY, -INFINITY, -INFINITY};
          std::uint32_t cnt = 0;
          for (int k = kBins - 1; k > 0; --k) {
            const Bin& b = bins[static_cast<std::size_t>(k)];
            cnt += b.count;
            for (int j = 0; j < 3; ++j) mn[j] = std::min(mn[j], b.mn[j]), mx[j] = std::max(mx[j], b.mx[j]);
            right_cost[static_cast<std::size_t>(k - 1)] = cnt ? area(mn, mx) * static_cast<float>(cnt) : INFINITY;
          }
        }
        float mn[3] = {INFINITY, INFINITY, INFINITY}, mx[3] = {-INFINITY, -INFINITY, -INFINITY};
        std::uint32_t cnt = 0;
        for (int k = 0; k < kBins - 1; ++k) {  // split between bin k and k + 1
          const Bin& b = bins[static_cast<std::size_t>(k)];
          cnt += b.count;
          for (int j = 0; j < 3; ++j) mn[j] = std::min(mn[j], b.mn[j]), mx[j] = std::max(mx[j], b.mx[j]);
          if (cnt == 0 || cnt == count) continue;
          const float cost = area(mn, mx) * static_cast<float>(cnt) + right_cost[static_cast<std::size_t>(k)];
          if (cost < best_cost) best_cost = cost, best_axis = axis, best_bin = k;
        }
      }
    }

    std::uint32_t mid = 0;
    if (best_axis >= 0) {
      const float node_area = area(nmn, nmx);
      const float split_cost = node_area > 0.0f ? kTraversalCost + best_cost / node_area : INFINITY;
      if (count <= static_cast<std::uint32_t>(kMaxLeaf) && !(split_cost < static_cast<float>(count))) continue;  // leaf
      const int axis = best_axis;
      const float lo = cmn[axis], scale = static_cast<float>(kBins) / (cmx[axis] - cmn[axis]);
      const int split = best_bin;
      auto it = std::partition(refs.begin() + task.begin, refs.begin() + task.end,
                               [&](const Ref& r) { return bin_of(r.c[axis], lo, scale) <= split; });
      mid = static_cast<std::uint32_t>(it - refs.begin());
    } else {
      if (count <= static_cast<std::uint32_t>(kMaxLeaf)) continue;  // leaf
      // Median split on the widest centroid axis (or halves of the range when all coincide).
      int axis = 0;
      for (int k = 1; k < 3; ++k)
        if (cmx[k] - cmn[k] > cmx[axis] - cmn[axis]) axis = k;
      mid = task.begin + count / 2;
      std::nth_element(refs.begin() + task.begin, refs.begin() + mid, refs.begin() + task.end,
                       [axis](const Ref& a, const Ref& b) { return a.c[axis] < b.c[axis]; });
    }
    nodes_[me].count = 0;  // inner; `first` is patched when the right child is created
    tasks.push_back({mid, task.end, me, task.depth + 1});     // right: popped after the left subtree
    tasks.push_back({task.begin, mid, kNone, task.depth + 1});  // left: next, so it lands at me + 1
  }
  nodes_.shrink_to_fit();

  prims_.reserve(n);
  prep_.reserve(n);
  for (const Ref& r : refs) {
    prims_.push_back(std::move(primitives[r.id]));
    prep_.push_back(prepare<Prepared>(prims_.back()));
  }
}

namespace {

// Ray against a node's box: entry distance in `t_entry`; false when the box is missed or lies
// beyond `t_max`.
template <class N>
inline bool hit_node(const N& n, const RayData& r, float t_max, float& t_entry) {
  const float x0 = (n.min.x() - r.ox) * r.ix, x1 = (n.max.x() - r.ox) * r.ix;
  const float y0 = (n.min.y() - r.oy) * r.iy, y1 = (n.max.y() - r.oy) * r.iy;
  const float z0 = (n.min.z() - r.oz) * r.iz, z1 = (n.max.z() - r.oz) * r.iz;
  const float lo = fmax2(fmax2(fmin2(x0, x1), fmin2(y0, y1)), fmax2(fmin2(z0, z1), 0.0f));
  const float hi = fmin2(fmin2(fmin2(fmax2(x0, x1), fmax2(y0, y1)), fmax2(z0, z1)) * kRobustFar, t_max);
  t_entry = lo;
  return lo <= hi;
}

}  // namespace

bool Bvh::intersect(const Ray& ray, Hit& hit) const {
  if (nodes_.empty()) return false;
  const RayData r = ray_data(ray);
  float best = ray.t_max;
  std::uint32_t best_prim = std::numeric_limits<std::uint32_t>::max();
  int best_part = 2;

  float t_entry = 0.0f;
  if (!(best > kMinT) || !hit_node(nodes_[0], r, best, t_entry)) return false;

  struct Entry {
    std::uint32_t node;
    float t;
  };
  Entry stack[kStackSize];
  int sp = 0;
  std::uint32_t ni = 0;
  const Node* nodes = nodes_.data();
  const Prepared* prep = prep_.data();
  for (;;) {
    const Node& n = nodes[ni];
    if (n.count != 0) {
      const std::uint32_t end = n.first + n.count;
      for (std::uint32_t i = n.first; i < end; ++i) {
        float t;
        int part = 2;
        if (hit_prepared(prep[i], r, best, t, part)) best = t, best_prim = i, best_part = part;
      }
    } else {
      std::uint32_t near = ni + 1, far = n.first;
      float t_near, t_far;
      const bool hit_near = hit_node(nodes[near], r, best, t_near);
      const bool hit_far = hit_node(nodes[far], r, best, t_far);
      if (hit_near && hit_far) {
        if (t_far < t_near) std::swap(near, far), std::swap(t_near, t_far);
        stack[sp++] = {far, t_far};
        ni = near;
        continue;
      }
      if (hit_near) {
        ni = near;
        continue;
      }
      if (hit_far) {
        ni = far;
        continue;
      }
    }
    // Pop the nearest pending subtree that can still hold a closer hit.
    for (;;) {
      if (sp == 0) goto done;
      const Entry& e = stack[--sp];
      if (e.t <= best) {
        ni = e.node;
        break;
      }
    }
  }
done:
  if (best_prim == std::numeric_limits<std::uint32_t>::max()) return false;
  hit.t = best;
  hit.primitive = best_prim;
  hit.normal = normal_at(prep[best_prim], r, best, best_part);
  return true;
}

}  // namespace pl::sim
