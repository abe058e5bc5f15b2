#include "tile_memory.hpp"

#include <algorithm>
#include <utility>

namespace pl::client {

const MapTile* TileMemory::find(const TileKey& key) const {
  auto it = slots_.find(key);
  return it == slots_.end() ? nullptr : &it->second.tile;
}

void TileMemory::put(MapTile tile, std::size_t size) {
  drop(tile.key);
  TileKey key = tile.key;
  slots_[key] = Slot{std::move(tile), size, ++tick_};
  bytes_ += size;
}

bool TileMemory::drop(const TileKey& key) {
  auto it = slots_.find(key);
  if (it == slots_.end()) return false;
  bytes_ -= it->second.size;
  slots_.erase(it);
  return true;
}

void TileMemory::clear() {
  slots_.clear();
  bytes_ = 0;
}

std::vector<MapTile> TileMemory::use_near(const TileGrid& grid, const Eigen::Vector2d& center, double radius) {
  std::vector<MapTile> out;
  for (auto& [key, slot] : slots_)
    if (touches(grid.bounds_of(key), center, radius)) {
      slot.used = ++tick_;
      out.push_back(slot.tile);
    }
  return out;
}

std::size_t TileMemory::evictable(const FetchPlan& plan, std::size_t rank) const {
  std::size_t n = 0;
  for (const auto& [key, slot] : slots_) {
    auto r = plan.rank_of(key);
    if (!r || *r > rank) n += slot.size;
  }
  return n;
}

bool TileMemory::fits(const FetchPlan& plan, std::size_t rank, std::size_t size) const {
  return bytes_ + size <= budget_ || bytes_ + size <= budget_ + evictable(plan, rank);
}

std::optional<std::vector<TileKey>> TileMemory::victims(const FetchPlan& plan, std::size_t rank, std::size_t size) const {
  if (bytes_ + size > budget_ + evictable(plan, rank)) return std::nullopt;
  // Eviction order: outside the plan by last use (oldest first), then planned tiles after `rank`
  // by rank (farthest first).
  struct Candidate {
    bool planned;
    std::uint64_t order;  // outside: the use stamp; planned: the rank
    TileKey key;
    std::size_t size;
  };
  std::vector<Candidate> candidates;
  for (const auto& [key, slot] : slots_) {
    auto r = plan.rank_of(key);
    if (!r)
      candidates.push_back({false, slot.used, key, slot.size});
    else if (*r > rank)
      candidates.push_back({true, static_cast<std::uint64_t>(*r), key, slot.size});
  }
  std::stable_sort(candidates.begin(), candidates.end(), [](const Candidate& a, const Candidate& b) {
    if (a.planned != b.planned) return !a.planned;
    return a.planned ? a.order > b.order : a.order < b.order;
  });
  std::vector<TileKey> out;
  std::size_t held = bytes_;
  for (const Candidate& c : candidates) {
    if (held + size <= budget_) break;
    held -= c.size;
    out.push_back(c.key);
  }
  return out;
}

std::optional<std::vector<TileKey>> TileMemory::make_room(const FetchPlan& plan, std::size_t rank, std::size_t size) {
  auto out = victims(plan, rank, size);
  if (out)
    for (const TileKey& k : *out) drop(k);
  return out;
}

}  // namespace pl::client
