// Tile keys: integer (tx, ty) on a square grid in the map's ENU frame. Tile (tx, ty) covers the
// half-open box [tx*size, (tx+1)*size) x [ty*size, (ty+1)*size).
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace pl {

struct TileKey {
  std::int32_t tx = 0;
  std::int32_t ty = 0;
  bool operator==(const TileKey& o) const { return tx == o.tx && ty == o.ty; }
  bool operator!=(const TileKey& o) const { return !(*this == o); }
  bool operator<(const TileKey& o) const { return tx != o.tx ? tx < o.tx : ty < o.ty; }
};

// For unordered containers of keys: both coordinates in one 64-bit word, mixed (splitmix64's
// finalizer) so that neighbouring tiles spread over the buckets.
struct TileKeyHash {
  std::size_t operator()(const TileKey& k) const {
    std::uint64_t x = (std::uint64_t{static_cast<std::uint32_t>(k.tx)} << 32) | static_cast<std::uint32_t>(k.ty);
    x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
    x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
    return static_cast<std::size_t>(x ^ (x >> 31));
  }
};

struct TileBounds {
  double min_x, min_y, max_x, max_y;  // [min, max)
  bool contains(double x, double y) const { return x >= min_x && x < max_x && y >= min_y && y < max_y; }
};

class TileGrid {
 public:
  explicit TileGrid(double tile_size);  // throws pl::Error unless 0 < size
  double tile_size() const { return size_; }
  TileKey key_of(double x, double y) const;
  TileBounds bounds_of(const TileKey& key) const;
  // Every tile whose box has a point within `radius` of (cx, cy), ordered by (tx, ty).
  std::vector<TileKey> keys_in_disc(double cx, double cy, double radius) const;

 private:
  double size_;
};

}  // namespace pl
