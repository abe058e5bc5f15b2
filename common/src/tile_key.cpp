#include "pl/common/tile_key.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "pl/common/error.hpp"

namespace pl {

TileGrid::TileGrid(double tile_size) : size_(tile_size) {
  if (!(tile_size > 0.0) || !std::isfinite(tile_size)) throw Error("tile size must be a positive number of metres");
}

static std::int32_t tile_index(double v, double size) {
  double i = std::floor(v / size);
  if (!(i >= std::numeric_limits<std::int32_t>::min() && i <= std::numeric_limits<std::int32_t>::max()))
    throw Error("coordinate " + std::to_string(v) + " is outside the tile grid (is the map in a local ENU frame?)");
  return static_cast<std::int32_t>(i);
}

TileKey TileGrid::key_of(double x, double y) const { return {tile_index(x, size_), tile_index(y, size_)}; }

TileBounds TileGrid::bounds_of(const TileKey& k) const {
  return {k.tx * size_, k.ty * size_, (static_cast<double>(k.tx) + 1.0) * size_, (static_cast<double>(k.ty) + 1.0) * size_};
}

std::vector<TileKey> TileGrid::keys_in_disc(double cx, double cy, double radius) const {
  std::vector<TileKey> out;
  if (!(radius >= 0.0)) return out;
  TileKey lo = key_of(cx - radius, cy - radius), hi = key_of(cx + radius, cy + radius);
  double r2 = radius * radius;
  for (std::int32_t tx = lo.tx; tx <= hi.tx; ++tx) {
    for (std::int32_t ty = lo.ty; ty <= hi.ty; ++ty) {
      TileBounds b = bounds_of({tx, ty});
      double dx = std::max({b.min_x - cx, 0.0, cx - b.max_x});
      double dy = std::max({b.min_y - cy, 0.0, cy - b.max_y});
      if (dx * dx + dy * dy <= r2) out.push_back({tx, ty});
    }
  }
  return out;
}

}  // namespace pl
