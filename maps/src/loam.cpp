// LOAM-style odometry: ring features, a local feature map in voxel hashes, point-to-line and
// point-to-plane Gauss-Newton. See loam.hpp for the outline.
//
// Registration parameters: a step (v, w) moves a transformed point q = R s + t (map frame, relative to
// the anchor) to q + w x (R s) + v, i.e. the rotation turns about the sensor, which keeps the normal
// matrix well conditioned however far the sensor is from the anchor.
#include "pl/maps/loam.hpp"


#include <algorithm>
#include <chrono>
#include <cmath>
#include <future>
#include <numeric>
#include <string>

#include "pl/common/error.hpp"
#include "pl/common/pose.hpp"
#include "pl/registration/cell_table.hpp"
#include "pl/registration/gauss_newton.hpp"
#include "pl/registration/motion.hpp"
#include "pl/registration/normals.hpp"

namespace pl::maps {
namespace {

using Mat6 = Eigen::Matrix<double, 6, 6>;
using Vec6 = Eigen::Matrix<double, 6, 1>;
using registration::cell_coordinate;
using registration::pack_cell;

// Keeps the first point of every leaf (a real return, not a blend of two surfaces), in input order.
void thin(std::vector<Eigen::Vector3f>& pts, double leaf) {
  if (!(leaf > 0) || pts.empty()) return;
  const float inv = static_cast<float>(1.0 / leaf);
  registration::CellTable<std::uint8_t> seen;
  std::size_t out = 0;
  for (std::size_t i = 0; i < pts.size(); ++i) {
    const Eigen::Vector3f& p = pts[i];
    bool fresh;
    seen.insert(pack_cell(cell_coordinate(p.x(), inv), cell_coordinate(p.y(), inv), cell_coordinate(p.z(), inv)), 1, fresh);
    if (fresh) pts[out++] = p;
  }
  pts.resize(out);
}

// Points of one feature kind in the map frame (relative to the anchor), in cells of `cell` metres,
// at most one point per `leaf` within a cell and `cap` points per cell. A cell's points sit together
// in one pool (no allocation per cell); pruned cells' slots are reused.
class FeatureGrid {
 public:
  FeatureGrid(double cell, double leaf, int cap)
      : inv_(static_cast<float>(1.0 / cell)), cell_(static_cast<float>(cell)), leaf2_(static_cast<float>(leaf * leaf)),
        cap_(static_cast<std::uint32_t>(std::clamp(cap, 1, 255))) {}

  void insert(const Eigen::Vector3f& p) {
    const auto ix = cell_coordinate(p.x(), inv_), iy = cell_coordinate(p.y(), inv_), iz = cell_coordinate(p.z(), inv_);
    const std::uint32_t next = free_.empty() ? static_cast<std::uint32_t>(count_.size()) : free_.back();
    bool fresh;
    const std::uint32_t c = *table_.insert(pack_cell(ix, iy, iz), next, fresh);
    if (fresh) {
      if (free_.empty()) {
        count_.push_back(0);
        centre_.emplace_back();
        pool_.resize(pool_.size() + cap_);
      } else {
        free_.pop_back();
      }
      count_[c] = 0;
      centre_[c] = Eigen::Vector2f((static_cast<float>(ix) + 0.5f) * cell_, (static_cast<float>(iy) + 0.5f) * cell_);
    }
    std::uint8_t& n = count_[c];
    if (n >= cap_) return;
    const Eigen::Vector3f* pts = &pool_[static_cast<std::size_t>(c) * cap_];
    for (std::uint32_t i = 0; i < n; ++i)
      if ((pts[i] - p).squaredNorm() < leaf2_) return;
    pool_[static_cast<std::size_t>(c) * cap_ + n] = p;
    ++n;
    ++size_;
  }

  // Drops the cells whose centre lies farther than `radius` from `at` in the xy plane.
  void prune(const Eigen::Vector3f& at, float radius) {
    const float r2 = radius * radius;
    std::vector<std::uint64_t> gone;
    table_.for_each([&](std::uint64_t key, std::uint32_t c) {
      if ((centre_[c] - at.head<2>()).squaredNorm() > r2) gone.push_back(key);
    });
    for (std::uint64_t key : gone) {
      const std::uint32_t c = *table_.find(key);
      size_ -= count_[c];
      count_[c] = 0;
      free_.push_back(c);
      table_.erase(key);
    }
  }

  // Up to 5 nearest points to q within sqrt(max_d2), from the 8 cells nearest q (exact within half a
  // cell). Returns how many were found, nearest first. A cell is skipped when its box lies no nearer
  // than the fifth point found so far: most queries then read two or three cells, not eight.
  int nearest5(const Eigen::Vector3f& q, float max_d2, Eigen::Vector3f out[5]) const {
    float d2s[5];
    int n = 0;
    const float fx = q.x() * inv_, fy = q.y() * inv_, fz = q.z() * inv_;
    const float flx = std::floor(fx), fly = std::floor(fy), flz = std::floor(fz);
    const auto ix = static_cast<std::int64_t>(flx), iy = static_cast<std::int64_t>(fly), iz = static_cast<std::int64_t>(flz);
    const float ux = fx - flx, uy = fy - fly, uz = fz - flz;
    const std::int64_t sx = ux < 0.5f ? -1 : 1, sy = uy < 0.5f ? -1 : 1, sz = uz < 0.5f ? -1 : 1;
    // Squared distance from q to the shared face along each axis (slightly shrunk against rounding).
    const float c2 = cell_ * cell_ * 0.9999f;
    const float bx = (sx < 0 ? ux : 1 - ux), by = (sy < 0 ? uy : 1 - uy), bz = (sz < 0 ? uz : 1 - uz);
    const float ax = bx * bx * c2, ay = by * by * c2, az = bz * bz * c2;
    std::uint64_t keys[8];
    for (int k = 0; k < 8; ++k) {
      keys[k] = pack_cell(ix + ((k & 1) ? sx : 0), iy + ((k & 2) ? sy : 0), iz + ((k & 4) ? sz : 0));
      table_.prefetch(keys[k]);
    }
    for (int k = 0; k < 8; ++k) {
      const float box = ((k & 1) ? ax : 0.0f) + ((k & 2) ? ay : 0.0f) + ((k & 4) ? az : 0.0f);
      if (box >= max_d2 || (n == 5 && box >= d2s[4])) continue;
      const std::uint32_t* found = table_.find(keys[k]);
      if (!found) continue;
      const std::uint32_t c = *found;
      const Eigen::Vector3f* pts = &pool_[static_cast<std::size_t>(c) * cap_];
      for (std::uint32_t i = 0, m = count_[c]; i < m; ++i) {
        const float d2 = (pts[i] - q).squaredNorm();
        if (d2 >= max_d2 || (n == 5 && d2 >= d2s[4])) continue;
        int j = n < 5 ? n++ : 4;
        while (j > 0 && d2s[j - 1] > d2) {
          d2s[j] = d2s[j - 1];
          out[j] = out[j - 1];
          --j;
        }
        d2s[j] = d2;
        out[j] = pts[i];
      }
    }
    return n;
  }

  std::size_t size() const { return size_; }

 private:
  float inv_, cell_, leaf2_;
  std::uint32_t cap_;
  std::size_t size_ = 0;
  registration::CellTable<std::uint32_t> table_;
  std::vector<std::uint8_t> count_;     // points in each cell slot
  std::vector<Eigen::Vector2f> centre_;  // xy centre of each cell slot
  std::vector<Eigen::Vector3f> pool_;   // cap_ points a slot
  std::vector<std::uint32_t> free_;     // slots of pruned cells
};

// A scan feature (sensor frame) paired with its line or plane in the map.
struct Match {
  Eigen::Vector3f s;
  registration::FeatureTarget target;
};

// Normal equations of the matches at (R, t), Cauchy-weighted, pairs beyond max_res dropped.
registration::NormalEquations accumulate(const std::vector<Match>& matches, const Eigen::Matrix3f& R, const Eigen::Vector3f& t,
                                         float k2, float max_res2) {
  registration::NormalEquations out;
  for (const Match& m : matches) {
    const Eigen::Vector3f qr = R * m.s;
    const Eigen::Vector3f q = qr + t;
    const registration::FeatureTarget& f = m.target;
    float r[2], e2 = 0;
    for (int i = 0; i < f.rows; ++i) {
      r[i] = f.n[i].dot(q) + f.d[i];
      e2 += r[i] * r[i];
    }
    if (e2 > max_res2) continue;
    const float w = registration::cauchy_weight(e2, k2);
    for (int i = 0; i < f.rows; ++i) out.add(f.n[i], qr, r[i], w);
  }
  return out;
}

}  // namespace

// An edge pick suppresses its ring neighbours up to the first gap longer than this (squared, m^2):
// across a gap the next point belongs to another surface and may be an edge of its own.
constexpr float kSuppressGap2 = 0.05f;

LoamFeatures extract_loam_features(const Scan& scan, const std::vector<std::uint16_t>& rings, const LoamConfig& cfg) {
  if (rings.size() != scan.size())
    throw Error("LOAM features need one ring per point: " + std::to_string(rings.size()) + " rings for " + std::to_string(scan.size()) + " points");
  LoamFeatures out;
  const int k = std::max(1, cfg.curvature_neighbours);
  const float min2 = static_cast<float>(cfg.min_range_m * cfg.min_range_m), max2 = static_cast<float>(cfg.max_range_m * cfg.max_range_m);

  // Valid points grouped by ring (counting sort), scan order kept within each ring.
  std::size_t nrings = 0;
  std::vector<std::uint8_t> valid(scan.size(), 0);
  for (std::size_t i = 0; i < scan.size(); ++i) {
    const PointXYZI& p = scan[i];
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) continue;
    const float r2 = p.x * p.x + p.y * p.y + p.z * p.z;
    if (r2 < min2 || r2 >= max2) continue;
    valid[i] = 1;
    nrings = std::max<std::size_t>(nrings, rings[i] + 1u);
  }
  std::vector<std::uint32_t> start(nrings + 1, 0);
  for (std::size_t i = 0; i < scan.size(); ++i)
    if (valid[i]) ++start[rings[i] + 1u];
  std::partial_sum(start.begin(), start.end(), start.begin());
  std::vector<std::uint32_t> order(start.back()), fill(start.begin(), start.end() - 1);
  for (std::size_t i = 0; i < scan.size(); ++i)
    if (valid[i]) order[fill[rings[i]]++] = static_cast<std::uint32_t>(i);

  const float edge_c = static_cast<float>(cfg.edge_curvature), plane_c = static_cast<float>(cfg.plane_curvature);
  const float occl = static_cast<float>(cfg.occlusion_ratio), graze2 = static_cast<float>(cfg.grazing_ratio * cfg.grazing_ratio);
  const int sectors = std::max(1, cfg.sectors);
  std::vector<Eigen::Vector3f> pts;
  std::vector<float> range, curv;
  std::vector<std::uint8_t> usable, taken;
  std::vector<int> cand;
  for (std::size_t r = 0; r < nrings; ++r) {
    const int n = static_cast<int>(start[r + 1] - start[r]);
    if (n < 2 * k + 1) continue;
    pts.resize(n);
    range.resize(n);
    for (int i = 0; i < n; ++i) {
      const PointXYZI& p = scan[order[start[r] + i]];
      pts[i] = Eigen::Vector3f(p.x, p.y, p.z);
      range[i] = pts[i].norm();
    }
    curv.assign(n, 0.0f);
    usable.assign(n, 0);
    taken.assign(n, 0);
    for (int i = k; i < n - k; ++i) {
      Eigen::Vector3f s = Eigen::Vector3f::Zero();
      for (int j = 1; j <= k; ++j) s += pts[i - j] + pts[i + j];
      curv[i] = (s - static_cast<float>(2 * k) * pts[i]).squaredNorm();
      usable[i] = 1;
    }
    // Occlusion boundaries: across a range jump, the farther side borders a shadow; its points look
    // sharp but move with the viewpoint.
    for (int i = 0; i + 1 < n; ++i) {
      const float a = range[i], b = range[i + 1];
      if (std::abs(a - b) <= occl * std::min(a, b)) continue;
      if (a > b) {
        for (int j = std::max(0, i - k); j <= i; ++j) usable[j] = 0;
      } else {
        for (int j = i + 1; j <= std::min(n - 1, i + 1 + k); ++j) usable[j] = 0;
      }
    }
    // Surfaces seen nearly edge-on: long gaps to both neighbours.
    for (int i = 1; i + 1 < n; ++i) {
      const float lim = graze2 * range[i] * range[i];
      if ((pts[i + 1] - pts[i]).squaredNorm() > lim && (pts[i] - pts[i - 1]).squaredNorm() > lim) usable[i] = 0;
    }
    for (int s = 0; s < sectors; ++s) {
      const int b = k + (n - 2 * k) * s / sectors, e = k + (n - 2 * k) * (s + 1) / sectors;
      // Edges: sharpest first; each pick suppresses its close ring neighbours.
      cand.clear();
      for (int i = b; i < e; ++i)
        if (usable[i] && curv[i] > edge_c) cand.push_back(i);
      std::sort(cand.begin(), cand.end(), [&](int x, int y) { return curv[x] > curv[y] || (curv[x] == curv[y] && x < y); });
      int picked = 0;
      for (int i : cand) {
        if (picked >= cfg.max_edges_per_sector) break;
        if (taken[i]) continue;
        out.edges.push_back(pts[i]);
        ++picked;
        taken[i] = 1;
        for (int j = 1; j <= k && i + j < n; ++j) {
          if ((pts[i + j] - pts[i + j - 1]).squaredNorm() > kSuppressGap2) break;
          taken[i + j] = 1;
        }
        for (int j = 1; j <= k && i - j >= 0; ++j) {
          if ((pts[i - j] - pts[i - j + 1]).squaredNorm() > kSuppressGap2) break;
          taken[i - j] = 1;
        }
      }
      // Planes: the flattest, up to the cap.
      cand.clear();
      for (int i = b; i < e; ++i)
        if (usable[i] && !taken[i] && curv[i] < plane_c) cand.push_back(i);
      const std::size_t cap = static_cast<std::size_t>(std::max(0, cfg.max_planes_per_sector));
      if (cand.size() > cap) {
        std::nth_element(cand.begin(), cand.begin() + static_cast<std::ptrdiff_t>(cap), cand.end(),
                         [&](int x, int y) { return curv[x] < curv[y] || (curv[x] == curv[y] && x < y); });
        cand.resize(cap);
      }
      for (int i : cand) out.planes.push_back(pts[i]);
    }
  }
  thin(out.edges, cfg.edge_voxel_m);
  thin(out.planes, cfg.plane_voxel_m);
  // Time within the sweep: counter-clockwise from straight ahead (-0.5 just past the back on the
  // right, 0 ahead, +0.5 back on the left).
  auto times = [](const std::vector<Eigen::Vector3f>& pts, std::vector<float>& t) {
    t.resize(pts.size());
    for (std::size_t i = 0; i < pts.size(); ++i) t[i] = registration::sweep_share_from_azimuth(pts[i]);
  };
  times(out.edges, out.edge_time);
  times(out.planes, out.plane_time);
  return out;
}

struct LoamOdometry::Impl {
  LoamConfig cfg;
  FeatureGrid edges, planes;
  Pose start = Pose::Identity();
  Eigen::Vector3d anchor = Eigen::Vector3d::Zero();
  Pose last = Pose::Identity(), prev = Pose::Identity(), keyframe = Pose::Identity();
  double t_last = 0, t_prev = 0;
  std::size_t scans = 0;
  std::vector<Match> matches;
  std::vector<std::vector<Match>> parts;  // one a search thread
  std::vector<int> part_edges;            // the edges among each part's pairs

  explicit Impl(const LoamConfig& c)
      : cfg(c), edges(c.map_cell_m, c.edge_voxel_m, c.map_points_per_cell), planes(c.map_cell_m, c.plane_voxel_m, c.map_points_per_cell) {}

  Pose predict(double t) const {
    if (scans == 0) return start;
    if (scans == 1) return last;
    const double dt = t_last - t_prev;
    const double f = dt > 0 ? (t - t_last) / dt : 1.0;
    return last * scale_motion(prev.inverse() * last, f);
  }

  void add_to_map(const LoamFeatures& f, const Pose& pose) {
    const Eigen::Matrix3f R = pose.linear().cast<float>();
    const Eigen::Vector3f t = (pose.translation() - anchor).cast<float>();
    for (const auto& p : f.edges) edges.insert(R * p + t);
    for (const auto& p : f.planes) planes.insert(R * p + t);
    const float radius = static_cast<float>(cfg.map_radius_m);
    edges.prune(t, radius);
    planes.prune(t, radius);
    keyframe = pose;
  }

  // Pairs every feature with its line or plane in the map at (R, t). Returns edges and planes matched.
  // The features are cut into cfg.threads runs searched at once; the pairs keep the features' order.
  std::pair<int, int> match(const LoamFeatures& f, const Eigen::Matrix3f& R, const Eigen::Vector3f& t) {
    const std::size_t n = f.edges.size() + f.planes.size();
    const std::size_t runs = std::min<std::size_t>(static_cast<std::size_t>(cfg.threads), std::max<std::size_t>(1, n / 512));
    parts.resize(runs);
    part_edges.assign(runs, 0);
    const auto search = [&](std::size_t k) {
      const std::size_t b = n * k / runs, e = n * (k + 1) / runs;
      const float max_d2 = static_cast<float>(cfg.max_neighbour_m * cfg.max_neighbour_m);
      Eigen::Vector3f nb[5];
      Match m;
      parts[k].clear();
      for (std::size_t i = b; i < e; ++i) {
        const bool edge = i < f.edges.size();
        const Eigen::Vector3f& s = edge ? f.edges[i] : f.planes[i - f.edges.size()];
        const bool fitted = edge ? edges.nearest5(R * s + t, max_d2, nb) == 5 && registration::fit_line(nb, 5, cfg.line_ratio, m.target)
                                 : planes.nearest5(R * s + t, max_d2, nb) == 5 && registration::fit_plane(nb, 5, cfg.plane_fit_m, m.target);
        if (!fitted) continue;
        m.s = s;
        part_edges[k] += edge;
        parts[k].push_back(m);
      }
    };
    std::vector<std::future<void>> others;
    for (std::size_t k = 1; k < runs; ++k) others.push_back(std::async(std::launch::async, search, k));
    search(0);
    for (auto& o : others) o.get();
    matches.clear();
    int ne = 0;
    for (std::size_t k = 0; k < runs; ++k) {
      matches.insert(matches.end(), parts[k].begin(), parts[k].end());
      ne += part_edges[k];
    }
    return {ne, static_cast<int>(matches.size()) - ne};
  }
};

namespace {
const LoamConfig& checked(const LoamConfig& cfg) {
  if (!(cfg.map_cell_m > 0) || !(cfg.edge_voxel_m >= 0) || !(cfg.plane_voxel_m >= 0) || !(cfg.kernel_m > 0))
    throw Error("LOAM: the map cell and the kernel must be positive, the voxel sizes not negative");
  if (cfg.threads < 1) throw Error("LOAM: threads must be at least 1, not " + std::to_string(cfg.threads));
  return cfg;
}
}  // namespace

LoamOdometry::LoamOdometry(const LoamConfig& cfg) : impl_(std::make_unique<Impl>(checked(cfg))) {}

LoamOdometry::~LoamOdometry() = default;

void LoamOdometry::start(const Pose& first_pose) {
  if (impl_->scans > 0) throw Error("LOAM: start() must come before the first scan");
  impl_->start = first_pose;
}

std::size_t LoamOdometry::map_edges() const { return impl_->edges.size(); }
std::size_t LoamOdometry::map_planes() const { return impl_->planes.size(); }
const LoamConfig& LoamOdometry::config() const { return impl_->cfg; }

LoamFrame LoamOdometry::add(const Scan& scan, const std::vector<std::uint16_t>& rings, double t) {
  const auto t0 = std::chrono::steady_clock::now();
  LoamFrame out = add(extract_loam_features(scan, rings, impl_->cfg), t);
  out.ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  return out;
}

LoamFrame LoamOdometry::add(LoamFeatures f, double t) {
  const auto t0 = std::chrono::steady_clock::now();
  Impl& m = *impl_;
  const LoamConfig& cfg = m.cfg;
  LoamFrame out;
  out.pose = m.predict(t);

  // Motion over one sweep from the motion since the last scan (at constant velocity), applied to
  // each feature at its own time.
  const double dt = t - m.t_last;
  const auto sweep_of = [&](const Pose& pose) { return scale_motion(m.last.inverse() * pose, dt > 0 ? cfg.scan_period_s / dt : 0.0); };
  const bool deskew = cfg.deskew && m.scans > 0;
  const LoamFeatures raw = deskew ? f : LoamFeatures{};
  const auto deskew_features = [&](const Pose& sweep) {
    registration::compensate_motion(f.edges, sweep, f.edge_time);
    registration::compensate_motion(f.planes, sweep, f.plane_time);
  };
  Pose sweep = Pose::Identity();
  if (deskew) {
    sweep = sweep_of(out.pose);  // from the prediction
    deskew_features(sweep);
  }

  if (m.scans == 0) {
    m.anchor = out.pose.translation();
    m.add_to_map(f, out.pose);
    out.keyframe = true;
    out.edges = static_cast<int>(f.edges.size());
    out.planes = static_cast<int>(f.planes.size());
    out.degenerate = f.edges.size() + f.planes.size() < static_cast<std::size_t>(cfg.min_correspondences);
  } else {
    const float k2 = static_cast<float>(cfg.kernel_m * cfg.kernel_m), max_res2 = static_cast<float>(cfg.max_residual_m * cfg.max_residual_m);
    bool degenerate = true, matched = false;
    // Gauss-Newton with re-matching from `start`; the solution in R, tr (relative to the anchor).
    Eigen::Matrix3d R;
    Eigen::Vector3d tr;
    const auto solve = [&](const Pose& start) {
      R = start.linear();
      tr = start.translation() - m.anchor;
      matched = false;
      for (int outer = 0; outer < std::max(1, cfg.max_rematches); ++outer) {
        auto [ne, np] = m.match(f, R.cast<float>(), tr.cast<float>());
        out.edges = ne;
        out.planes = np;
        if (ne + np < cfg.min_correspondences) {
          matched = false;
          break;
        }
        matched = true;
        const Eigen::Matrix3d R_before = R;
        const Eigen::Vector3d t_before = tr;
        for (int it = 0; it < std::max(1, cfg.iterations_per_match); ++it) {
          registration::NormalEquations n = accumulate(m.matches, R.cast<float>(), tr.cast<float>(), k2, max_res2);
          if (n.rows() < cfg.min_correspondences) break;
          const Vec6 step = registration::solve_step_truncated(n.H(), n.g(), cfg.degenerate_ratio, degenerate);
          if (!step.allFinite()) break;
          R = rotation_from_vector(step.tail<3>()) * R;
          tr += step.head<3>();
          ++out.iterations;
          if (step.head<3>().norm() < cfg.converged_m && step.tail<3>().norm() < cfg.converged_rad) break;
        }
        // Pairs found again after a move this small would be (nearly) the same: done.
        const double moved = (tr - t_before).norm(), turned = Eigen::AngleAxisd(R * R_before.transpose()).angle();
        if (moved < cfg.rematch_m && turned < cfg.rematch_rad) break;
      }
      Eigen::Quaterniond q(R);
      q.normalize();
      Pose p = Pose::Identity();
      p.linear() = q.toRotationMatrix();
      p.translation() = tr + m.anchor;
      return p;
    };
    Pose solved = solve(out.pose);
    // Where the motion changes (a turn begins or ends) the prediction's sweep is not the one the
    // scan was taken over: deskew again with the motion the registration found, and solve from there.
    if (deskew && matched) {
      const Pose measured = sweep_of(solved);
      const Pose change = sweep.inverse() * measured;
      if (change.translation().norm() > cfg.redeskew_m || rotation_angle(change) > cfg.redeskew_deg * M_PI / 180.0) {
        f = raw;
        deskew_features(measured);
        solved = solve(solved);
      }
    }
    // Once the velocity is known, a solution far from the prediction is a wrong match (a view blocked
    // by a passing truck, say), not the vehicle's motion.
    if (matched && m.scans >= 2 && cfg.max_correction_m > 0) {
      const Pose correction = out.pose.inverse() * solved;
      if (correction.translation().norm() > cfg.max_correction_m || rotation_angle(correction) > cfg.max_correction_deg * M_PI / 180.0)
        matched = false;
    }
    if (matched) {
      out.pose = solved;
      registration::NormalEquations n = accumulate(m.matches, solved.linear().cast<float>(), tr.cast<float>(), k2, max_res2);
      Mat6 A = Mat6::Zero();
      A.block<3, 3>(0, 0) = solved.linear();
      A.block<3, 3>(3, 3) = solved.linear();
      const Mat6 info = A.transpose() * n.H() * A;
      out.information = 0.5 * (info + info.transpose());  // exactly symmetric (float sums are not)
      registration::solve_step_truncated(n.H(), n.g(), cfg.degenerate_ratio, degenerate);
      out.degenerate = degenerate;
    } else {
      out.degenerate = true;  // the prediction is kept, with no information, and stays out of the map
    }
    const Pose rel = m.keyframe.inverse() * out.pose;
    const bool far_enough = rel.translation().norm() >= cfg.keyframe_m || rotation_angle(rel) >= cfg.keyframe_deg * M_PI / 180.0;
    if ((matched && far_enough) || m.edges.size() + m.planes.size() == 0) {
      m.add_to_map(f, out.pose);
      out.keyframe = true;
    }
  }
  m.prev = m.last;
  m.t_prev = m.t_last;
  m.last = out.pose;
  m.t_last = t;
  ++m.scans;
  out.ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  return out;
}

}  // namespace pl::maps
