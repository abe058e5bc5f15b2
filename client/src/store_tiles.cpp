#include "pl/client/store_tiles.hpp"

#include <algorithm>

#include "pl/common/error.hpp"
#include "pl/common/tile_codec.hpp"
#include "pl/common/tile_key.hpp"
#include "pl/schema/store.hpp"
#include "tile_normals.hpp"

namespace pl::client {

struct StoreTiles::Impl {
  store::Store db;
  std::string map;
  double voxel_m = 0;
  std::map<TileKey, std::string> hashes;  // the whole version's index (small: one row per tile)
  std::map<std::string, std::shared_ptr<const TileCloud>> decoded;
};

StoreTiles::StoreTiles(const std::string& db_path, const std::string& map, long long version) {
  auto db = store::Store::open(db_path, false);
  const auto info = db.find_map(map);
  if (!info) throw Error("no map '" + map + "' in " + db_path + " (see: pl-map list --db " + db_path + ")");
  if (version <= 0) {
    if (!info->current) throw Error("map '" + map + "' in " + db_path + " has no published version (pl-map publish)");
    version = *info->current;
  }
  if (!db.find_version(map, version))
    throw Error("map '" + map + "' in " + db_path + " has no version " + std::to_string(version));
  impl_ = std::make_unique<Impl>(Impl{std::move(db), map, info->voxel_size, {}, {}});
  for (const auto& t : impl_->db.list_tiles(map, version)) {
    impl_->hashes[t.key] = t.hash;
    if (!extent_) extent_ = MapExtent{t.min_x, t.min_y, t.max_x, t.max_y};
    extent_->min_x = std::min(extent_->min_x, t.min_x);
    extent_->min_y = std::min(extent_->min_y, t.min_y);
    extent_->max_x = std::max(extent_->max_x, t.max_x);
    extent_->max_y = std::max(extent_->max_y, t.max_y);
  }
  tile_size_ = info->tile_size;
  origin_ = info->origin;
  version_ = version;
}

StoreTiles::~StoreTiles() = default;

std::vector<MapTile> StoreTiles::near(const Eigen::Vector2d& center, double radius) {
  std::vector<MapTile> out;
  const TileGrid grid(tile_size_);
  for (const TileKey& key : grid.keys_in_disc(center.x(), center.y(), radius)) {
    auto it = impl_->hashes.find(key);
    if (it == impl_->hashes.end()) continue;
    auto& cloud = impl_->decoded[it->second];
    if (!cloud) {
      const auto bytes = impl_->db.blob(it->second);
      if (!bytes) throw Error("map store is missing blob " + it->second + " (run PRAGMA integrity_check)");
      cloud = with_normals(decode_tile(*bytes), impl_->voxel_m);
    }
    out.push_back({key, it->second, cloud, 0});
  }
  return out;
}

std::optional<std::string> StoreTiles::places() const { return impl_->db.places(impl_->map, version_); }

}  // namespace pl::client
