#include "fetch_plan.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

namespace pl::client {

namespace {

// Per axis, how far the point lies outside the box (0 within its extent).
Eigen::Vector2d outside(const TileBounds& b, const Eigen::Vector2d& c) {
  return {std::max({b.min_x - c.x(), 0.0, c.x() - b.max_x}), std::max({b.min_y - c.y(), 0.0, c.y() - b.max_y})};
}

}  // namespace

bool touches(const TileBounds& b, const Eigen::Vector2d& c, double r) {
  Eigen::Vector2d d = outside(b, c);
  return d.x() * d.x() + d.y() * d.y() <= r * r;
}

double box_distance(const TileBounds& b, const Eigen::Vector2d& c) {
  Eigen::Vector2d d = outside(b, c);
  return std::sqrt(d.x() * d.x() + d.y() * d.y());
}

std::optional<std::size_t> FetchPlan::rank_of(const TileKey& key) const {
  auto it = std::lower_bound(rank_.begin(), rank_.end(), key, [](const auto& r, const TileKey& k) { return r.first < k; });
  if (it == rank_.end() || it->first != key) return std::nullopt;
  return it->second;
}

FetchPlan make_plan(const TileGrid& grid, const std::vector<Disc>& discs, const TileIndex& index, std::uint64_t gen) {
  FetchPlan p;
  p.gen = gen;
  // Every key of every disc with its distance, then one entry per key (the nearest disc's), in key
  // order. Vectors rather than a map: a fleet's load generator plans for thousands of vehicles at
  // 10 Hz, and the map's node allocations were the larger part of make_plan's time.
  std::vector<WantedTile> all;
  for (const Disc& d : discs) {
    bool unknown = false;
    for (const TileKey& k : grid.keys_in_disc(d.center.x(), d.center.y(), d.radius)) {
      all.push_back({k, box_distance(grid.bounds_of(k), d.center)});
      if (!index.knows(k)) unknown = true;
    }
    if (!unknown) continue;
    RoiQuery q{{d.center, std::min(d.radius + std::max(grid.tile_size(), 1.0), kMaxRoiRadius)}, {}};
    if (index.have_usable())
      for (const TileKey& k : grid.keys_in_disc(q.disc.center.x(), q.disc.center.y(), q.disc.radius)) {
        const CachedTile* row = index.find(k);
        if (row && row->exists() && q.have.size() < kMaxHave) q.have.push_back(row->hash);
      }
    p.queries.push_back(std::move(q));
  }
  std::sort(all.begin(), all.end(), [](const WantedTile& a, const WantedTile& b) {
    return a.key < b.key || (a.key == b.key && a.distance < b.distance);
  });
  for (const WantedTile& w : all)
    if (p.wants.empty() || p.wants.back().key != w.key) p.wants.push_back(w);
  std::stable_sort(p.wants.begin(), p.wants.end(), [](const WantedTile& a, const WantedTile& b) { return a.distance < b.distance; });
  p.rank_.reserve(p.wants.size());
  for (std::size_t i = 0; i < p.wants.size(); ++i) p.rank_.push_back({p.wants[i].key, i});
  std::sort(p.rank_.begin(), p.rank_.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  return p;
}

}  // namespace pl::client
