#include "pl/client/localizer.hpp"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <limits>

#include "localizer_geometry.hpp"
#include "pl/client/config_fields.hpp"
#include "pl/common/error.hpp"
#include "pl/common/pose.hpp"
#include "pl/common/stats.hpp"
#include "pl/registration/motion.hpp"

namespace pl::client {
namespace {

// The most steps a sweep grid may take from 0 to its maximum (each step is a whole registration).
constexpr double kMaxSweepGrid = 100.0;

double now_ms() {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

void push_window(std::vector<double>& w, double value, std::size_t size) {
  w.push_back(value);
  if (w.size() > size) w.erase(w.begin());
}

// sigma grown by an independent error g.
void add_sigma(double& s, double g) { s = std::sqrt(s * s + g * g); }

}  // namespace

const char* health_name(Health h) {
  switch (h) {
    case Health::Ok: return "ok";
    case Health::Degraded: return "degraded";
    case Health::Lost: return "lost";
  }
  return "?";
}

const char* basin_name(Basin b) {
  switch (b) {
    case Basin::Fine: return "fine";
    case Basin::Coarse: return "coarse";
    case Basin::Search: return "search";
  }
  return "?";
}

Localizer::Localizer(const LocalizerConfig& cfg, double tile_size, TileProvider tiles)
    : cfg_(cfg), tile_size_(tile_size), tiles_(std::move(tiles)), fusion_(cfg.fusion), odometry_(cfg.odometry) {
  if (!tiles_) throw Error("localizer: no tile provider");
  check_localizer_config(cfg_);
  // Each setting's own range is checked above (the grid steps > 0 among them); here the two together.
  const MotionConfig& m = cfg_.motion;
  if (m.max_speed_mps / m.sweep_speed_step_mps > kMaxSweepGrid || m.max_yaw_rate_dps / m.sweep_yaw_rate_step_dps > kMaxSweepGrid)
    throw Error("localizer: the sweep search's grids (localizer/motion/max_speed_mps over sweep_speed_step_mps, max_yaw_rate_dps "
                "over sweep_yaw_rate_step_dps) must each be at most " +
                std::to_string(static_cast<int>(kMaxSweepGrid)) + " steps from 0 to its maximum (a larger step)");
}

Localizer::~Localizer() = default;

void Localizer::start(const Eigen::Isometry3d& pose, double t, const OdometryBuffer* odometry) {
  fusion_.reset(pose, t, odometry);
  unfused_streak_ = 0;
  lost_ = false;
  recent_share_.clear();
  recent_rms_.clear();
  odometry_.reset();
  posterior_ = {cfg_.motion.fix_floor_m, cfg_.motion.fix_floor_m, cfg_.motion.fix_floor_deg * kDeg};
  velocity_known_ = false;
  previous_fused_ = false;
  previous_verified_ = false;
  ambiguity_hold_left_ = 0;
  held_alternative_m_ = 0.0;
  relocalizing_ = false;
  global_ = false;
  have_fix_ = true;  // the start pose, as good as a fix (start_search and start_global say otherwise)
  fix_t_ = t;
  fix_pose_ = pose;
  fix_protection_m_ = cfg_.integrity.map_error_m + 3.0 * cfg_.motion.fix_floor_m;
  last_protection_m_ = fix_protection_m_;
  set_anchor(t, posterior_, false, 0.0);
  last_t_ = t;
  last_pose_ = pose;
  if (!map_ || (pose.translation() - map_->anchor()).head<2>().norm() > 5000.0) {
    map_ = std::make_unique<RoiMap>(tile_size_, pose.translation(), cfg_.map);
    coarse_ = std::make_unique<RoiMap>(tile_size_, pose.translation(), cfg_.coarse_map);
  }
  update_map(pose.translation().head<2>());
}

void Localizer::update_map(const Eigen::Vector2d& center) {
  if (!map_) {
    const Eigen::Vector3d anchor(center.x(), center.y(), 0.0);
    map_ = std::make_unique<RoiMap>(tile_size_, anchor, cfg_.map);
    coarse_ = std::make_unique<RoiMap>(tile_size_, anchor, cfg_.coarse_map);
  }
  load_maps(center, tiles_);
}

void Localizer::load_maps(const Eigen::Vector2d& center, const TileProvider& provider) {
  const std::vector<MapTile> tiles = provider(center, cfg_.roi_radius_m);
  map_->update(tiles);
  coarse_->update(tiles);
  map_center_ = center;
}

void Localizer::set_places(std::shared_ptr<const registration::PlaceIndex> places, TileProvider far_tiles) {
  places_ = std::move(places);
  far_tiles_ = std::move(far_tiles);
}

void Localizer::start_search(const Eigen::Isometry3d& guess, double t, const OdometryBuffer* odometry, double radius_m,
                             double yaw_deg) {
  if (!(radius_m >= 0) || !(yaw_deg >= 0)) throw Error("localizer: a start search needs a radius and a heading range >= 0");
  start(guess, t, odometry);
  relocalizing_ = true;
  have_fix_ = false;
  posterior_ = {std::max(radius_m / 3.0, cfg_.motion.fix_floor_m), std::max(radius_m / 3.0, cfg_.motion.fix_floor_m),
                std::max(yaw_deg / 3.0, cfg_.motion.fix_floor_deg) * kDeg};
  last_protection_m_ = cfg_.integrity.map_error_m + radius_m;
  set_anchor(t, posterior_, false, 0.0);
}

void Localizer::start_global(double t, const OdometryBuffer* odometry) {
  if (!has_places())
    throw Error("localizer: a global start needs the map's places, and this map version has none: rebuild it with pl-map build "
                "and pl-map tile, or start from a pose");
  // The first place is only where the maps begin; the search does not look round it.
  Eigen::Isometry3d at = Eigen::Isometry3d::Identity();
  at.translation() = places_->places().front().position;
  start(at, t, odometry);
  relocalizing_ = true;
  have_fix_ = false;
  global_ = true;
  lost_ = true;
  posterior_ = {cfg_.motion.relocalize_m, cfg_.motion.relocalize_m, M_PI};
  last_protection_m_ = std::numeric_limits<double>::infinity();
  set_anchor(t, posterior_, false, 0.0);
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
  ScanReport r = register_at(t, points, predict(t));
  fuse(r);
  return r;
}

Prediction Localizer::predict(double t) const {
  Prediction p;
  p.pose = fusion_.predict(t);
  p.odometry = fusion_.odometry_covers(t) && fusion_.odometry_covers(last_t_);
  return p;
}

Uncertainty Localizer::grow(double t, const Prediction& p, bool motion_only) const {
  const MotionConfig& m = cfg_.motion;
  Uncertainty u;
  if (p.odometry) {  // external odometry: a random walk per 0.1 s since the last scan
    if (!motion_only) u = posterior_;
    const double steps = std::sqrt(std::max(0.0, t - last_t_) / 0.1);
    add_sigma(u.along, cfg_.fusion.odometry_sigma[0] * steps);
    add_sigma(u.across, cfg_.fusion.odometry_sigma[1] * steps);
    add_sigma(u.yaw, cfg_.fusion.odometry_sigma[5] * steps);
    return u;
  }
  // Momentum from the last scan whose position was measured (a fix, or LiDAR odometry): the velocity
  // then was known to anchor_speed_sigma_, the acceleration since is unknown to accel_sigma; the
  // errors grow with the time since, linearly and quadratically (they do not average out).
  const double T = std::max(0.0, t - anchor_t_);
  const double speed = anchor_speed_sigma_ * T, accel = 0.5 * m.accel_sigma_mps2 * T * T;
  const double turn = anchor_yaw_rate_sigma_ * T + 0.5 * m.yaw_accel_sigma_dps2 * kDeg * T * T;
  if (!motion_only) u = anchor_;
  add_sigma(u.along, std::hypot(speed, accel));
  add_sigma(u.across, std::max(0.15 * speed, 0.5 * accel) + turn * anchor_speed_ * T);
  add_sigma(u.yaw, turn);
  return u;
}

void Localizer::set_anchor(double t, const Uncertainty& u, bool velocity_known, double speed) {
  const MotionConfig& m = cfg_.motion;
  anchor_t_ = t;
  anchor_ = u;
  anchor_speed_ = speed;
  anchor_speed_sigma_ = velocity_known ? m.speed_sigma_mps : m.max_speed_mps / 3.0;
  anchor_yaw_rate_sigma_ = (velocity_known ? m.yaw_rate_sigma_dps : m.max_yaw_rate_dps / 3.0) * kDeg;
}

void Localizer::relocalize(double t, const Uncertainty& u) {
  const MotionConfig& m = cfg_.motion;
  relocalizing_ = true;
  const double reach = m.relocalize_m / 3.0;
  posterior_ = {std::max(reach, u.along), std::max(reach, u.across), std::max(m.relocalize_deg * kDeg / 3.0, u.yaw)};
  set_anchor(t, posterior_, velocity_known_, 0.0);
}

ScanReport Localizer::register_at(double t, const std::vector<Eigen::Vector3f>& scan, const Prediction& prediction) {
  if (!map_) throw Error("localizer: register_at() before start()");
  const MotionConfig& m = cfg_.motion;
  ScanReport r;
  r.t = t;
  r.scan_points = scan.size();
  Uncertainty u = grow(t, prediction);
  Eigen::Isometry3d guess = prediction.pose;
  r.motion = prediction.odometry ? "odometry" : "momentum";

  // The sweep's motion from the prediction: the motion since the last scan at constant velocity.
  scan_ = scan;
  const std::vector<Eigen::Vector3f>& points = scan_;
  const double dt = t - last_t_;
  r.compensated = prediction.compensated;
  const bool compensate = cfg_.compensate_motion && !prediction.compensated && !relocalizing_ && dt > 0 && dt < 1.0;
  if (compensate && (velocity_known_ || prediction.odometry)) {
    registration::compensate_motion(scan_, scale_motion(last_pose_.inverse() * prediction.pose, cfg_.sweep_s / dt));
    r.compensated = true;
  }

  // LiDAR odometry measures the motion where no external odometry does, when the local map's basin
  // reaches the uncertainty of the motion since the last scan. The local map lies where the recent
  // scans were put, so the pose's own uncertainty then does not widen it: gated on that, the odometry
  // stopped after an unconfirmed search at four times drive 0005's speed (2 deg of yaw sigma grown
  // over 0.83 s past the coarse basin), and every later scan searched again.
  double t0 = now_ms();
  const Uncertainty motion = grow(t, prediction, true);
  if (cfg_.lidar_odometry && !prediction.odometry && !odometry_.empty() && 3.0 * motion.horizontal() <= m.coarse_basin_m &&
      3.0 * motion.yaw <= cfg_.odometry.max_yaw_deg * kDeg) {
    const bool wide = 3.0 * motion.horizontal() > m.fine_basin_m || 3.0 * motion.yaw > m.fine_basin_deg * kDeg;
    const double yaw_range_deg = wide ? std::max(3.0 * motion.yaw / kDeg, cfg_.odometry.seed_range_deg) : 0.0;
    registration::IcpResult odo = odometry_.track(points, guess, wide, yaw_range_deg);
    // From the fine basin its increment is held to the motion's uncertainty, as the map's result is
    // to the pose's: there a local map that a kidnapped scan half fitted moved it 2.2 m (3 sigma 0.09
    // m), the next scans' momentum followed that jump, and the search round the coasting pose found
    // an alias. A wide track searched for larger errors (headings beyond 3 sigma among them).
    // The limit is never below odometry_gate_m: a momentum from one interval 0.2 s long is off by more
    // than its Gaussian 3 sigma now and then (drive 0005: 0.51 m against 0.49 m, a right increment).
    if (odo.accepted && !wide &&
        (horizontal_distance(guess, odo.pose) > std::max(3.0 * motion.horizontal() + m.gate_floor_m, m.odometry_gate_m) ||
         turn_between(guess, odo.pose) > 3.0 * motion.yaw + m.gate_floor_deg * kDeg)) {
      odo.accepted = false;
      odo.reject_reason = "the increment lies beyond the motion's uncertainty";
    }
    if (odo.accepted) {
      const double d = horizontal_distance(last_pose_, odo.pose);
      guess = cfg_.odometry.planar ? in_ground_plane(guess, odo.pose) : odo.pose;
      // From a wide basin the increment is as uncertain as half the basin.
      const double step = m.odometry_sigma_m + m.odometry_share * d;
      const double g = wide ? std::max(step, motion.horizontal() / 2.0) : step;
      u = posterior_;
      add_sigma(u.along, g);
      add_sigma(u.across, g);
      add_sigma(u.yaw, m.odometry_sigma_deg * kDeg);
      r.odometry_ok = true;
      r.motion = "lidar odometry";
      // The sweep again, with the motion measured rather than extrapolated: where the motion changes
      // (a turn ending) constant velocity turned the scan by the old yaw rate.
      if (compensate) {
        scan_ = scan;
        registration::compensate_motion(scan_, scale_motion(last_pose_.inverse() * guess, cfg_.sweep_s / dt));
        r.compensated = true;
      }
    }
  }
  r.odometry_ms = now_ms() - t0;
  r.predicted = guess;
  r.uncertainty = u;

  t0 = now_ms();
  update_map(guess.translation().head<2>());
  r.map_ms = now_ms() - t0;
  r.map_tiles = map_->tiles();
  r.map_points = map_->points();

  // The basin the uncertainty asks for.
  t0 = now_ms();
  const double r3 = 3.0 * u.horizontal(), y3 = 3.0 * u.yaw / kDeg;
  std::vector<registration::Candidate> alternatives;
  if (r3 <= m.fine_basin_m && y3 <= m.fine_basin_deg) {
    r.basin = Basin::Fine;
    r.icp = registration::register_scan(map_->points_map(), points, guess, cfg_.icp);
  } else if (r3 <= m.coarse_basin_m && y3 <= m.coarse_basin_deg) {
    r.basin = Basin::Coarse;
    r.icp = registration::register_coarse_to_fine(coarse_->points_map(), map_->points_map(), points, guess, cfg_.icp);
  } else {
    r.basin = Basin::Search;
    alternatives = search(points, guess, u, r);
    if (alternatives.empty()) {
      r.icp = registration::register_scan(map_->points_map(), points, guess, cfg_.icp);
    } else {
      r.icp = alternatives.front().icp;
      alternatives.erase(alternatives.begin());
    }
  }
  // No velocity yet (a start, or a search after a jump): the sweep's own distortion tells the motion.
  // A scan compensated for the wrong motion fits the map worse, so the speed and turn rate whose
  // compensated scan registers best are taken, and the scan registered again compensated for them.
  // Drive 0005's first scans (a start turning at 8-13 deg/s) registered as they were ended 0.10-0.31
  // m off on a compensated map; compensated for the true motion 0.02-0.08 m.
  if (r.icp.accepted && cfg_.compensate_motion && m.sweep_points > 0 && !prediction.compensated && !prediction.odometry &&
      (!velocity_known_ || relocalizing_) && !r.compensated) {
    const double t_search = now_ms();
    const Eigen::Isometry3d sweep = sweep_motion(scan, r.icp.pose);
    r.sweep_speed_mps = sweep.translation().x() / cfg_.sweep_s;
    r.sweep_yaw_rate_dps = yaw_of(sweep) / kDeg / cfg_.sweep_s;
    scan_ = scan;
    registration::compensate_motion(scan_, sweep);
    registration::IcpResult again = registration::register_scan(map_->points_map(), points, r.icp.pose, cfg_.icp);
    if (again.accepted) {
      r.icp = again;
      r.compensated = true;
    } else {
      scan_ = scan;
    }
    r.sweep_search_ms = now_ms() - t_search;
  }
  r.register_ms = now_ms() - t0;
  t0 = now_ms();
  check_integrity(points, r, alternatives);
  for (int i = 0; i < 3; ++i) r.position_sigma[i] = std::sqrt(std::max(0.0, r.icp.covariance(i, i)));
  r.integrity_ms = now_ms() - t0;
  return r;
}

Eigen::Isometry3d Localizer::sweep_motion(const std::vector<Eigen::Vector3f>& scan, const Eigen::Isometry3d& guess) const {
  const MotionConfig& m = cfg_.motion;
  // The grids register at most sweep_points of the scan.
  const std::vector<Eigen::Vector3f> sparse = registration::subsample(scan, m.sweep_points);
  std::vector<Eigen::Vector3f> moved;
  const auto sweep_of = [&](double v, double w) {
    Eigen::Isometry3d sweep = Eigen::Isometry3d::Identity();
    sweep.translation().x() = v * cfg_.sweep_s;
    sweep.linear() = Eigen::AngleAxisd(w * kDeg * cfg_.sweep_s, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    return sweep;
  };
  const auto score = [&](double v, double w) {
    moved = sparse;
    registration::compensate_motion(moved, sweep_of(v, w));
    const registration::IcpResult fit = registration::register_scan(map_->points_map(), moved, guess, cfg_.icp);
    return fit.accepted ? registration::registration_score(fit) : 0.0;
  };
  // The best of a grid lo + k step (k = 0..n), refined by a parabola through it and its neighbours;
  // `none` when no value of the grid registers at all.
  const auto best_on = [&](double lo, double step, int n, double none, const std::function<double(double)>& f) {
    std::vector<double> s;
    int best = 0;
    for (int k = 0; k <= n; ++k) {
      s.push_back(f(lo + k * step));
      if (s.back() > s[best]) best = k;
    }
    if (!(s[best] > 0.0)) return none;
    double x = lo + best * step;
    if (best > 0 && best < n) {
      const double denom = s[best - 1] - 2.0 * s[best] + s[best + 1];
      if (denom < 0.0) x += step * std::clamp(0.5 * (s[best - 1] - s[best + 1]) / denom, -0.5, 0.5);
    }
    return x;
  };
  const double ws = m.sweep_yaw_rate_step_dps, vs = m.sweep_speed_step_mps;
  const int wn = static_cast<int>(std::floor(m.max_yaw_rate_dps / ws));
  const int vback = static_cast<int>(std::floor(m.max_speed_mps / 3.0 / vs)), vn = vback + static_cast<int>(std::floor(m.max_speed_mps / vs));
  // The turn first (over a sweep it moves far points most), then the speed at that turn, then the
  // turn again at that speed.
  double w = best_on(-wn * ws, ws, 2 * wn, 0.0, [&](double x) { return score(0.0, x); });
  const double v = best_on(-vback * vs, vs, vn, 0.0, [&](double x) { return score(x, w); });
  w = best_on(w - ws, ws / 2.0, 4, w, [&](double x) { return score(v, x); });
  return sweep_of(v, w);
}

namespace {

// The height, roll and pitch of `registered` where `at` stands (its x, y and heading): carried along
// the plane of the registered pose's x and y axes, so that on a slope a registration a period up the
// street gives the height of the ground under `at`, not its own.
Eigen::Isometry3d vertical_at(const Eigen::Isometry3d& registered, const Eigen::Isometry3d& at) {
  Eigen::Isometry3d out = in_ground_plane(registered, at);
  const Eigen::Vector3d ax = registered.linear().col(0), ay = registered.linear().col(1);
  Eigen::Matrix2d a;
  a << ax.x(), ay.x(), ax.y(), ay.y();
  if (std::abs(a.determinant()) < 0.5) return out;  // tilted beyond 60 deg: no vehicle stands there
  const Eigen::Vector2d step = a.inverse() * (at.translation().head<2>() - registered.translation().head<2>());
  out.translation().z() = registered.translation().z() + step.x() * ax.z() + step.y() * ay.z();
  return out;
}

}  // namespace

void Localizer::fuse(ScanReport& r) {
  if (!fusion_.initialized()) throw Error("localizer: fuse() before start()");
  const MotionConfig& m = cfg_.motion;
  const IntegrityConfig& c = cfg_.integrity;
  const double t = r.t;
  const Uncertainty& u = r.uncertainty;
  const Uncertainty before = posterior_;  // the last scan's

  // The gate: the correction within 3 sigma of the prediction (plus a floor), axis by axis.
  const double dyaw = turn_between(r.predicted, r.icp.pose);
  // A relocalization by the map's places looks at every heading: its heading is not gated.
  const bool any_heading = relocalizing_ && r.place_proposals > 0;
  // The gate's position half (along and across the prediction's heading).
  auto within_gate = [&](const Eigen::Isometry3d& pose) {
    const Eigen::Isometry3d d = r.predicted.inverse() * pose;
    return std::abs(d.translation().x()) <= 3.0 * u.along + m.gate_floor_m && std::abs(d.translation().y()) <= 3.0 * u.across + m.gate_floor_m;
  };
  // With no pose at all (a global start) nothing is gated.
  // Nor is a verified result of a search while lost: the prediction it would be held to is the
  // coasting that lost the vehicle (pl-sim's KITTI 00 LiDAR only at four times the speed: the search
  // found the vehicle 31 m from a coasting prediction whose 3 sigma was 17 m, was gated, and the
  // coasting ran on to 90 m).
  const bool gate = global_ || (relocalizing_ && r.basin == Basin::Search && r.verified) ||
                    (within_gate(r.icp.pose) && (any_heading || dyaw <= 3.0 * u.yaw + m.gate_floor_deg * kDeg));
  r.map_outdated = r.icp.accepted && (1.0 - r.icp.inlier_share) > cfg_.outdated_share;
  // From an uncertain prediction (a coarse basin or a search) only a verified result is fused: that is
  // where wrong minima are. An ambiguous one from a coarse basin is fused when the prediction tells
  // the two apart: the solution within its gate, the alternative beyond it (as the fine basin's
  // results are fused, ambiguous or not, the prediction there being the judge). Its health stays
  // degraded and its bound covers the alternative. On drive 0005 with a 180 deg field of view, the
  // scans of the turn (frames 53-67) were each ambiguous with an alternative 1.0-1.6 m along the
  // street, each correct within the gate and refused, and the coasting drifted to 0.81 m off.
  r.disambiguated = r.ambiguous && r.basin == Basin::Coarse && r.plausible && r.consistent && !r.resolved && within_gate(r.icp.pose) &&
                    !within_gate(r.alternative);
  const bool take = r.icp.accepted && r.plausible && gate && (r.basin == Basin::Fine || r.verified || r.disambiguated);
  r.gated = r.icp.accepted && r.plausible && !gate;
  // A relocalization search that moved the vehicle relocated it: what momentum and the local map
  // knew of the motion belongs to the old place.
  // (With no pose at all, or turned beyond the coarse basin, it relocates however near it lies.)
  const bool relocated = take && relocalizing_ && r.basin == Basin::Search &&
                         (global_ || horizontal_distance(r.predicted, r.icp.pose) > m.lost_m ||
                          dyaw > m.coarse_basin_deg * kDeg);
  if (relocated) {
    fusion_.restart(r.icp.pose, t);
    odometry_.reset();
    previous_fused_ = false;
  }
  if (take) {
    if (r.disambiguated) r.note = "ambiguous: another pose fits about as well, beyond the prediction's uncertainty";
    r.fused = relocated ? r.icp.pose : fusion_.correct(t, r.icp.pose);
    r.fused_lidar = true;
    unfused_streak_ = 0;
    lost_ = false;
    double s = std::max(m.fix_floor_m, r.registration_sigma_m);
    double yaw_s = std::max(m.fix_floor_deg * kDeg, std::sqrt(std::max(0.0, r.icp.covariance(5, 5))));
    if (!r.integrity) {  // not confirmed yet (a search, an ambiguity): the next scan looks wider than the fine basin
      s = std::max(s, 2.0 * m.fine_basin_m / 3.0);
      yaw_s = std::max(yaw_s, 2.0 * m.fine_basin_deg * kDeg / 3.0);
    }
    posterior_ = {s, s, yaw_s};
    // Two fused scans in a row give momentum its velocity; LiDAR odometry measures it. Relocated,
    // it is unknown: the odometry measured this scan against a local map placed where the vehicle
    // was not. Taken as known, with a jump's speed as 0, the next scan was predicted standing still
    // with a 0.5 m uncertainty, 4.4 m from where it was (pl-sim's KITTI 00, every 4th odd scan).
    velocity_known_ = !relocated && (r.odometry_ok || previous_fused_);
    if (r.integrity) {
      push_window(recent_share_, r.icp.inlier_share, static_cast<std::size_t>(c.reference_scans));
      push_window(recent_rms_, r.icp.rms_m, static_cast<std::size_t>(c.reference_scans));
    }
  } else {
    // The measured motion beats momentum, and momentum goes on from it: continued from its own
    // extrapolation over a scan not fused, momentum doubled a braking vehicle's lag (pl-sim's KITTI
    // 00 every 4th odd scan: 3 m off, past every basin, and the vehicle was lost).
    r.fused = r.odometry_ok ? r.predicted : fusion_.predict(t);
    // What is in doubt is where along the ground the scan fits (an alternative along the street, a
    // search to confirm); a plausible registration within the prediction's gate stands on the same
    // ground and measures the height, roll and pitch, which the planar LiDAR odometry leaves to
    // momentum. Coasting on momentum alone, drive 0005 with a 180 deg field of view was 0.77 m off in
    // height after five unfused scans of its 3.6 % descent (0.25 m horizontally).
    // (Not from a search: its candidates may lie streets away, on other ground.)
    if (r.icp.accepted && r.plausible && r.basin != Basin::Search && within_gate(r.icp.pose)) {
      r.fused = vertical_at(r.icp.pose, r.fused);
      r.vertical_from_map = true;
    }
    fusion_.coast(t, r.fused);
    posterior_ = u;
    if (r.odometry_ok) velocity_known_ = true;
    ++unfused_streak_;
    if (r.gated) r.note = "correction beyond the prediction's uncertainty";
    else if (r.note.empty()) r.note = r.icp.accepted ? "not verified" : r.icp.reject_reason;
    r.protection_m = c.map_error_m + 3.0 * std::hypot(u.along, u.across);
    // A result that fits the map but was not taken may be where the vehicle is: the bound covers it.
    if (r.icp.accepted && r.plausible)
      r.protection_m = std::max(r.protection_m, c.map_error_m + c.sigmas * r.registration_sigma_m + horizontal_distance(r.fused, r.icp.pose));
    // A scan not fused learns nothing of where the vehicle stands in the plane: its bound is at least
    // the last scan's, grown by the motion since (3 sigma of the uncertainty it added). The statistical
    // uncertainty alone forgets what the last bound covered besides it (an alternative along the
    // street): driven backwards with a 180 deg field of view, a scan gated after two ambiguous ones
    // had a bound of 1.11 m, half the last, 1.23 m off.
    const double grown = std::sqrt(std::max(0.0, u.horizontal() * u.horizontal() - before.horizontal() * before.horizontal()));
    r.protection_m = std::max(r.protection_m, last_protection_m_ + 3.0 * grown);
  }
  // The local map of the LiDAR odometry: the scan where it was put. A scan that neither the map nor
  // the odometry could place (a jump) starts the local map again.
  if (cfg_.lidar_odometry) {
    if (!take && !r.odometry_ok && !odometry_.empty()) odometry_.reset();
    odometry_.add(scan_, r.fused);
  }
  if (take || r.odometry_ok) {
    const double dt = t - last_t_;
    const double speed = dt > 0 && !relocated ? horizontal_distance(last_pose_, r.fused) / dt : 0.0;
    set_anchor(t, posterior_, velocity_known_, speed);
  }
  last_t_ = t;
  last_pose_ = r.fused;
  previous_fused_ = take;
  previous_verified_ = take && r.verified;
  if (r.ambiguous) {
    ambiguity_hold_left_ = c.ambiguity_hold;
    held_alternative_m_ = r.alternative_m;
  } else if (ambiguity_hold_left_ > 0 && --ambiguity_hold_left_ == 0) {
    held_alternative_m_ = 0.0;
  }

  // A scan neither the map nor the LiDAR odometry could place, fitting the map badly at the
  // prediction: the vehicle may be elsewhere. Search round the last pose from the next scan on.
  if (!take && !r.odometry_ok && (!r.icp.accepted || !r.plausible)) {
    relocalize(t, u);
    lost_ = true;
    r.protection_m = c.map_error_m + m.relocalize_m;
    r.note = "the scan fits neither the map here nor the recent scans: searching " + std::to_string(static_cast<int>(m.relocalize_m)) +
             " m round";
  }
  // Scans that fit worse than the recent ones, twice in a row: search again round the last pose.
  // A scan that fits the map well beyond the prediction's uncertainty: the prediction may be what is
  // wrong (momentum braking late, a missed bend), so the next scan searches a region holding both.
  unverified_streak_ = r.icp.accepted && r.plausible && !r.consistent ? unverified_streak_ + 1 : 0;
  if ((unverified_streak_ >= 2 || (r.gated && r.consistent)) && !relocalizing_) {
    relocalize(t, posterior_);
    unverified_streak_ = 0;
  } else if (take && r.verified) {
    relocalizing_ = false;
    global_ = false;
  }
  // A verified result of a search is the reference the next scans are compared with.
  if (take && r.verified && r.basin == Basin::Search) {
    recent_share_.assign(1, r.icp.inlier_share);
    recent_rms_.assign(1, r.icp.rms_m);
  }
  if (!take && (3.0 * u.horizontal() > m.lost_m || unfused_streak_ >= cfg_.lost_after)) lost_ = true;
  if (global_) {
    lost_ = true;
    r.protection_m = std::numeric_limits<double>::infinity();
    r.note = "no pose yet: searching the whole map by its places";
  }
  // Lost, the error is bounded by physics: the vehicle is at most max_speed_mps times the time since
  // the last ok scan from where that scan put it (within its bound), and the estimate has coasted
  // from there. The uncertainty's 3 sigma alone trusts the momentum that lost it.
  if (lost_ && !global_ && have_fix_)
    r.protection_m = std::max(r.protection_m, fix_protection_m_ + horizontal_distance(r.fused, fix_pose_) +
                                                  m.max_speed_mps * std::max(0.0, t - fix_t_));
  if (!lost_ && take && r.integrity && !r.after_ambiguity) {
    have_fix_ = true;
    fix_t_ = t;
    fix_pose_ = r.fused;
    fix_protection_m_ = r.protection_m;
  }
  last_protection_m_ = r.protection_m;
  if (lost_) {
    r.health = Health::Lost;
    if (r.note.empty()) r.note = "too many scans not fused";
  } else if (!take || !r.integrity || r.after_ambiguity || r.map_outdated || r.protection_m > c.alert_limit_m) {
    r.health = Health::Degraded;
    if (r.note.empty())
      r.note = r.map_outdated ? "map looks outdated" : r.protection_m > c.alert_limit_m ? "protection level above the alert limit" : "not verified";
  }
}

}  // namespace pl::client
