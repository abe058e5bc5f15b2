// The ROI map's voxel hash: an open-addressing table (linear probing, deletion by backward shift)
// from a packed cell index to the run of a tile's points in that cell. Each tile keeps its points
// sorted by cell, so a cell is one contiguous run and a lookup touches one table slot.
#include "pl/client/roi_map.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>

#include "pl/common/error.hpp"

namespace pl::client {
namespace {

constexpr int kBits = 21;  // per axis: +-2^20 cells from the anchor
constexpr std::int64_t kHalf = std::int64_t{1} << (kBits - 1);
constexpr std::uint64_t kEmpty = ~std::uint64_t{0};

inline std::uint64_t pack(std::int64_t x, std::int64_t y, std::int64_t z) {
  return static_cast<std::uint64_t>(x + kHalf) | (static_cast<std::uint64_t>(y + kHalf) << kBits) |
         (static_cast<std::uint64_t>(z + kHalf) << (2 * kBits));
}

inline std::uint64_t mix(std::uint64_t k) {
  k ^= k >> 31;
  k *= 0x7fb5d329728ea185ull;
  k ^= k >> 27;
  k *= 0x81dadef4bc2dd44dull;
  k ^= k >> 33;
  return k;
}

}  // namespace

struct RoiMap::Tile {
  std::string hash;
  std::shared_ptr<const TileCloud> cloud;  // kept so the bytes are not decoded twice by the caller
  std::vector<MapPoint> points;            // sorted by cell
  std::vector<std::uint64_t> cells;        // the cells this tile owns
};

struct RoiMap::Table {
  struct Slot {
    std::uint64_t key = kEmpty;
    const MapPoint* begin = nullptr;
    std::uint32_t count = 0;
  };
  std::vector<Slot> slots;
  std::size_t used = 0, mask = 0;

  Table() { resize(1024); }

  void resize(std::size_t capacity) {
    std::vector<Slot> old = std::move(slots);
    slots.assign(capacity, Slot{});
    mask = capacity - 1;
    used = 0;
    for (const Slot& s : old)
      if (s.key != kEmpty) insert(s.key, s.begin, s.count);
  }

  void insert(std::uint64_t key, const MapPoint* begin, std::uint32_t count) {
    if (2 * (used + 1) > slots.size()) resize(2 * slots.size());
    std::size_t i = mix(key) & mask;
    while (slots[i].key != kEmpty && slots[i].key != key) i = (i + 1) & mask;
    if (slots[i].key == kEmpty) ++used;
    slots[i] = {key, begin, count};
  }

  const Slot* find(std::uint64_t key) const {
    std::size_t i = mix(key) & mask;
    while (true) {
      const Slot& s = slots[i];
      if (s.key == key) return &s;
      if (s.key == kEmpty) return nullptr;
      i = (i + 1) & mask;
    }
  }

  void erase(std::uint64_t key) {
    std::size_t i = mix(key) & mask;
    while (slots[i].key != key) {
      if (slots[i].key == kEmpty) return;
      i = (i + 1) & mask;
    }
    // Backward shift: move later members of the probe run into the hole when their home allows it.
    std::size_t hole = i;
    std::size_t j = i;
    while (true) {
      j = (j + 1) & mask;
      if (slots[j].key == kEmpty) break;
      const std::size_t home = mix(slots[j].key) & mask;
      const bool movable = hole <= j ? (home <= hole || home > j) : (home <= hole && home > j);
      if (movable) {
        slots[hole] = slots[j];
        hole = j;
      }
    }
    slots[hole] = Slot{};
    --used;
  }
};

RoiMap::RoiMap(double tile_size, const Eigen::Vector3d& anchor, const RoiMapConfig& cfg)
    : table_(std::make_unique<Table>()) {
  if (!(tile_size > 0)) throw Error("ROI map: tile size must be positive, got " + std::to_string(tile_size));
  if (!(cfg.cell_m > 0)) throw Error("ROI map: cell_m must be positive, got " + std::to_string(cfg.cell_m));
  const double per_tile = std::max(1.0, std::round(tile_size / cfg.cell_m));
  cell_ = tile_size / per_tile;
  // On the tile grid horizontally (cells never straddle tiles), on the cell grid vertically.
  anchor_ = {std::floor(anchor.x() / tile_size) * tile_size, std::floor(anchor.y() / tile_size) * tile_size,
             std::floor(anchor.z() / cell_) * cell_};
}

RoiMap::~RoiMap() = default;

std::size_t RoiMap::cells() const { return table_->used; }

std::size_t RoiMap::update(const std::vector<TileRef>& tiles) {
  std::map<TileKey, const TileRef*> wanted;
  for (const TileRef& t : tiles)
    if (t.cloud && t.cloud->normals.size() == t.cloud->size()) wanted[t.key] = &t;
  std::size_t changes = 0;
  for (auto it = tiles_.begin(); it != tiles_.end();) {
    auto w = wanted.find(it->first);
    if (w == wanted.end() || w->second->hash != it->second->hash) {
      auto next = std::next(it);
      remove(it);
      it = next;
      ++changes;
    } else {
      ++it;
    }
  }
  for (const auto& [key, ref] : wanted)
    if (!tiles_.count(key)) {
      add(*ref);
      ++changes;
    }
  return changes;
}

void RoiMap::add(const TileRef& ref) {
  auto tile = std::make_unique<Tile>();
  tile->hash = ref.hash;
  tile->cloud = ref.cloud;
  const TileCloud& c = *ref.cloud;
  const double inv = 1.0 / cell_;
  const std::size_t n = c.size();
  std::vector<std::uint64_t> keys(n);
  std::vector<std::uint32_t> order(n);
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d d = (c.points[i] - anchor_) * inv;
    keys[i] = pack(static_cast<std::int64_t>(std::floor(d.x())), static_cast<std::int64_t>(std::floor(d.y())),
                   static_cast<std::int64_t>(std::floor(d.z())));
  }
  std::iota(order.begin(), order.end(), 0u);
  std::sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) { return keys[a] < keys[b]; });
  tile->points.resize(n);
  for (std::size_t k = 0; k < n; ++k) {
    const std::uint32_t i = order[k];
    tile->points[k].p = (c.points[i] - anchor_).cast<float>();
    tile->points[k].n = c.normals[i];
  }
  for (std::size_t k = 0; k < n;) {
    std::size_t e = k + 1;
    while (e < n && keys[order[e]] == keys[order[k]]) ++e;
    const std::uint64_t key = keys[order[k]];
    if (!table_->find(key)) {  // a cell belongs to one tile (points of a bad tile outside its box are dropped)
      table_->insert(key, tile->points.data() + k, static_cast<std::uint32_t>(e - k));
      tile->cells.push_back(key);
    }
    k = e;
  }
  points_ += n;
  tiles_[ref.key] = std::move(tile);
}

void RoiMap::remove(std::map<TileKey, std::unique_ptr<Tile>>::iterator it) {
  for (std::uint64_t key : it->second->cells) table_->erase(key);
  points_ -= it->second->points.size();
  tiles_.erase(it);
}

Neighbour RoiMap::nearest(const Eigen::Vector3f& q, float max_dist2) const {
  // The 2 x 2 x 2 block of cells nearest to q: on each axis its own cell and the neighbour on q's
  // side. Its own cell first; a neighbour only while its box is nearer than the best point so far.
  const float c = static_cast<float>(cell_);
  const float inv = 1.0f / c;
  std::int64_t base[3], step[3];
  float gap2[3];  // squared distance from q to the face shared with the neighbour, per axis
  for (int a = 0; a < 3; ++a) {
    const float u = q[a] * inv;
    const float f = std::floor(u);
    base[a] = static_cast<std::int64_t>(f);
    const float frac = u - f;
    step[a] = frac < 0.5f ? -1 : 1;
    const float gap = (frac < 0.5f ? frac : 1.0f - frac) * c;
    gap2[a] = gap * gap;
  }
  Neighbour best;
  best.dist2 = max_dist2;
  for (int m = 0; m < 8; ++m) {
    const int dx = m & 1, dy = (m >> 1) & 1, dz = (m >> 2) & 1;
    const float box2 = dx * gap2[0] + dy * gap2[1] + dz * gap2[2];
    if (box2 >= best.dist2) continue;
    const Table::Slot* s = table_->find(pack(base[0] + dx * step[0], base[1] + dy * step[1], base[2] + dz * step[2]));
    if (!s) continue;
    const MapPoint* p = s->begin;
    for (std::uint32_t k = 0; k < s->count; ++k) {
      const float d2 = (p[k].p - q).squaredNorm();
      if (d2 < best.dist2) {
        best.dist2 = d2;
        best.point = p + k;
      }
    }
  }
  return best;
}

std::vector<MapPoint> RoiMap::all_points() const {
  std::vector<MapPoint> out;
  out.reserve(points_);
  for (const auto& [key, tile] : tiles_) out.insert(out.end(), tile->points.begin(), tile->points.end());
  return out;
}

}  // namespace pl::client
