// Fetch planning for the tile client: which tiles are wanted for the discs around the focus points
// (and any wait_for disc), in which order (nearest first), and which discs to ask the server about
// (those with keys the index does not know). Plain logic: inputs in, a plan out; no threads, network
// or clocks. Private to pl_client.
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "pl/schema/api_rules.hpp"
#include "pl/common/tile_key.hpp"
#include "tile_index.hpp"

namespace pl::client {

constexpr double kMaxRoiRadius = api::kMaxRoiRadiusM;  // the server's limit on an ROI query's radius
constexpr std::size_t kMaxHave = 80;    // hashes in one have= (65 B each, well within the server's 8 KB of headers)

struct Disc {
  Eigen::Vector2d center;
  double radius;
};

// The test of TileGrid::keys_in_disc and of the server's ROI: does the tile's box touch the disc?
bool touches(const TileBounds& b, const Eigen::Vector2d& c, double r);
// From the point to the nearest point of the box (0 inside it).
double box_distance(const TileBounds& b, const Eigen::Vector2d& c);

struct WantedTile {
  TileKey key;
  double distance;  // to the nearest disc center it is wanted for
};

// An ROI query: the disc, and the hashes of tiles already known in it (have=).
struct RoiQuery {
  Disc disc;
  std::vector<std::string> have;
};

struct FetchPlan {
  std::uint64_t gen = 0;          // of the inputs it was made for (the client's change counter)
  std::vector<WantedTile> wants;  // every key touching a disc, nearest first (ties by key)
  std::vector<RoiQuery> queries;  // one per disc with keys the index does not know, in disc order

  // The position of `key` in wants (0: nearest); nullopt when the key lies outside every disc.
  std::optional<std::size_t> rank_of(const TileKey& key) const;
  bool wanted(const TileKey& key) const { return rank_of(key).has_value(); }

 private:
  friend FetchPlan make_plan(const TileGrid&, const std::vector<Disc>&, const TileIndex&, std::uint64_t);
  std::vector<std::pair<TileKey, std::size_t>> rank_;  // (key, its position in wants), by key
};

// The plan for `discs` on `grid`, given what the index knows. A disc with unknown keys is asked about
// one tile wider (at most kMaxRoiRadius), so that small moves do not ask again, naming up to kMaxHave
// known tiles of the wider disc by hash when the index allows have=.
FetchPlan make_plan(const TileGrid& grid, const std::vector<Disc>& discs, const TileIndex& index, std::uint64_t gen = 0);

}  // namespace pl::client
