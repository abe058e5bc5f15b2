#include "pl/client/roi_map.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "pl/common/error.hpp"

namespace pl::client {
namespace {

// Part ids in the order of tile keys (signed tx, then ty).
registration::PointMap::PartId part_of(const TileKey& k) {
  const auto biased = [](std::int32_t v) { return static_cast<std::uint64_t>(static_cast<std::uint32_t>(v) ^ 0x80000000u); };
  return (biased(k.tx) << 32) | biased(k.ty);
}

}  // namespace

RoiMap::RoiMap(double tile_size, const Eigen::Vector3d& anchor, const RoiMapConfig& cfg) {
  if (!(tile_size > 0)) throw Error("ROI map: tile size must be positive, got " + std::to_string(tile_size));
  if (!(cfg.cell_m > 0)) throw Error("ROI map: cell_m must be positive, got " + std::to_string(cfg.cell_m));
  const double per_tile = std::max(1.0, std::round(tile_size / cfg.cell_m));
  const double cell = tile_size / per_tile;
  // On the tile grid horizontally (cells never straddle tiles), on the cell grid vertically.
  const Eigen::Vector3d snapped(std::floor(anchor.x() / tile_size) * tile_size, std::floor(anchor.y() / tile_size) * tile_size,
                                std::floor(anchor.z() / cell) * cell);
  map_ = std::make_unique<registration::PointMap>(snapped, cell);
}

std::size_t RoiMap::update(const std::vector<MapTile>& tiles) {
  std::map<TileKey, const MapTile*> wanted;
  for (const MapTile& t : tiles)
    if (t.cloud && t.cloud->normals.size() == t.cloud->size()) wanted[t.key] = &t;
  std::size_t changes = 0;
  for (auto it = held_.begin(); it != held_.end();) {
    auto w = wanted.find(it->first);
    if (w == wanted.end() || w->second->hash != it->second) {
      map_->remove(part_of(it->first));
      it = held_.erase(it);
      ++changes;
    } else {
      ++it;
    }
  }
  for (const auto& [key, tile] : wanted)
    if (!held_.count(key)) {
      map_->add(part_of(key), tile->cloud->points, tile->cloud->normals);
      held_[key] = tile->hash;
      ++changes;
    }
  return changes;
}

}  // namespace pl::client
