#include "pl/client/roi_map.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include <unordered_set>

#include "pl/common/error.hpp"
#include "pl/common/voxel.hpp"

namespace pl::client {
namespace {

// Part ids in the order of tile keys (signed tx, then ty).
registration::PointMap::PartId part_of(const TileKey& k) {
  const auto biased = [](std::int32_t v) { return static_cast<std::uint64_t>(static_cast<std::uint32_t>(v) ^ 0x80000000u); };
  return (biased(k.tx) << 32) | biased(k.ty);
}

// The first point of each voxel, with its normal.
void thin(const TileCloud& cloud, double voxel_m, std::vector<Eigen::Vector3d>& points, std::vector<Eigen::Vector3f>& normals) {
  std::unordered_set<VoxelIndex, VoxelIndexHash> seen;
  seen.reserve(cloud.size());
  const double inv = 1.0 / voxel_m;
  for (std::size_t i = 0; i < cloud.size(); ++i)
    if (seen.insert(voxel_index(cloud.points[i], inv)).second) {
      points.push_back(cloud.points[i]);
      normals.push_back(cloud.normals[i]);
    }
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
  thin_m_ = cfg.thin_m;
}

std::size_t RoiMap::update(const std::vector<MapTile>& tiles) {
  std::map<TileKey, const MapTile*> wanted;
  for (const MapTile& t : tiles)
    if (t.cloud && t.cloud->normals.size() == t.cloud->size()) wanted[t.key] = &t;
  std::size_t changes = 0;
  for (auto it = held_.begin(); it != held_.end();) {
    auto w = wanted.find(it->first);
    if (w == wanted.end() || w->second->hash != it->second.hash) {
      map_->remove(part_of(it->first));
      it = held_.erase(it);
      ++changes;
    } else {
      ++it;
    }
  }
  for (const auto& [key, tile] : wanted)
    if (!held_.count(key)) {
      if (thin_m_ > 0) {
        std::vector<Eigen::Vector3d> points;
        std::vector<Eigen::Vector3f> normals;
        thin(*tile->cloud, thin_m_, points, normals);
        map_->add(part_of(key), points, normals);
      } else {
        map_->add(part_of(key), tile->cloud->points, tile->cloud->normals);
      }
      held_[key] = *tile;
      ++changes;
    }
  return changes;
}

std::vector<MapTile> RoiMap::held_tiles() const {
  std::vector<MapTile> out;
  out.reserve(held_.size());
  for (const auto& [key, tile] : held_) out.push_back(tile);
  return out;
}

}  // namespace pl::client
