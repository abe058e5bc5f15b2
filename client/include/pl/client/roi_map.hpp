// The map the localizer registers against: the points and normals of the tiles around the vehicle,
// in a voxel hash that is updated only as tiles enter and leave (never rebuilt per scan).
//
// Points are stored as float32 offsets from an anchor on the tile grid (double), so the map frame may
// be anywhere; cells divide tiles exactly, so a tile owns its cells and leaves without a trace.
#pragma once

#include <Eigen/Core>

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "pl/client/map_tile.hpp"
#include "pl/common/tile_codec.hpp"
#include "pl/common/tile_key.hpp"

namespace pl::client {

struct RoiMapConfig {
  double cell_m = 1.0;  // hash cell edge, rounded so that cells divide the tile size; nearest-neighbour
                        // search is exact within cell_m / 2 and approximate up to cell_m
};

// A map point in anchor coordinates with its unit normal.
struct MapPoint {
  Eigen::Vector3f p;
  Eigen::Vector3f n;
};

struct Neighbour {
  const MapPoint* point = nullptr;  // nullptr: nothing within the distance asked
  float dist2 = 0;
};

class RoiMap {
 public:
  // tile_size: the map's tile edge; anchor: any point near where the drive happens (map frame).
  RoiMap(double tile_size, const Eigen::Vector3d& anchor, const RoiMapConfig& cfg = {});
  ~RoiMap();
  RoiMap(const RoiMap&) = delete;
  RoiMap& operator=(const RoiMap&) = delete;

  // Makes the held tiles exactly `tiles` (key, content hash, decoded cloud): adds the new ones,
  // drops the ones not listed, keeps the rest untouched. Tiles without normals are skipped (the
  // localizer needs them). Returns the number of tiles added + removed.
  using TileRef = MapTile;
  std::size_t update(const std::vector<TileRef>& tiles);

  // Nearest map point to q (anchor coordinates) within sqrt(max_dist2) (at most cell_m).
  Neighbour nearest(const Eigen::Vector3f& q, float max_dist2) const;

  const Eigen::Vector3d& anchor() const { return anchor_; }
  double cell_m() const { return cell_; }
  std::size_t tiles() const { return tiles_.size(); }
  std::size_t points() const { return points_; }
  std::size_t cells() const;
  // All points (anchor coordinates), for baselines and plots.
  std::vector<MapPoint> all_points() const;

 private:
  struct Tile;
  struct Table;
  double cell_;
  Eigen::Vector3d anchor_;
  std::map<TileKey, std::unique_ptr<Tile>> tiles_;
  std::unique_ptr<Table> table_;
  std::size_t points_ = 0;
  void add(const TileRef& ref);
  void remove(std::map<TileKey, std::unique_ptr<Tile>>::iterator it);
};

}  // namespace pl::client
