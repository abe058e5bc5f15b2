#include "pl/eval/nearest.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

#include "pl/common/error.hpp"

namespace pl::eval {

namespace {
constexpr std::uint32_t kLeafSize = 12;
}  // namespace

NearestIndex::NearestIndex(const Points3d& points) {
  if (points.size() >= std::numeric_limits<std::uint32_t>::max())
    throw Error("nearest-neighbour index: more than 4 billion points");
  if (points.empty()) return;
  order_.resize(points.size());
  std::iota(order_.begin(), order_.end(), std::uint32_t{0});
  nodes_.reserve(4 * points.size() / kLeafSize + 2);
  build(points, 0, static_cast<std::uint32_t>(points.size()));
  // The points in leaf order, so that a leaf scans contiguous memory.
  points_.resize(points.size());
  for (std::size_t k = 0; k < points.size(); ++k) points_[k] = points[order_[k]];
  slot_.resize(points.size());
  for (std::size_t k = 0; k < points.size(); ++k) slot_[order_[k]] = static_cast<std::uint32_t>(k);
}

std::uint32_t NearestIndex::build(const Points3d& input, std::uint32_t begin, std::uint32_t end) {
  const auto id = static_cast<std::uint32_t>(nodes_.size());
  nodes_.emplace_back();
  Node node;
  node.begin = begin;
  node.end = end;
  node.lo = node.hi = input[order_[begin]];
  for (std::uint32_t i = begin + 1; i < end; ++i) {
    node.lo = node.lo.cwiseMin(input[order_[i]]);
    node.hi = node.hi.cwiseMax(input[order_[i]]);
  }
  int axis = 0;
  (node.hi - node.lo).maxCoeff(&axis);
  // Split at the median of the widest axis, unless the node is small or all its points coincide.
  if (end - begin > kLeafSize && node.hi[axis] > node.lo[axis]) {
    const std::uint32_t mid = begin + (end - begin) / 2;
    std::nth_element(order_.begin() + begin, order_.begin() + mid, order_.begin() + end,
                     [&](std::uint32_t a, std::uint32_t b) { return input[a][axis] < input[b][axis]; });
    node.leaf = false;
    node.left = build(input, begin, mid);
    node.right = build(input, mid, end);
  }
  nodes_[id] = node;
  return id;
}

void NearestIndex::search(std::uint32_t id, const Eigen::Vector3d& q, std::size_t exclude, double& best_sq,
                          std::size_t& best) const {
  const Node& node = nodes_[id];
  if (node.leaf) {
    for (std::uint32_t i = node.begin; i < node.end; ++i) {
      const double d = (points_[i] - q).squaredNorm();
      if (d < best_sq && order_[i] != exclude) {
        best_sq = d;
        best = i;
      }
    }
    return;
  }
  // The child whose box is closer first; the other only if its box can still hold a closer point.
  const double dl = nodes_[node.left].box_distance_sq(q), dr = nodes_[node.right].box_distance_sq(q);
  const bool left_first = dl <= dr;
  const std::uint32_t first = left_first ? node.left : node.right, second = left_first ? node.right : node.left;
  if ((left_first ? dl : dr) < best_sq) search(first, q, exclude, best_sq, best);
  if ((left_first ? dr : dl) < best_sq) search(second, q, exclude, best_sq, best);
}

NearestIndex::Hit NearestIndex::nearest(const Eigen::Vector3d& q, std::size_t exclude) const {
  Hit hit;
  if (points_.empty()) return hit;
  double best_sq = std::numeric_limits<double>::infinity();
  std::size_t best = points_.size();
  search(0, q, exclude, best_sq, best);
  if (best == points_.size()) return hit;  // the only point was excluded
  hit.index = order_[best];
  hit.distance = std::sqrt(best_sq);
  return hit;
}

bool NearestIndex::within(std::uint32_t id, const Eigen::Vector3d& q, double radius_sq) const {
  const Node& node = nodes_[id];
  if (node.box_distance_sq(q) > radius_sq) return false;
  if (node.leaf) {
    for (std::uint32_t i = node.begin; i < node.end; ++i)
      if ((points_[i] - q).squaredNorm() <= radius_sq) return true;
    return false;
  }
  return within(node.left, q, radius_sq) || within(node.right, q, radius_sq);
}

bool NearestIndex::any_within(const Eigen::Vector3d& q, double radius) const {
  if (points_.empty() || !(radius >= 0.0)) return false;
  return within(0, q, radius * radius);
}

void NearestIndex::collect(std::uint32_t id, const Eigen::Vector3d& q, double radius_sq, std::vector<std::size_t>& out) const {
  const Node& node = nodes_[id];
  if (node.box_distance_sq(q) > radius_sq) return;
  if (node.leaf) {
    for (std::uint32_t i = node.begin; i < node.end; ++i)
      if ((points_[i] - q).squaredNorm() <= radius_sq) out.push_back(order_[i]);
    return;
  }
  collect(node.left, q, radius_sq, out);
  collect(node.right, q, radius_sq, out);
}

void NearestIndex::radius_search(const Eigen::Vector3d& q, double radius, std::vector<std::size_t>& out) const {
  if (points_.empty() || !(radius >= 0.0)) return;
  collect(0, q, radius * radius, out);
}

const Eigen::Vector3d& NearestIndex::point(std::size_t input_index) const { return points_[slot_.at(input_index)]; }

}  // namespace pl::eval
