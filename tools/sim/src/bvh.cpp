// The bounding-volume hierarchy over the world's shapes: built once with binned SAH, then queried
// for the closest hit by a stack traversal, nearer child first.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <utility>
#include <vector>

#include "pl/sim/raycast.hpp"
#include "shape_hits.hpp"

namespace pl::sim {

using namespace raycast_detail;

namespace {

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

}  // namespace

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
