#include "pl/sim/sensors.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>

#include "pl/common/error.hpp"
#include "pl/common/text.hpp"

namespace pl::sim {

double encoder_resolution(const EncoderConfig& cfg) {
  return 2.0 * M_PI * cfg.wheel_radius / (cfg.teeth * cfg.edges_per_tooth);
}

std::vector<EncoderSample> simulate_encoder(const SimTrajectory& path, double t0, double t1, const EncoderConfig& cfg) {
  std::vector<EncoderSample> out;
  const double dt = 1.0 / cfg.rate_hz, res = encoder_resolution(cfg);
  double left = 0.0, right = 0.0;  // true wheel travel, with scale and slip
  Pose prev = path.pose_at(t0);
  out.push_back({0.0, 0.0, 0.0});
  for (long k = 1;; ++k) {
    double t = t0 + k * dt;
    if (t > t1 + 1e-9) break;
    Pose cur = path.pose_at(t);
    double h0 = yaw_of(prev), h1 = yaw_of(cur);
    double dtheta = std::remainder(h1 - h0, 2.0 * M_PI);
    Eigen::Vector2d d = (cur.translation() - prev.translation()).head<2>();
    double hm = h0 + 0.5 * dtheta;
    double ds = d.x() * std::cos(hm) + d.y() * std::sin(hm);  // signed: reversing counts backwards
    double dl = ds - dtheta * cfg.wheel_base / 2, dr = ds + dtheta * cfg.wheel_base / 2;
    double lateral_acc = std::abs(ds / dt * dtheta / dt);
    double extra = cfg.slip * lateral_acc;  // the outer wheel slips more in a turn
    if (dtheta > 0)
      dr *= 1.0 + extra;
    else
      dl *= 1.0 + extra;
    left += dl * cfg.scale_left;
    right += dr * cfg.scale_right;
    out.push_back({t - t0, std::floor(left / res) * res, std::floor(right / res) * res});
    prev = cur;
  }
  return out;
}

std::vector<GnssProfileEntry> read_gnss_profile(const std::string& dir) {
  std::string data = dir + "/oxts/data";
  if (!dir_exists(data)) data = dir + "/data";
  if (!dir_exists(data))
    throw Error(dir + ": no OXTS records (expected oxts/data/*.txt or data/*.txt; the KITTI OXTS archives in ../shared/data/kitti-oxts expand with unpack.sh)");
  std::vector<std::string> files;
  for (const auto& e : std::filesystem::directory_iterator(data))
    if (e.path().extension() == ".txt") files.push_back(e.path().string());
  std::sort(files.begin(), files.end());
  if (files.empty()) throw Error(data + ": no .txt OXTS records");
  std::vector<GnssProfileEntry> out;
  for (const auto& f : files) {
    LineReader r(f);
    std::string line;
    if (!r.next(line)) r.fail("one line of 30 OXTS values");
    auto v = parse_numbers(r, line, 30, 30, "an OXTS record (30 values)", " \t\r");
    int mode = static_cast<int>(v[27]);
    int status = gps_status_from_oxts(mode);
    out.push_back({v[23], status, static_cast<int>(v[26])});
  }
  return out;
}

double sky_blockage(const World& world, const Eigen::Vector2f& p) {
  constexpr int kSectors = 36;
  bool blocked[kSectors] = {};
  const float kMinElevation = std::tan(40.0f * static_cast<float>(M_PI) / 180.0f);
  for (const WorldObject& o : world.objects) {
    if (o.cls != ObjectClass::Building && o.cls != ObjectClass::Tree) continue;
    Eigen::Vector2f d = o.centre - p;
    float dist = d.norm(), size = o.half.norm();
    if (dist > 60.0f) continue;
    float near = std::max(1.0f, dist - size * 0.7f);
    if (o.height / near < kMinElevation) continue;
    float az = std::atan2(d.y(), d.x()), width = std::atan2(size, std::max(dist, 1.0f));
    for (int k = 0; k < kSectors; ++k) {
      float sa = (k + 0.5f) * 2.0f * static_cast<float>(M_PI) / kSectors;
      if (std::abs(std::remainder(sa - az, 2.0f * static_cast<float>(M_PI))) <= width) blocked[k] = true;
    }
  }
  int n = 0;
  for (bool b : blocked) n += b;
  return static_cast<double>(n) / kSectors;
}

std::vector<GpsFix> simulate_gps(const SimTrajectory& path, double t0, double t1, const World& world, const EnuFrame& enu,
                                 const GpsConfig& cfg, std::mt19937_64& rng) {
  std::normal_distribution<double> n01(0.0, 1.0);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  std::vector<GpsFix> out;
  const double dt = 1.0 / cfg.rate_hz;
  int status = kGpsFixed;
  double dwell = 0.0;             // time in the current status
  double burst_left = 0.0;        // multipath burst still running (s)
  Eigen::Vector2d burst_offset = Eigen::Vector2d::Zero();
  Eigen::Vector3d bias = Eigen::Vector3d::Zero();  // slowly wandering error of float/single fixes
  for (long k = 0;; ++k) {
    double t = t0 + cfg.time_offset + k * dt;
    if (t > t1 + 1e-9) break;
    Pose pose = path.pose_at(t);
    Eigen::Vector3d antenna = pose * cfg.lever_arm;
    double blocked = sky_blockage(world, antenna.head<2>().cast<float>());
    double sigma = cfg.sigma_fixed;
    int want = kGpsFixed;
    bool outage = false;
    if (!cfg.profile.empty()) {
      const auto& e = cfg.profile[std::min<std::size_t>(cfg.profile.size() - 1, static_cast<std::size_t>((t - t0) * 10.0))];
      want = e.status;
      outage = e.status == kGpsNone || e.satellites < 4;
      sigma = std::max(e.std_m, want == kGpsFixed ? cfg.sigma_fixed : cfg.sigma_float * 0.5);
    } else {
      want = blocked < 0.35 ? kGpsFixed : blocked < 0.50 ? kGpsFloat : blocked < 0.62 ? kGpsSingle : kGpsNone;
      outage = want == kGpsNone;
    }
    // Status changes need a second of the new conditions (receivers do not flicker every epoch);
    // getting worse is immediate.
    dwell += dt;
    if (want < status || outage) {
      status = want;
      dwell = 0.0;
    } else if (want > status && dwell > 1.0) {
      status = want;
      dwell = 0.0;
    }
    if (outage || status == kGpsNone) continue;
    if (cfg.profile.empty()) sigma = status == kGpsFixed ? cfg.sigma_fixed : status == kGpsFloat ? cfg.sigma_float : cfg.sigma_single;
    // Float and single fixes wander (correlated error); fixed ones are white at 2 cm.
    double corr = status == kGpsFixed ? 0.0 : 0.95;
    for (int a = 0; a < 3; ++a) bias[a] = corr * bias[a] + std::sqrt(1 - corr * corr) * sigma * n01(rng);
    Eigen::Vector3d err = status == kGpsFixed ? Eigen::Vector3d(sigma * n01(rng), sigma * n01(rng), 2 * sigma * n01(rng)) : bias;
    // Multipath where the sky is blocked (no RTK fix there): metres off for a few seconds, the
    // reported sigma unchanged.
    if (burst_left <= 0.0 && status != kGpsFixed && blocked > 0.3 && u01(rng) < cfg.multipath_rate) {
      burst_left = 1.0 + 2.0 * u01(rng);
      double ang = 2 * M_PI * u01(rng);
      burst_offset = (2.0 + 6.0 * u01(rng)) * Eigen::Vector2d(std::cos(ang), std::sin(ang));
    }
    if (status == kGpsFixed) burst_left = 0.0;  // a fix regained ends the burst
    if (burst_left > 0.0) {
      err.head<2>() += burst_offset;
      burst_left -= dt;
    }
    GpsFix fix;
    fix.t = t - t0;
    fix.position = enu.to_geodetic(antenna + err);
    fix.std_m = sigma;
    fix.status = status;
    out.push_back(fix);
  }
  return out;
}

std::vector<Pose, Eigen::aligned_allocator<Pose>> ins_truth(const std::vector<Pose, Eigen::aligned_allocator<Pose>>& truth,
                                                          const std::vector<double>& times, const TruthErrorConfig& cfg,
                                                          std::uint64_t seed) {
  if (truth.size() != times.size()) throw Error("ins_truth: one time per pose");
  if (!(cfg.scale >= 0) || !std::isfinite(cfg.scale)) throw Error("the truth error scale must be 0 or more");
  if (cfg.scale == 0.0 || truth.empty()) return truth;
  std::mt19937_64 rng(seed * 0xD1B54A32D192ED03ull + 0x7F4A7C15ull);
  std::normal_distribution<double> unit(0.0, 1.0);
  // A smooth wander: a first-order Gauss-Markov process low-passed once more with the same time
  // constant (a critically damped second-order process). An INS's error moves smoothly from scan to
  // scan; a first-order process of the same size moved 8 cm between scans 0.1 s apart along the track.
  struct Wander {
    double sigma, tau, x1 = 0, x2 = 0;  // sigma: of the output (x2), whose variance is half x1's
    void step(double dt, double n) {
      const double a = std::exp(-std::max(0.0, dt) / tau);
      x1 = a * x1 + std::sqrt(2.0) * sigma * std::sqrt(std::max(0.0, 1.0 - a * a)) * n;
      x2 = a * x2 + (1.0 - a) * x1;
    }
  };
  const double k = cfg.scale;
  Wander along{k * cfg.along_m, cfg.along_s}, across{k * cfg.across_m, cfg.across_s}, height{k * cfg.height_m, cfg.height_s},
      heading{k * cfg.heading_deg * M_PI / 180.0, cfg.heading_s};
  for (Wander* w : {&along, &across, &height, &heading})  // from a stationary state: ten time constants run in
    for (int i = 0; i < 200; ++i) w->step(w->tau / 20.0, unit(rng));
  std::vector<Pose, Eigen::aligned_allocator<Pose>> out;
  out.reserve(truth.size());
  double travelled = 0.0;
  for (std::size_t i = 0; i < truth.size(); ++i) {
    if (i) {
      travelled += (truth[i].translation() - truth[i - 1].translation()).head<2>().norm();
      const double dt = times[i] - times[i - 1];
      for (Wander* w : {&along, &across, &height, &heading}) w->step(dt, unit(rng));
    }
    const double jitter = k * cfg.jitter_m * unit(rng);
    const Pose& p = truth[i];
    Eigen::Vector3d fwd = p.linear().col(0);
    fwd.z() = 0.0;
    fwd = fwd.norm() > 1e-9 ? fwd.normalized() : Eigen::Vector3d::UnitX();
    const Eigen::Vector3d left(-fwd.y(), fwd.x(), 0.0);
    Pose q = p;
    q.translation() += (along.x2 + jitter + k * cfg.along_share * travelled) * fwd + across.x2 * left + Eigen::Vector3d(0, 0, height.x2);
    const double jr = k * cfg.attitude_jitter_deg * M_PI / 180.0;
    const Eigen::Vector3d shake(jr * unit(rng), jr * unit(rng), jr * unit(rng));  // roll, pitch, yaw noise of the INS
    q.linear() = Eigen::AngleAxisd(heading.x2, Eigen::Vector3d::UnitZ()) * p.linear() *
                 Eigen::AngleAxisd(shake.norm(), shake.norm() > 0 ? Eigen::Vector3d(shake.normalized()) : Eigen::Vector3d::UnitZ());
    out.push_back(q);
  }
  return out;
}

}  // namespace pl::sim
