#include "pl/client/replay.hpp"

#include <chrono>
#include <thread>

#include "pl/client/run_log.hpp"
#include "pl/common/error.hpp"

namespace pl::client {
namespace {

double seconds_now() { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); }

// Odometry samples reach the localizer in time order; `next` is the first one not yet given.
struct OdometryFeed {
  const Dataset& ds;
  OdometrySource source;
  std::size_t next = 0;

  std::size_t size() const {
    return source == OdometrySource::Encoder ? ds.encoder.size() : source == OdometrySource::Poses ? ds.odometry.size() : 0;
  }
  double time(std::size_t i) const { return source == OdometrySource::Encoder ? ds.encoder[i].t : ds.odometry[i].t; }
  // Every sample with time < until.
  void until(VehicleLocalizer& loc, double until) {
    for (; next < size() && time(next) < until; ++next) {
      if (source == OdometrySource::Encoder)
        loc.add_wheel_travel(ds.encoder[next].t, ds.encoder[next].left_m, ds.encoder[next].right_m);
      else
        loc.add_odometry_pose(ds.odometry[next].t, ds.odometry[next].pose);
    }
  }
};

// Odometry known this long after a scan's time by when its result is ready (and the output window).
constexpr double kAhead = 0.25;

}  // namespace

ReplayResult replay(const Dataset& ds, VehicleLocalizer& loc, const ReplayOptions& o) {
  if (o.scans.empty()) throw Error("replay: no scan to localize");
  if (!o.time_shift.empty() && (o.time_shift.size() != o.scans.size() || o.odometry != OdometrySource::None))
    throw Error("replay: time shifts need one per scan and no odometry");
  const auto time_of = [&](std::size_t k) { return ds.times[o.scans[k]] + (o.time_shift.empty() ? 0.0 : o.time_shift[k]); };
  ReplayResult out;
  out.fused.format = PoseFormat::Tum;
  // Every fused pose output goes through here (and to the log).
  const auto output = [&](double tj, const Eigen::Isometry3d& pose) {
    out.fused.times.push_back(tj);
    out.fused.poses.push_back(pose);
    if (o.log) o.log->pose(tj, pose);
  };
  OdometryFeed feed{ds, o.odometry};
  const double t0 = time_of(0);
  // The drive's GPS fixes from a second before the first scan, logged as the replay passes them.
  std::size_t gps_next = 0;
  while (gps_next < ds.gps.size() && ds.gps[gps_next].t < t0 - 1.0) ++gps_next;
  const auto log_gps = [&](double until) {
    for (; o.log && gps_next < ds.gps.size() && ds.gps[gps_next].t <= until; ++gps_next) o.log->gps(ds.gps[gps_next]);
  };
  feed.until(loc, t0 + kAhead);
  if (o.start) o.start(loc);
  if (o.timing)
    std::fprintf(o.timing,
                 "scan,t,registration_ms,prepare_ms,map_ms,total_ms,points,iterations,pairs,inlier_share,rms_m,"
                 "conditioning,correction_m,position_sigma_m,odometry_ms,integrity_ms,motion,basin,uncertainty_m,protection_m,alternative_m,"
                 "basin_spread_m,place_proposals,compensated,status,fused,note\n");
  const bool odometry = o.odometry != OdometrySource::None;
  // The output at the odometry rate: sample `out_next` is the next one not yet written.
  std::size_t out_next = 0;
  if (odometry)
    while (out_next < feed.size() && feed.time(out_next) <= t0 - 1e-9) ++out_next;
  const double wall0 = seconds_now();
  for (std::size_t k = 0; k < o.scans.size(); ++k) {
    const std::size_t i = o.scans[k];
    const double t = time_of(k);
    if (o.realtime) {
      const double wait = (t - t0) - (seconds_now() - wall0);
      if (wait > 0) std::this_thread::sleep_for(std::chrono::duration<double>(wait));
    }
    feed.until(loc, t + kAhead);
    log_gps(t);
    std::vector<std::pair<double, Eigen::Isometry3d>> pending;  // samples the result arrives too late for
    if (odometry) {
      for (; out_next < feed.size() && feed.time(out_next) < t; ++out_next)
        output(feed.time(out_next), loc.pose_at(feed.time(out_next)).base_in_map);
      for (std::size_t j = out_next; j < feed.size() && feed.time(j) < t + kAhead; ++j)
        pending.emplace_back(feed.time(j), loc.pose_at(feed.time(j)).base_in_map);
    }
    const double c0 = seconds_now();
    const Frame frame = ds.load_frame(i, o.rings);
    loc.add_scan(t, frame.scan, frame.rings, frame.times);
    if (!loc.wait_idle(600.0)) throw Error("replay: scan " + std::to_string(i) + " took over 10 minutes");
    if (!loc.pose_at(t).valid) throw Error("the localizer did not start: " + loc.last_error());
    const ScanReport r = loc.last_report();
    const double latency = seconds_now() - c0;
    if (odometry) {
      // Poses between the scan and the moment its result is ready were output before the correction.
      for (const auto& [tj, pj] : pending) {
        if (tj >= t + latency) break;
        output(tj, pj);
        ++out_next;
      }
    } else {
      output(t, r.fused);
    }
    if (o.log) {
      o.log->scan(r, frame.scan, frame.rings, latency * 1000.0);
      o.log->map(t, loc.map_tiles());
    }
    out.per_scan.times.push_back(t);
    out.per_scan.poses.push_back(r.fused);
    out.per_scan.frame_ids.push_back(ds.frame_ids.empty() ? static_cast<long>(i) : ds.frame_ids[i]);
    out.registration_ms.push_back(r.register_ms);
    out.total_ms.push_back(latency * 1000.0);
    out.lidar_fused += r.fused_lidar;
    out.outdated += r.map_outdated;
    if (r.fused_lidar) {
      out.unpaired_sum += 1.0 - r.icp.inlier_share;
      ++out.unpaired_scans;
    }
    (r.health == Health::Ok ? out.ok : r.health == Health::Degraded ? out.degraded : out.lost)++;
    if (o.timing)
      std::fprintf(o.timing, "%zu,%.6f,%.3f,%.3f,%.3f,%.3f,%zu,%d,%d,%.4f,%.4f,%.4f,%.4f,%.5f,%.3f,%.3f,%s,%s,%.4f,%.4f,%.3f,%.3f,%d,%d,%s,%d,%s\n", i,
                   t, r.register_ms, r.prepare_ms, r.map_ms, latency * 1000.0, r.scan_points, r.icp.iterations, r.icp.pairs,
                   r.icp.inlier_share, r.icp.rms_m, r.icp.conditioning, (r.predicted.translation() - r.icp.pose.translation()).norm(),
                   r.position_sigma.norm(), r.odometry_ms, r.integrity_ms, r.motion, basin_name(r.basin), r.uncertainty.horizontal(),
                   r.protection_m, r.alternative_m, r.basin_spread_m, r.place_proposals, r.compensated ? 1 : 0, health_name(r.health), r.fused_lidar ? 1 : 0, r.note.c_str());
    if (o.progress) o.progress(k + 1, o.scans.size());
  }
  if (odometry) {
    for (; out_next < feed.size() && feed.time(out_next) <= time_of(o.scans.size() - 1); ++out_next)
      output(feed.time(out_next), loc.pose_at(feed.time(out_next)).base_in_map);
  }
  log_gps(time_of(o.scans.size() - 1));
  // The poses are the base's; a replay's base is the LiDAR (the dataset's frame; pl-localize sets no
  // other extrinsics).
  out.fused.frame = out.per_scan.frame = "lidar";
  return out;
}

}  // namespace pl::client
