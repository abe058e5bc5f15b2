// Each part keeps its points sorted by cell, so a cell is one contiguous run of one part and a
// lookup touches one table slot.
#include "pl/registration/point_map.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <string>

#include "pl/common/error.hpp"
#include "pl/registration/cell_table.hpp"

namespace pl::registration {

struct PointMap::Part {
  std::vector<MapPoint> points;      // sorted by cell
  std::vector<std::uint64_t> cells;  // the cells this part owns
};

struct Run {
  const MapPoint* begin = nullptr;
  std::uint32_t count = 0;
};

struct PointMap::Cells : CellTable<Run> {};

PointMap::PointMap(const Eigen::Vector3d& anchor, double cell_m)
    : cell_(cell_m), anchor_(anchor), cells_(std::make_unique<Cells>()) {
  if (!(cell_m > 0) || !std::isfinite(cell_m))
    throw Error("point map: the cell size must be positive, got " + std::to_string(cell_m));
  if (!anchor.allFinite()) throw Error("point map: the anchor is not finite");
}

PointMap::~PointMap() = default;

std::size_t PointMap::cells() const { return cells_->size(); }

void PointMap::add(PartId id, const std::vector<Eigen::Vector3d>& pts, const std::vector<Eigen::Vector3f>& normals) {
  if (normals.size() != pts.size())
    throw Error("point map: " + std::to_string(normals.size()) + " normals for " + std::to_string(pts.size()) + " points");
  if (parts_.count(id)) throw Error("point map: part " + std::to_string(id) + " is already held");
  auto part = std::make_unique<Part>();
  const double inv = 1.0 / cell_;
  const std::size_t n = pts.size();
  std::vector<std::uint64_t> keys(n);
  std::vector<std::uint32_t> order(n);
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d d = (pts[i] - anchor_) * inv;
    keys[i] = pack_cell(static_cast<std::int64_t>(std::floor(d.x())), static_cast<std::int64_t>(std::floor(d.y())),
                        static_cast<std::int64_t>(std::floor(d.z())));
  }
  std::iota(order.begin(), order.end(), 0u);
  std::stable_sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) { return keys[a] < keys[b]; });
  part->points.resize(n);
  for (std::size_t k = 0; k < n; ++k) {
    const std::uint32_t i = order[k];
    part->points[k].p = (pts[i] - anchor_).cast<float>();
    part->points[k].n = normals[i];
  }
  for (std::size_t k = 0; k < n;) {
    std::size_t e = k + 1;
    while (e < n && keys[order[e]] == keys[order[k]]) ++e;
    bool fresh;
    cells_->insert(keys[order[k]], Run{part->points.data() + k, static_cast<std::uint32_t>(e - k)}, fresh);
    if (fresh) part->cells.push_back(keys[order[k]]);
    k = e;
  }
  points_ += n;
  parts_[id] = std::move(part);
}

bool PointMap::remove(PartId id) {
  auto it = parts_.find(id);
  if (it == parts_.end()) return false;
  for (std::uint64_t key : it->second->cells) cells_->erase(key);
  points_ -= it->second->points.size();
  parts_.erase(it);
  return true;
}

Neighbour PointMap::nearest(const Eigen::Vector3f& q, float max_dist2) const {
  CellBlock block;
  return nearest(q, max_dist2, block);
}

Neighbour PointMap::nearest(const Eigen::Vector3f& q, float max_dist2, CellBlock& block) const {
  // The 2 x 2 x 2 block of cells nearest to q: on each axis its own cell and the neighbour on q's
  // side. Its own cell first; a neighbour only while its box is nearer than the best point so far.
  const float c = static_cast<float>(cell_);
  const float inv = 1.0f / c;
  std::int64_t base[3], step[3];
  float gap2[3];  // squared distance from q to the face shared with the neighbour, per axis
  std::uint8_t side = 0;
  for (int a = 0; a < 3; ++a) {
    const float u = q[a] * inv;
    const float f = std::floor(u);
    if (!(std::abs(f) < 0x1p62f)) return {};  // not a number, or beyond any cell key: no neighbour
    base[a] = static_cast<std::int64_t>(f);
    const float frac = u - f;
    const bool up = !(frac < 0.5f);  // one flag for the step and the block's key (a NaN goes up in both)
    step[a] = up ? 1 : -1;
    if (up) side |= static_cast<std::uint8_t>(1 << a);
    const float gap = (frac < 0.5f ? frac : 1.0f - frac) * c;
    gap2[a] = gap * gap;
  }
  const std::uint64_t own = pack_cell(base[0], base[1], base[2]);
  if (own != block.own || side != block.side) {
    block.own = own;
    block.side = side;
    block.looked = 0;
  }
  Neighbour best;
  best.dist2 = max_dist2;
  for (int m = 0; m < 8; ++m) {
    const int dx = m & 1, dy = (m >> 1) & 1, dz = (m >> 2) & 1;
    const float box2 = dx * gap2[0] + dy * gap2[1] + dz * gap2[2];
    if (box2 >= best.dist2) continue;
    CellBlock::Span& span = block.cells[m];
    if (!(block.looked & (1 << m))) {
      const Run* s = cells_->find(pack_cell(base[0] + dx * step[0], base[1] + dy * step[1], base[2] + dz * step[2]));
      span = s ? CellBlock::Span{s->begin, s->count} : CellBlock::Span{};
      block.looked |= static_cast<std::uint8_t>(1 << m);
    }
    const MapPoint* p = span.begin;
    for (std::uint32_t k = 0; k < span.count; ++k) {
      const float d2 = (p[k].p - q).squaredNorm();
      if (d2 < best.dist2) {
        best.dist2 = d2;
        best.point = p + k;
      }
    }
  }
  return best;
}

void PointMap::prefetch_points(const CellBlock& block) {
  for (int m = 0; m < 8; ++m)
    if ((block.looked & (1 << m)) && block.cells[m].count) __builtin_prefetch(block.cells[m].begin);
}

std::uint64_t PointMap::cell_of(const Eigen::Vector3f& q) const {
  const float inv = 1.0f / static_cast<float>(cell_);
  return pack_cell(cell_coordinate(q.x(), inv), cell_coordinate(q.y(), inv), cell_coordinate(q.z(), inv));
}

void PointMap::prefetch(const Eigen::Vector3f& q) const { cells_->prefetch(cell_of(q)); }

void PointMap::prefetch_points(const Eigen::Vector3f& q) const {
  if (const Run* r = cells_->find(cell_of(q))) __builtin_prefetch(r->begin);
}

std::vector<MapPoint> PointMap::all_points() const {
  std::vector<MapPoint> out;
  out.reserve(points_);
  for (const auto& [id, part] : parts_) out.insert(out.end(), part->points.begin(), part->points.end());
  return out;
}

}  // namespace pl::registration
