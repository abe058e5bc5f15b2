// The decoded tiles the tile client holds in memory, within a byte budget (TileClientConfig::memory_mb,
// counted by decoded_size), with the least-recently-used order that eviction follows. The decisions:
// can a tile of a given size fit for the plan, and which tiles go to make room for it: the least
// recently used outside the plan first, then planned tiles farthest first, never one ranked at or
// before the tile being loaded. Plain logic: no threads, network or clocks ("recently" is a counter
// of uses). Private to pl_client.
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <map>
#include <optional>
#include <vector>

#include "fetch_plan.hpp"
#include "pl/client/map_tile.hpp"
#include "pl/common/tile_key.hpp"

namespace pl::client {

class TileMemory {
 public:
  explicit TileMemory(std::size_t budget_bytes) : budget_(budget_bytes) {}

  std::size_t budget() const { return budget_; }
  std::size_t bytes() const { return bytes_; }  // sum of the sizes held
  std::size_t count() const { return slots_.size(); }
  const MapTile* find(const TileKey& key) const;
  bool holds(const TileKey& key) const { return slots_.count(key) > 0; }

  // Holds a tile counted as `size` bytes, as the most recently used (replacing one at its key).
  // The caller makes room first (make_room): put() itself does not check the budget.
  void put(MapTile tile, std::size_t size);
  // Drops the tile at `key`; returns whether one was held.
  bool drop(const TileKey& key);
  void clear();

  // The tiles (in key order) whose box on `grid` touches the disc, each marked as just used.
  std::vector<MapTile> use_near(const TileGrid& grid, const Eigen::Vector2d& center, double radius);

  // The bytes that may go to make room for the plan's tile of rank `rank`: the tiles held outside
  // the plan, and the planned ones ranked after it.
  std::size_t evictable(const FetchPlan& plan, std::size_t rank) const;
  // Whether `size` more bytes fit within the budget, evicting only what may go for rank `rank`.
  bool fits(const FetchPlan& plan, std::size_t rank, std::size_t size) const;
  // The tiles to evict, in order, so that `size` more bytes fit: the least recently used outside
  // the plan first, then planned tiles ranked after `rank`, farthest first; just enough of them.
  // nullopt when even evicting all of those would not do (a tile that may not go is in the way,
  // or the size is over the whole budget).
  std::optional<std::vector<TileKey>> victims(const FetchPlan& plan, std::size_t rank, std::size_t size) const;
  // Evicts the victims; returns them (nullopt, and nothing evicted, when the size cannot fit).
  std::optional<std::vector<TileKey>> make_room(const FetchPlan& plan, std::size_t rank, std::size_t size);

 private:
  struct Slot {
    MapTile tile;
    std::size_t size = 0;    // as counted against the budget
    std::uint64_t used = 0;  // stamp of the last use: larger is more recent
  };
  std::size_t budget_;
  std::size_t bytes_ = 0;
  std::uint64_t tick_ = 0;
  std::map<TileKey, Slot> slots_;
};

}  // namespace pl::client
