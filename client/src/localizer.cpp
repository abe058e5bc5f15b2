#include "pl/client/localizer.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "pl/common/error.hpp"
#include "pl/common/pose.hpp"
#include "pl/common/stats.hpp"

namespace pl::client {
namespace {

double now_ms() {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

void push_window(std::vector<double>& w, double value, std::size_t size = 20) {
  w.push_back(value);
  if (w.size() > size) w.erase(w.begin());
}

}  // namespace

const char* health_name(Health h) {
  switch (h) {
    case Health::Ok: return "ok";
    case Health::Degraded: return "degraded";
    case Health::Lost: return "lost";
  }
  return "?";
}

std::vector<Eigen::Vector3f> to_points(const Scan& scan) {
  std::vector<Eigen::Vector3f> out;
  out.reserve(scan.size());
  for (const auto& p : scan) out.emplace_back(p.x, p.y, p.z);
  return out;
}

Localizer::Localizer(const LocalizerConfig& cfg, double tile_size, TileProvider tiles)
    : cfg_(cfg), tile_size_(tile_size), tiles_(std::move(tiles)), fusion_(cfg.fusion) {
  if (!tiles_) throw Error("localizer: no tile provider");
}

Localizer::~Localizer() = default;

void Localizer::start(const Eigen::Isometry3d& pose, double t, const OdometryBuffer* odometry) {
  fusion_.reset(pose, t, odometry);
  unfused_streak_ = 0;
  lost_ = false;
  recent_share_.clear();
  recent_rms_.clear();
  if (!map_ || (pose.translation() - map_->anchor()).head<2>().norm() > 5000.0)
    map_ = std::make_unique<RoiMap>(tile_size_, pose.translation(), cfg_.map);
  update_map(pose.translation().head<2>());
}

void Localizer::update_map(const Eigen::Vector2d& center) {
  if (!map_) map_ = std::make_unique<RoiMap>(tile_size_, Eigen::Vector3d(center.x(), center.y(), 0.0), cfg_.map);
  map_->update(tiles_(center, cfg_.roi_radius_m));
}

ScanReport Localizer::process(double t, const Scan& scan, const std::vector<std::uint16_t>& rings) {
  const double t0 = now_ms();
  const Scan prepared = prepare_scan(scan, rings, cfg_.scan);
  const double prep = now_ms() - t0;
  ScanReport r = process_prepared(t, to_points(prepared));
  r.prepare_ms = prep;
  return r;
}

ScanReport Localizer::process_prepared(double t, const std::vector<Eigen::Vector3f>& points) {
  if (!fusion_.initialized()) throw Error("localizer: process() before start()");
  ScanReport r = register_at(t, points, fusion_.predict(t));
  fuse(r);
  return r;
}

ScanReport Localizer::register_at(double t, const std::vector<Eigen::Vector3f>& points, const Eigen::Isometry3d& predicted) {
  if (!map_) throw Error("localizer: register_at() before start()");
  ScanReport r;
  r.t = t;
  r.scan_points = points.size();
  r.predicted = predicted;

  double t0 = now_ms();
  update_map(r.predicted.translation().head<2>());
  r.map_ms = now_ms() - t0;
  r.map_tiles = map_->tiles();
  r.map_points = map_->points();

  t0 = now_ms();
  r.icp = registration::register_scan(map_->points_map(), points, r.predicted, cfg_.icp);
  r.register_ms = now_ms() - t0;
  for (int i = 0; i < 3; ++i) r.position_sigma[i] = std::sqrt(std::max(0.0, r.icp.covariance(i, i)));
  return r;
}

void Localizer::fuse(ScanReport& r) {
  if (!fusion_.initialized()) throw Error("localizer: fuse() before start()");
  const double t = r.t;

  // Health. The divergence detector does not rest on one score: it needs a large correction
  // together with a fall in the share of paired points or a rise of the residual against their
  // recent medians -- or a run of scans that could not be fused.
  const Eigen::Isometry3d delta = r.predicted.inverse() * r.icp.pose;
  const double corr_m = delta.translation().norm();
  const double corr_deg = rotation_angle(delta) * 180.0 / M_PI;
  const bool big_correction = corr_m > cfg_.max_correction_m || corr_deg > cfg_.max_correction_deg;
  const bool share_fell = recent_share_.size() >= 5 && r.icp.inlier_share < 0.5 * median(recent_share_);
  const bool rms_rose = recent_rms_.size() >= 5 && r.icp.rms_m > 2.0 * median(recent_rms_);
  r.diverging = big_correction && (share_fell || rms_rose || !r.icp.accepted);
  r.map_outdated = r.icp.accepted && (1.0 - r.icp.inlier_share) > cfg_.outdated_share;

  const bool take = r.icp.accepted && (!big_correction || lost_);
  if (take) {
    r.fused = fusion_.correct(t, r.icp.pose);
    r.fused_lidar = true;
    unfused_streak_ = 0;
    lost_ = false;
    push_window(recent_share_, r.icp.inlier_share);
    push_window(recent_rms_, r.icp.rms_m);
  } else {
    fusion_.coast(t);
    r.fused = fusion_.predict(t);
    ++unfused_streak_;
    r.note = r.icp.accepted ? "correction too large" : r.icp.reject_reason;
  }
  if (r.diverging || unfused_streak_ >= cfg_.lost_after) lost_ = true;
  if (lost_) {
    r.health = Health::Lost;
    if (r.note.empty()) r.note = r.diverging ? "diverging" : "too many scans not fused";
  } else if (!r.fused_lidar || r.map_outdated) {
    r.health = Health::Degraded;
    if (r.note.empty()) r.note = "map looks outdated";
  }
}

bool Localizer::start_near(const Eigen::Isometry3d& guess, double t, const OdometryBuffer* odometry, const Scan& scan,
                           const std::vector<std::uint16_t>& rings, const registration::PoseSearch& search) {
  start(guess, t, odometry);
  const std::vector<Eigen::Vector3f> points = to_points(prepare_scan(scan, rings, cfg_.scan));
  // The seeds find their basin on the same tiles in 2 m cells.
  RoiMapConfig coarse_cfg;
  coarse_cfg.cell_m = 2.0;
  RoiMap coarse(tile_size_, guess.translation(), coarse_cfg);
  coarse.update(tiles_(guess.translation().head<2>(), cfg_.roi_radius_m));
  Eigen::Isometry3d found;
  if (!registration::search_pose(coarse.points_map(), map_->points_map(), points, guess, search, cfg_.icp, found)) return false;
  start(found, t, odometry);
  return true;
}

}  // namespace pl::client
