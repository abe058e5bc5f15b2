// Change evidence from localized scans (see the header). Per used scan: the scan thinned to one
// return per evidence voxel; each return looked up in the map (added or seen); each return's ray
// walked from the sensor to just short of it, counting the map points it passes through (passed)
// and the added voxels it shows empty now (free).
#include "pl/client/change_evidence.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <string>
#include <tuple>
#include <unordered_map>
#include <unordered_set>

#include "pl/common/error.hpp"
#include "pl/registration/ray_crossing.hpp"

namespace pl::client {

namespace {

// A voxel index packed in 63 bits (21 bits a coordinate, offset to be non-negative): +-1 million
// voxels, +-500 km of map frame at 0.5 m.
constexpr std::int64_t kOffset = 1 << 20;
std::uint64_t pack(std::int64_t x, std::int64_t y, std::int64_t z) {
  return static_cast<std::uint64_t>(x + kOffset) << 42 | static_cast<std::uint64_t>(y + kOffset) << 21 |
         static_cast<std::uint64_t>(z + kOffset);
}
bool in_range(std::int64_t v) { return v > -kOffset && v < kOffset - 1; }

struct Cell {
  std::int32_t x = 0, y = 0, z = 0;
  std::uint32_t added = 0, free = 0, seen = 0, passed = 0;
  std::uint32_t seen_near = 0;  // returns on the map in this voxel and the 26 round it (folded before compaction)
  // The last scan that counted each (a scan counts once per voxel).
  std::uint32_t added_at = 0, free_at = 0, seen_at = 0, passed_at = 0;
  bool evidence() const { return added > 0 || passed > 0; }
};

void count_once(std::uint32_t& count, std::uint32_t& at, std::uint32_t scan) {
  if (at == scan) return;
  at = scan;
  ++count;
}

// Scans whose returns confirmed the map in the voxel or next to it: a ray that passed a map point
// there went by an edge, through leaves or glass, of a thing that is still there.
template <class Cells>
std::uint32_t seen_near(const Cells& cells, const Cell& c) {
  std::uint64_t sum = 0;
  for (int dx = -1; dx <= 1; ++dx)
    for (int dy = -1; dy <= 1; ++dy)
      for (int dz = -1; dz <= 1; ++dz) {
        const auto n = cells.find(pack(c.x + dx, c.y + dy, c.z + dz));
        if (n != cells.end()) sum += n->second.seen;
      }
  return static_cast<std::uint32_t>(std::max<std::uint64_t>(c.seen_near, std::min<std::uint64_t>(sum, UINT32_MAX)));
}

}  // namespace

void ChangeEvidenceConfig::validate() const {
  auto need = [](bool ok, const char* what) {
    if (!ok) throw Error(std::string("change evidence: ") + what);
  };
  need(delta_m > 0 && delta_m <= 5, "delta_m must be within (0, 5] m");
  need(voxel_m >= 0.05 && voxel_m <= 10, "voxel_m must be within 0.05..10 m");
  need(min_range_m >= 0 && max_range_m > min_range_m && max_range_m <= 500, "the ranges must be 0 <= min_range_m < max_range_m <= 500 m");
  need(ray_step_m > 0.01 && ray_step_m <= voxel_m * 4, "ray_step_m must be within 0.01 m .. 4 voxels");
  need(ray_margin_m >= 0, "ray_margin_m must be 0 or more");
  need(pass_radius_m > 0 && pass_radius_m <= 2, "pass_radius_m must be within (0, 2] m");
  need(cross_radius_m > 0 && cross_radius_m <= 2, "cross_radius_m must be within (0, 2] m");
  need(min_incidence >= 0 && min_incidence <= 1, "min_incidence must be within 0..1");
  need(min_travel_m >= 0, "min_travel_m must be 0 or more");
  need(corridor_m >= 0 && corridor_m <= 5, "corridor_m must be within 0..5 m");
  need(max_cells_per_tile >= 1, "max_cells_per_tile must be 1 or more");
  need(sample_m >= 0.02 && sample_m <= voxel_m, "sample_m must be within 0.02 m .. voxel_m");
}

struct ChangeEvidence::Impl {
  std::unordered_map<std::uint64_t, Cell> cells;
  std::unordered_map<TileKey, std::pair<std::uint32_t, std::uint32_t>, TileKeyHash> tiles;  // scans, last scan
  std::unordered_set<std::uint64_t> thinned;  // this scan's voxels
  struct Return {
    Eigen::Vector3d at, from;  // the return and where its ray started (map frame)
    std::uint64_t key;
  };
  std::vector<Return> returns;
  std::size_t compact_at = 1u << 20;
  std::unordered_set<std::uint64_t> swept;  // voxels of the corridor the sensor drove along
  // The added structure's sample (sample_m grid): the returns' sum, and the scans that found it.
  struct Sample {
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    std::uint32_t returns = 0, scans = 0, at = 0;
  };
  std::unordered_map<std::uint64_t, Sample> samples;
  std::vector<std::uint64_t> added_now;  // this scan's added voxels
  std::size_t samples_compact_at = 1u << 20;
  bool have_last = false;
  Eigen::Vector3d last = Eigen::Vector3d::Zero();  // the last evidence scan's sensor position
};

void ChangeEvidence::corridor(const Eigen::Vector3d& from, const Eigen::Vector3d& to) {
  if (cfg_.corridor_m <= 0) return;
  Impl& m = *impl_;
  const double v = cfg_.voxel_m, r = cfg_.corridor_m;
  const Eigen::Vector3d a = m.have_last ? from : to;
  const double length = (to - a).norm();
  const int steps = std::max(1, static_cast<int>(std::ceil(length / (0.5 * v))));
  const int reach = static_cast<int>(std::ceil(r / v));
  for (int k = 0; k <= steps; ++k) {
    const Eigen::Vector3d c = a + (to - a) * (static_cast<double>(k) / steps);
    const std::int64_t cx = static_cast<std::int64_t>(std::floor(c.x() / v)), cy = static_cast<std::int64_t>(std::floor(c.y() / v));
    const std::int64_t z0 = static_cast<std::int64_t>(std::floor((c.z() - 2.2) / v)), z1 = static_cast<std::int64_t>(std::floor((c.z() + 2.5) / v));
    for (std::int64_t x = cx - reach; x <= cx + reach; ++x)
      for (std::int64_t y = cy - reach; y <= cy + reach; ++y) {
        const double dx = (static_cast<double>(x) + 0.5) * v - c.x(), dy = (static_cast<double>(y) + 0.5) * v - c.y();
        if (dx * dx + dy * dy > r * r) continue;
        for (std::int64_t z = z0; z <= z1; ++z)
          if (in_range(x) && in_range(y) && in_range(z)) m.swept.insert(pack(x, y, z));
      }
  }
}

ChangeEvidence::ChangeEvidence(const ChangeEvidenceConfig& cfg, double tile_size)
    : cfg_(cfg), grid_(tile_size), impl_(std::make_unique<Impl>()) {
  cfg_.validate();
}

ChangeEvidence::~ChangeEvidence() = default;

bool ChangeEvidence::add(const Eigen::Isometry3d& sensor_in_map, const std::vector<Eigen::Vector3f>& points,
                         const registration::PointMap& map, const std::vector<Eigen::Vector3f>& origins) {
  if (!origins.empty() && origins.size() != points.size())
    throw Error("ChangeEvidence::add: " + std::to_string(origins.size()) + " origins for " + std::to_string(points.size()) + " points");
  Impl& m = *impl_;
  if (m.have_last && (sensor_in_map.translation() - m.last).norm() < cfg_.min_travel_m) return false;
  const auto t0 = std::chrono::steady_clock::now();
  corridor(m.last, sensor_in_map.translation());
  m.have_last = true;
  m.last = sensor_in_map.translation();
  const std::uint32_t scan = static_cast<std::uint32_t>(++used_);
  const double v = cfg_.voxel_m;
  const Eigen::Vector3d origin = sensor_in_map.translation();
  const Eigen::Vector3d anchor = map.anchor();
  auto voxel = [v](const Eigen::Vector3d& q, std::int64_t& x, std::int64_t& y, std::int64_t& z) {
    x = static_cast<std::int64_t>(std::floor(q.x() / v));
    y = static_cast<std::int64_t>(std::floor(q.y() / v));
    z = static_cast<std::int64_t>(std::floor(q.z() / v));
    return in_range(x) && in_range(y) && in_range(z);
  };
  auto cell_at = [&](std::uint64_t key, std::int64_t x, std::int64_t y, std::int64_t z) -> Cell& {
    auto [it, fresh] = m.cells.try_emplace(key);
    if (fresh) {
      it->second.x = static_cast<std::int32_t>(x);
      it->second.y = static_cast<std::int32_t>(y);
      it->second.z = static_cast<std::int32_t>(z);
    }
    return it->second;
  };

  // The returns, one per voxel, and the tiles they fall in.
  m.thinned.clear();
  m.returns.clear();
  const double r0 = cfg_.min_range_m * cfg_.min_range_m, r1 = cfg_.max_range_m * cfg_.max_range_m;
  // Point i within the ranges: where it lies in the map frame, and its voxel.
  auto in_map = [&](std::size_t i, Eigen::Vector3d& q, std::int64_t& x, std::int64_t& y, std::int64_t& z) {
    const double r2 = static_cast<double>(points[i].squaredNorm());
    if (!(r2 >= r0 && r2 <= r1)) return false;
    q = sensor_in_map * points[i].cast<double>();
    return voxel(q, x, y, z);
  };
  for (std::size_t i = 0; i < points.size(); ++i) {
    Eigen::Vector3d q;
    std::int64_t x, y, z;
    if (!in_map(i, q, x, y, z)) continue;
    const std::uint64_t key = pack(x, y, z);
    if (!m.thinned.insert(key).second) continue;
    m.returns.push_back({q, origins.empty() ? origin : sensor_in_map * origins[i].cast<double>(), key});
    auto& t = m.tiles[grid_.key_of((static_cast<double>(x) + 0.5) * v, (static_cast<double>(y) + 0.5) * v)];
    if (t.second != scan) {
      t.second = scan;
      ++t.first;
    }
  }

  // Added or seen.
  const float delta2 = static_cast<float>(cfg_.delta_m * cfg_.delta_m);
  for (const Impl::Return& ret : m.returns) {
    const Eigen::Vector3d& q = ret.at;
    const registration::Neighbour nb = map.nearest((q - anchor).cast<float>(), delta2);
    std::int64_t x, y, z;
    if (nb.point) {  // the map point it confirms: a ray passing near it elsewhere does not remove it
      if (!voxel(anchor + nb.point->p.cast<double>(), x, y, z)) continue;
      Cell& c = cell_at(pack(x, y, z), x, y, z);
      count_once(c.seen, c.seen_at, scan);
    } else {
      voxel(q, x, y, z);
      Cell& c = cell_at(ret.key, x, y, z);
      if (c.added_at != scan) m.added_now.push_back(ret.key);
      count_once(c.added, c.added_at, scan);
    }
  }

  // The added structure, finer: every return in this scan's added voxels with no map surface within
  // delta, on the sample grid (a voxel's first return decided it added; its others may lie on the map).
  if (!m.added_now.empty()) {
    const std::unordered_set<std::uint64_t> added_now(m.added_now.begin(), m.added_now.end());
    m.added_now.clear();
    const double sv = cfg_.sample_m;
    for (std::size_t i = 0; i < points.size(); ++i) {
      Eigen::Vector3d q;
      std::int64_t x, y, z;
      if (!in_map(i, q, x, y, z) || !added_now.count(pack(x, y, z))) continue;
      if (map.nearest((q - anchor).cast<float>(), delta2).point) continue;
      const std::int64_t sx = static_cast<std::int64_t>(std::floor(q.x() / sv)), sy = static_cast<std::int64_t>(std::floor(q.y() / sv)),
                         sz = static_cast<std::int64_t>(std::floor(q.z() / sv));
      if (!in_range(sx) || !in_range(sy) || !in_range(sz)) continue;
      Impl::Sample& smp = m.samples[pack(sx, sy, sz)];
      smp.sum += q;
      ++smp.returns;
      count_once(smp.scans, smp.at, scan);
    }
  }

  // The rays: map points passed through (pl/registration/ray_crossing.hpp), added voxels now seen empty.
  registration::RayCrossingConfig ray;
  ray.start_m = cfg_.min_range_m;
  ray.step_m = cfg_.ray_step_m;
  ray.margin_m = cfg_.ray_margin_m;
  ray.pass_radius_m = cfg_.pass_radius_m;
  ray.cross_radius_m = cfg_.cross_radius_m;
  ray.min_incidence = cfg_.min_incidence;
  registration::CellBlock block;
  for (const Impl::Return& ret : m.returns) {
    std::uint64_t last_key = ~std::uint64_t{0};
    auto probe = [&](const Eigen::Vector3d& x, double) {
      std::int64_t vx, vy, vz;
      if (!voxel(x, vx, vy, vz)) return false;
      const std::uint64_t here = pack(vx, vy, vz);
      if (here != last_key) {
        last_key = here;
        auto it = m.cells.find(here);
        if (it != m.cells.end() && it->second.added > 0) count_once(it->second.free, it->second.free_at, scan);
      }
      return true;
    };
    auto crossed = [&](const registration::MapPoint&, const Eigen::Vector3d& mp) {
      std::int64_t mx, my, mz;
      if (!voxel(mp, mx, my, mz)) return;
      // A map surface confirmed by a return this scan within a voxel of the point is still there:
      // the ray passed glass, leaves or an edge of it, not a thing that is gone.
      bool confirmed = false;
      for (int dx = -1; dx <= 1 && !confirmed; ++dx)
        for (int dy = -1; dy <= 1 && !confirmed; ++dy)
          for (int dz = -1; dz <= 1 && !confirmed; ++dz) {
            const auto n = m.cells.find(pack(mx + dx, my + dy, mz + dz));
            confirmed = n != m.cells.end() && n->second.seen_at == scan;
          }
      Cell& c = cell_at(pack(mx, my, mz), mx, my, mz);
      if (!confirmed) count_once(c.passed, c.passed_at, scan);
    };
    registration::walk_ray(map, ret.from, ret.at, ray, block, probe, crossed);
  }

  // Bounded memory over a long drive: the voxels with nothing but returns on the map are dropped
  // from tiles the vehicle left (their `seen` then restarts should it come back).
  if (m.cells.size() > m.compact_at) {
    for (auto& [key, c] : m.cells)
      if (c.passed > 0) c.seen_near = seen_near(m.cells, c);
    for (auto it = m.cells.begin(); it != m.cells.end();) {
      const Cell& c = it->second;
      const auto t = m.tiles.find(grid_.key_of((c.x + 0.5) * v, (c.y + 0.5) * v));
      const bool left = t == m.tiles.end() || scan - t->second.second > 50;
      it = !c.evidence() && left ? m.cells.erase(it) : std::next(it);
    }
    m.compact_at = std::max<std::size_t>(1u << 20, 2 * m.cells.size());
  }
  if (m.samples.size() > m.samples_compact_at) {  // a sample one scan saw, of a tile left, will not be reported
    for (auto it = m.samples.begin(); it != m.samples.end();) {
      const Eigen::Vector3d c = it->second.sum / it->second.returns;
      const auto t = m.tiles.find(grid_.key_of(c.x(), c.y()));
      const bool left = t == m.tiles.end() || scan - t->second.second > 50;
      it = it->second.scans < 2 && left ? m.samples.erase(it) : std::next(it);
    }
    m.samples_compact_at = std::max<std::size_t>(1u << 20, 2 * m.samples.size());
  }
  ms_.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
  return true;
}

std::vector<schema::TileChangeEvidence> ChangeEvidence::tiles() const {
  const Impl& m = *impl_;
  const double v = cfg_.voxel_m;
  std::unordered_map<TileKey, std::vector<const Cell*>, TileKeyHash> by_tile;
  std::vector<Cell> kept;  // evidence cells, with what was added in the vehicle's own corridor dropped
  kept.reserve(m.cells.size() / 8);
  for (const auto& [key, c] : m.cells) {
    if (!c.evidence()) continue;
    Cell e = c;
    if (e.added > 0 && m.swept.count(key)) e.added = e.free = 0;
    // One scan's word is not reported: the service's rule needs two or more (pl/maps/change_detect.hpp),
    // and on drive 0005 such voxels were 40 % of a report.
    if (e.added < 2 && e.passed < 2) continue;
    if (e.passed > 0) e.seen = seen_near(m.cells, c);
    kept.push_back(e);
  }
  for (const Cell& c : kept) by_tile[grid_.key_of((c.x + 0.5) * v, (c.y + 0.5) * v)].push_back(&c);
  std::vector<schema::TileChangeEvidence> out;
  out.reserve(m.tiles.size());
  for (const auto& [key, t] : m.tiles) {
    schema::TileChangeEvidence e;
    e.key = key;
    e.scans = t.first;
    auto it = by_tile.find(key);
    if (it != by_tile.end()) {
      std::vector<const Cell*>& cells = it->second;
      if (cells.size() > cfg_.max_cells_per_tile) {  // the most evidence first
        std::nth_element(cells.begin(), cells.begin() + static_cast<std::ptrdiff_t>(cfg_.max_cells_per_tile), cells.end(),
                         [](const Cell* a, const Cell* b) {
                           return std::make_tuple(a->added + a->passed, a->x, a->y, a->z) >
                                  std::make_tuple(b->added + b->passed, b->x, b->y, b->z);
                         });
        cells.resize(cfg_.max_cells_per_tile);
      }
      e.cells.reserve(cells.size());
      for (const Cell* c : cells) e.cells.push_back({c->x, c->y, c->z, c->added, c->free, c->seen, c->passed});
      std::sort(e.cells.begin(), e.cells.end(), [](const schema::ChangeCell& a, const schema::ChangeCell& b) {
        return std::tie(a.x, a.y, a.z) < std::tie(b.x, b.y, b.z);
      });
    }
    out.push_back(std::move(e));
  }
  std::sort(out.begin(), out.end(), [](const auto& a, const auto& b) { return a.key < b.key; });

  // The sample of the added structure: in the voxels reported added, the sample voxels two or more
  // scans found added (one scan's may be a thing passing), as the report's checks want them.
  std::unordered_map<std::uint64_t, std::size_t> added_in;  // reported added voxel -> its tile in `out`
  for (std::size_t i = 0; i < out.size(); ++i)
    for (const schema::ChangeCell& c : out[i].cells)
      if (c.added > 0) added_in.emplace(pack(c.x, c.y, c.z), i);
  std::vector<std::vector<std::pair<std::uint32_t, std::array<std::int32_t, 3>>>> sampled(out.size());
  for (const auto& [key, smp] : m.samples) {
    if (smp.scans < 2) continue;
    const Eigen::Vector3d mean = smp.sum / smp.returns * 100.0;
    if (!(mean.cwiseAbs().maxCoeff() < 2.0e9)) continue;
    const std::array<std::int32_t, 3> cm{static_cast<std::int32_t>(std::lround(mean.x())), static_cast<std::int32_t>(std::lround(mean.y())),
                                         static_cast<std::int32_t>(std::lround(mean.z()))};
    const auto vx = schema::voxel_of_cm(cm, v);
    const auto it = added_in.find(pack(vx[0], vx[1], vx[2]));
    if (it != added_in.end()) sampled[it->second].push_back({smp.scans, cm});
  }
  for (std::size_t i = 0; i < out.size(); ++i) {
    auto& pts = sampled[i];
    if (pts.size() > cfg_.max_points_per_tile) {  // the points most scans saw
      std::nth_element(pts.begin(), pts.begin() + static_cast<std::ptrdiff_t>(cfg_.max_points_per_tile), pts.end(),
                       [](const auto& a, const auto& b) { return std::tie(b.first, a.second) < std::tie(a.first, b.second); });
      pts.resize(cfg_.max_points_per_tile);
    }
    out[i].points.reserve(pts.size());
    for (const auto& [scans, p] : pts) out[i].points.push_back(p);
    std::sort(out[i].points.begin(), out[i].points.end());
    out[i].points.erase(std::unique(out[i].points.begin(), out[i].points.end()), out[i].points.end());
  }
  return out;
}

}  // namespace pl::client
