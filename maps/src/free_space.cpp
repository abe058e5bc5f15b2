// The free-space filter (see the header). The merged points go into a PointMap for the rays and into
// two indexes of their own: by voxel (a crossed MapPoint back to its merged point) and by column (the
// corridor). Per walked scan: its returns marked on the voxel grid (the confirmation rule), the scan
// thinned to one return per ray voxel, and each return's ray walked.
#include "pl/maps/free_space.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numeric>
#include <string>

#include "pl/common/error.hpp"
#include "pl/common/scan.hpp"
#include "pl/registration/cell_table.hpp"

namespace pl::maps {

namespace {

// Voxel indices relative to a base voxel, packed for CellTable (21 bits each: +-2^20 voxels round
// the map's anchor, 200 km at 0.2 m); false when out of that range.
constexpr std::int64_t kReach = (std::int64_t{1} << 20) - 2;
bool in_reach(const VoxelIndex& v) {
  return std::abs(v[0]) < kReach && std::abs(v[1]) < kReach && std::abs(v[2]) < kReach;
}
VoxelIndex relative(const VoxelIndex& v, const VoxelIndex& base) { return {v[0] - base[0], v[1] - base[1], v[2] - base[2]}; }
std::uint64_t pack(const VoxelIndex& v) { return registration::pack_cell(v[0], v[1], v[2]); }

struct Span {
  std::uint32_t begin = 0, count = 0;
};

}  // namespace

void FreeSpaceConfig::validate() const {
  auto need = [](bool ok, const char* what) {
    if (!ok) throw Error(std::string("free space: ") + what);
  };
  need(min_range_m >= 0 && max_range_m > min_range_m && max_range_m <= 500,
       "the ranges must be 0 <= min_range_m < max_range_m <= 500 m");
  need(ray_voxel_m >= 0.05 && ray_voxel_m <= 10, "ray_voxel_m must be within 0.05..10 m");
  need(min_travel_m >= 0 && min_travel_m <= 100, "min_travel_m must be within 0..100 m");
  need(min_passes >= 1, "min_passes must be 1 or more (0 would remove every point)");
  need(pass_share >= 0 && pass_share <= 1, "pass_share must be within 0..1");
  need(confirm_voxels >= 0 && confirm_voxels <= 5, "confirm_voxels must be within 0..5");
  need(corridor_m >= 0 && corridor_m <= 5, "corridor_m must be within 0..5 m");
  need(corridor_below_m >= 0 && corridor_below_m <= 10, "corridor_below_m must be within 0..10 m");
  need(corridor_above_m >= 0 && corridor_above_m <= 10, "corridor_above_m must be within 0..10 m");
  need(max_corridor_step_m > 0 && max_corridor_step_m <= 1000, "max_corridor_step_m must be within (0, 1000] m");
  need(sky_range_m >= 0 && sky_range_m <= 500, "sky_range_m must be within 0..500 m");
  need(sky_min_elevation_deg >= -90 && sky_min_elevation_deg <= 90, "sky_min_elevation_deg must be within -90..90 deg");
  need(sky_bin_deg >= 0.05 && sky_bin_deg <= 45, "sky_bin_deg must be within 0.05..45 deg");
  need(sky_start_m >= 0 && sky_start_m <= 500, "sky_start_m must be within 0..500 m");
  need(sky_near_deg >= 0 && sky_near_deg <= 5, "sky_near_deg must be within 0..5 deg");
  ray.validate();
}

struct FreeSpaceFilter::Impl {
  FreeSpaceConfig cfg;
  double voxel = 0, inv_voxel = 0, inv_ray_voxel = 0, column = 0;
  Points3d points;
  std::vector<std::uint32_t> seen, passes;
  std::vector<std::uint32_t> checked;  // per point: the last scan that judged a crossing of it
  std::vector<std::uint8_t> corridor;  // per point: in the vehicle's corridor
  std::unique_ptr<registration::PointMap> map;
  VoxelIndex base{}, ray_base{};
  registration::CellTable<std::uint32_t> by_voxel;   // relative voxel -> point index
  registration::CellTable<std::uint32_t> returned;   // relative voxel -> the last scan that returned from it
  registration::CellTable<std::uint32_t> thinned;    // relative ray voxel -> the last scan that took a return there
  registration::CellTable<Span> columns;             // column -> its points' span in `in_column`
  std::vector<std::uint32_t> in_column;
  struct Return {
    Eigen::Vector3d at, from;
  };
  std::vector<Return> returns;
  std::vector<double> beams;          // this drive's beam elevations (rad), ascending
  std::size_t first_sky = 0;          // beams[first_sky..] are the sky rays' beams
  std::vector<std::uint8_t> occupied;  // per sky beam and azimuth bin: a return this scan
  // Per point: the last scan that returned from its voxel, crossings since then, and crossings
  // between two scans that returned from it (those do not count).
  std::vector<std::uint32_t> last_seen, pending, interleaved;
  registration::CellBlock block;
  bool have_last = false, have_walked = false;
  Eigen::Vector3d last = Eigen::Vector3d::Zero(), walked_at = Eigen::Vector3d::Zero();
  std::uint32_t scan = 0;  // walked scans so far (the stamps)
  FreeSpaceReport report;

  std::uint64_t column_key(double x, double y) const {
    return registration::pack_cell(static_cast<std::int64_t>(std::floor(x / column)), static_cast<std::int64_t>(std::floor(y / column)), 0);
  }
  // The rule: crossed by min_passes scans or more, and by pass_share of those that returned from it.
  bool by_rays(std::size_t i) const {
    const std::uint32_t n = passes[i] - interleaved[i];
    return n >= cfg.min_passes && n >= cfg.pass_share * seen[i];
  }
  void mark_corridor(const Eigen::Vector3d& a, const Eigen::Vector3d& b);
  void walk(const Pose& sensor, const std::vector<Eigen::Vector3f>& pts, const std::vector<Eigen::Vector3f>& origins);
};

FreeSpaceFilter::FreeSpaceFilter(const Points3d& points, const std::vector<Eigen::Vector3f>& normals,
                                 const std::vector<std::uint32_t>& seen, double voxel_m, const FreeSpaceConfig& cfg)
    : impl_(std::make_unique<Impl>()) {
  cfg.validate();
  if (normals.size() != points.size() || seen.size() != points.size())
    throw Error("free space: " + std::to_string(normals.size()) + " normals and " + std::to_string(seen.size()) + " seen counts for " +
                std::to_string(points.size()) + " points; give one of each per point");
  if (!(voxel_m >= 0.02 && voxel_m <= 5)) throw Error("free space: voxel_m must be within 0.02..5 m (the merged map's voxel)");
  if (points.size() >= UINT32_MAX) throw Error("free space: more than 4 billion points; filter the map in parts");
  Impl& m = *impl_;
  m.cfg = cfg;
  m.last_seen.assign(points.size(), 0);
  m.pending.assign(points.size(), 0);
  m.interleaved.assign(points.size(), 0);
  m.voxel = voxel_m;
  m.inv_voxel = 1.0 / voxel_m;
  m.inv_ray_voxel = 1.0 / cfg.ray_voxel_m;
  m.column = std::max(1.0, cfg.corridor_m);
  m.points = points;
  m.seen = seen;
  m.passes.assign(points.size(), 0);
  m.checked.assign(points.size(), 0);
  m.corridor.assign(points.size(), 0);
  m.report.points = points.size();

  // The anchor: the middle of the map in whole metres (float offsets stay small).
  Eigen::Vector3d anchor = Eigen::Vector3d::Zero();
  if (!points.empty()) {
    Eigen::Vector3d lo = points[0], hi = points[0];
    for (const Eigen::Vector3d& p : points) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
    anchor = ((lo + hi) * 0.5).array().round().matrix();
  }
  // Cells of twice the pass radius: the nearest point within it is then exact.
  m.map = std::make_unique<registration::PointMap>(anchor, std::max(0.5, 2 * cfg.ray.pass_radius_m));
  m.map->add(0, points, normals);
  m.base = voxel_index(anchor, m.inv_voxel);
  m.ray_base = voxel_index(anchor, m.inv_ray_voxel);

  // A merged point's voxel as a crossing will name it: from its float offset, as the PointMap holds it.
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3f off = (points[i] - anchor).cast<float>();
    const VoxelIndex v = relative(voxel_index(anchor + off.cast<double>(), m.inv_voxel), m.base);
    if (!in_reach(v)) continue;
    bool fresh;
    m.by_voxel.insert(pack(v), static_cast<std::uint32_t>(i), fresh);  // two in one voxel: the first answers
  }

  // Columns for the corridor: point indices sorted by column.
  std::vector<std::uint64_t> keys(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) keys[i] = m.column_key(points[i].x(), points[i].y());
  m.in_column.resize(points.size());
  std::iota(m.in_column.begin(), m.in_column.end(), 0u);
  std::stable_sort(m.in_column.begin(), m.in_column.end(), [&](std::uint32_t a, std::uint32_t b) { return keys[a] < keys[b]; });
  for (std::size_t k = 0; k < m.in_column.size();) {
    std::size_t e = k + 1;
    while (e < m.in_column.size() && keys[m.in_column[e]] == keys[m.in_column[k]]) ++e;
    bool fresh;
    m.columns.insert(keys[m.in_column[k]], Span{static_cast<std::uint32_t>(k), static_cast<std::uint32_t>(e - k)}, fresh);
    k = e;
  }
}

FreeSpaceFilter::~FreeSpaceFilter() = default;

void FreeSpaceFilter::begin_drive(const std::vector<double>& beams_deg) {
  Impl& m = *impl_;
  m.have_last = false;
  m.have_walked = false;
  m.beams.clear();
  for (const double b : beams_deg) m.beams.push_back(b * M_PI / 180.0);
  std::sort(m.beams.begin(), m.beams.end());
  const double min_sky = m.cfg.sky_min_elevation_deg * M_PI / 180.0;
  m.first_sky = static_cast<std::size_t>(std::lower_bound(m.beams.begin(), m.beams.end(), min_sky - 1e-9) - m.beams.begin());
}

// The map points within corridor_m (horizontally) of the sensor's path from a to b, between
// corridor_below_m below it and corridor_above_m above it.
void FreeSpaceFilter::Impl::mark_corridor(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  const double r = cfg.corridor_m;
  if (r <= 0) return;
  const Eigen::Vector2d a2 = a.head<2>(), ab = b.head<2>() - a2;
  const double len2 = ab.squaredNorm();
  const std::int64_t x0 = static_cast<std::int64_t>(std::floor((std::min(a.x(), b.x()) - r) / column)),
                     x1 = static_cast<std::int64_t>(std::floor((std::max(a.x(), b.x()) + r) / column)),
                     y0 = static_cast<std::int64_t>(std::floor((std::min(a.y(), b.y()) - r) / column)),
                     y1 = static_cast<std::int64_t>(std::floor((std::max(a.y(), b.y()) + r) / column));
  for (std::int64_t cx = x0; cx <= x1; ++cx)
    for (std::int64_t cy = y0; cy <= y1; ++cy) {
      const Span* span = columns.find(registration::pack_cell(cx, cy, 0));
      if (!span) continue;
      for (std::uint32_t k = span->begin; k < span->begin + span->count; ++k) {
        const std::uint32_t i = in_column[k];
        const Eigen::Vector3d& p = points[i];
        const double t = len2 > 0 ? std::clamp((p.head<2>() - a2).dot(ab) / len2, 0.0, 1.0) : 0.0;
        if ((a2 + t * ab - p.head<2>()).squaredNorm() > r * r) continue;
        const double z = a.z() + t * (b.z() - a.z());
        if (p.z() >= z - cfg.corridor_below_m && p.z() <= z + cfg.corridor_above_m) corridor[i] = 1;
      }
    }
}

// One scan's rays: every map point they cross, counted once per scan unless the scan returned from
// within a voxel of it.
void FreeSpaceFilter::Impl::walk(const Pose& sensor, const std::vector<Eigen::Vector3f>& pts, const std::vector<Eigen::Vector3f>& origins) {
  const std::uint32_t stamp = ++scan;
  const Eigen::Vector3d origin = sensor.translation();
  const double r0 = cfg.min_range_m * cfg.min_range_m, r1 = cfg.max_range_m * cfg.max_range_m;
  // Returns beyond max_range_m by a little still confirm the points the farthest rays cross.
  const double rc = (cfg.max_range_m + 2 * voxel) * (cfg.max_range_m + 2 * voxel);
  returns.clear();
  // The stamps make old entries harmless; dropping them now and then bounds the memory over a drive.
  if (returned.size() > (std::size_t{1} << 22)) returned = {};
  if (thinned.size() > (std::size_t{1} << 21)) thinned = {};
  bool fresh;
  for (std::size_t i = 0; i < pts.size(); ++i) {
    const double r2 = static_cast<double>(pts[i].squaredNorm());
    if (!(r2 <= rc)) continue;
    const Eigen::Vector3d q = sensor * pts[i].cast<double>();
    const VoxelIndex v = relative(voxel_index(q, inv_voxel), base);
    if (!in_reach(v)) continue;
    *returned.insert(pack(v), stamp, fresh) = stamp;
    if (const std::uint32_t* p = by_voxel.find(pack(v)); p && last_seen[*p] != stamp) {
      if (last_seen[*p] != 0) interleaved[*p] += pending[*p];
      pending[*p] = 0;
      last_seen[*p] = stamp;
    }
    if (!(r2 >= r0 && r2 <= r1)) continue;
    const VoxelIndex t = relative(voxel_index(q, inv_ray_voxel), ray_base);
    if (!in_reach(t)) continue;
    std::uint32_t* at = thinned.insert(pack(t), stamp, fresh);
    if (!fresh && *at == stamp) continue;
    *at = stamp;
    returns.push_back({q, origins.empty() ? origin : sensor * origins[i].cast<double>()});
  }

  auto crossed = [&](const registration::MapPoint&, const Eigen::Vector3d& mp) {
    const VoxelIndex v = relative(voxel_index(mp, inv_voxel), base);
    if (!in_reach(v)) return;
    const std::uint32_t* found = by_voxel.find(pack(v));
    if (!found) return;
    const std::uint32_t i = *found;
    if (checked[i] == stamp) return;  // judged for this scan already
    checked[i] = stamp;
    const int c = cfg.confirm_voxels;
    for (int dx = -c; dx <= c; ++dx)
      for (int dy = -c; dy <= c; ++dy)
        for (int dz = -c; dz <= c; ++dz) {
          const std::uint32_t* s = returned.find(registration::pack_cell(v[0] + dx, v[1] + dy, v[2] + dz));
          if (s && *s == stamp) return;  // this scan returned from next to it: still there
        }
    ++passes[i];
    ++pending[i];
  };
  for (const Return& ret : returns) registration::walk_ray(*map, ret.from, ret.at, cfg.ray, block, crossed);
  report.rays += returns.size();

  // The sky rays: each sky beam's azimuth bins without a return.
  if (cfg.sky_range_m > 0 && first_sky < beams.size()) {
    const std::size_t sky = beams.size() - first_sky;
    const int bins = std::max(1, static_cast<int>(std::lround(360.0 / cfg.sky_bin_deg)));
    const double bin = 2 * M_PI / bins;
    occupied.assign((sky + 1) * bins, 0);
    for (const Eigen::Vector3f& p : pts) {
      const std::size_t k = nearest_angle(beams, elevation_of(p.x(), p.y(), p.z()));  // the point's beam
      if (k + 1 < first_sky) continue;
      const double az = std::atan2(static_cast<double>(p.y()), static_cast<double>(p.x())) + M_PI;
      const int b = std::min(bins - 1, static_cast<int>(az / bin));
      occupied[(k + 1 - first_sky) * bins + b] = 1;
    }
    registration::RayCrossingConfig ray = cfg.ray;
    ray.start_m = cfg.sky_start_m;
    // Nothing returned along a sky ray: a map point within sky_near_deg of it is crossed whatever
    // its normal (a truck's roof or side, which the ray only grazes).
    const Eigen::Vector3d anchor = map->anchor();
    const float pass2 = static_cast<float>(cfg.ray.pass_radius_m * cfg.ray.pass_radius_m);
    const double near = std::tan(cfg.sky_near_deg * M_PI / 180.0);
    Eigen::Vector3d dir = Eigen::Vector3d::UnitX();
    auto probe = [&](const Eigen::Vector3d& x, double s) {
      if (near <= 0) return true;
      const registration::Neighbour nb = map->nearest((x - anchor).cast<float>(), pass2, block);
      if (!nb.point) return true;
      const Eigen::Vector3d mp = anchor + nb.point->p.cast<double>(), off = mp - x;
      const double along = off.dot(dir), tol = (s + along) * near;
      if ((off - along * dir).squaredNorm() <= tol * tol) crossed(*nb.point, mp);
      return true;
    };
    for (std::size_t k = 0; k < sky; ++k) {
      const double el = beams[first_sky + k], ce = std::cos(el), se = std::sin(el);
      for (int b = 0; b < bins; ++b) {
        bool free = true;  // this bin, its two neighbours, and the same three of the beam below
        for (int dk = 0; dk <= 1 && free; ++dk)
          for (int db = -1; db <= 1 && free; ++db) free = !occupied[(k + dk) * bins + (b + db + bins) % bins];
        if (!free) continue;
        const double az = (b + 0.5) * bin - M_PI;
        const Eigen::Vector3d d(ce * std::cos(az), ce * std::sin(az), se);
        dir = sensor.linear() * d;
        registration::walk_ray(*map, origin, sensor * (cfg.sky_range_m * d), ray, block, probe, crossed);
        ++report.rays, ++report.sky_rays;
      }
    }
  }
  ++report.walked;
}

void FreeSpaceFilter::add_scan(const Pose& sensor, const std::vector<Eigen::Vector3f>& points, const std::vector<Eigen::Vector3f>& origins) {
  if (!origins.empty() && origins.size() != points.size())
    throw Error("free space: " + std::to_string(origins.size()) + " origins for " + std::to_string(points.size()) +
                " points; give none or one per point");
  Impl& m = *impl_;
  const auto t0 = std::chrono::steady_clock::now();
  const Eigen::Vector3d at = sensor.translation();
  const bool joined = m.have_last && (at - m.last).norm() <= m.cfg.max_corridor_step_m;
  m.mark_corridor(joined ? m.last : at, at);
  m.have_last = true;
  m.last = at;
  ++m.report.scans;
  if (!m.have_walked || (at - m.walked_at).norm() >= m.cfg.min_travel_m) {
    m.have_walked = true;
    m.walked_at = at;
    m.walk(sensor, points, origins);
  }
  m.report.ms += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

const std::vector<std::uint32_t>& FreeSpaceFilter::passes() const { return impl_->passes; }

std::vector<bool> FreeSpaceFilter::moving() const {
  const Impl& m = *impl_;
  std::vector<bool> out(m.points.size(), false);
  for (std::size_t i = 0; i < out.size(); ++i) out[i] = m.by_rays(i) || m.corridor[i];
  return out;
}

FreeSpaceReport FreeSpaceFilter::report() const {
  const Impl& m = *impl_;
  FreeSpaceReport r = m.report;
  r.passed = r.removed_by_rays = r.removed_by_corridor = 0;
  for (std::size_t i = 0; i < m.points.size(); ++i) {
    if (m.passes[i] > 0) ++r.passed;
    if (m.by_rays(i))
      ++r.removed_by_rays;
    else if (m.corridor[i])
      ++r.removed_by_corridor;
  }
  return r;
}

}  // namespace pl::maps
