// The replay as pl-localize's options choose it: which scans (the selection, then the --cut edit),
// the odometry that predicts between them, and the settings the drive decides (beams, deskew).
#include <algorithm>
#include <string>
#include <vector>

#include "pl/client/replay.hpp"
#include "pl/common/error.hpp"

namespace pl::client {
namespace {

// The dataset indices of --scans all|even|odd, every --every-th of them from the --phase-th, then
// --first K and --count N.
std::vector<std::size_t> choose_scans(const Dataset& ds, const std::string& which, std::size_t every, std::size_t phase,
                                      std::size_t first, std::size_t count) {
  std::vector<std::size_t> scans;
  for (std::size_t i = 0; i < ds.size(); ++i) {
    const long f = ds.frame_ids.empty() ? static_cast<long>(i) : ds.frame_ids[i];
    if (which == "all" || (which == "even") == (f % 2 == 0)) scans.push_back(i);
  }
  if (every > 1) {
    std::vector<std::size_t> kept;
    for (std::size_t k = phase; k < scans.size(); k += every) kept.push_back(scans[k]);
    scans.swap(kept);
  }
  if (first >= scans.size())
    throw Error("--first " + std::to_string(first) + " is not one of the " + std::to_string(scans.size()) + " " + which + " scans");
  const std::size_t end = first + std::min(count, scans.size() - first);  // (first + count would wrap: count defaults to the largest size_t)
  return std::vector<std::size_t>(scans.begin() + static_cast<long>(first), scans.begin() + static_cast<long>(end));
}

// --cut K,N: leaves out N scans after the K-th kept; with the clock closed over the cut, the scans
// after it are moved back by its span (a kidnapping with no hint).
void cut_scans(const Dataset& ds, const std::vector<std::size_t>& cut, bool close_clock, ReplayOptions& replay) {
  if (cut[0] < 1 || cut[0] + cut[1] >= replay.scans.size())
    throw Error("--cut " + std::to_string(cut[0]) + "," + std::to_string(cut[1]) + ": keep at least one scan before and after the cut (of " +
                std::to_string(replay.scans.size()) + ")");
  const double gap = ds.times[replay.scans[cut[0] + cut[1]]] - ds.times[replay.scans[cut[0]]];
  replay.scans.erase(replay.scans.begin() + static_cast<long>(cut[0]), replay.scans.begin() + static_cast<long>(cut[0] + cut[1]));
  if (close_clock) {
    replay.time_shift.assign(replay.scans.size(), 0.0);
    for (std::size_t k = cut[0]; k < replay.scans.size(); ++k) replay.time_shift[k] = -gap;
  }
}

// --odometry: auto takes the encoder, else the odometry, else the LiDAR momentum. Sets `odometry` to
// the one taken.
OdometrySource choose_odometry(const Dataset& ds, std::string& odometry, VehicleLocalizerConfig& cfg) {
  if (odometry == "auto") odometry = !ds.encoder.empty() ? "encoder" : !ds.odometry.empty() ? "odometry" : "lidar";
  if (odometry == "encoder") {
    if (ds.encoder.empty()) throw Error("--odometry encoder: " + ds.dir + " has no encoder.csv");
    cfg.wheel_base_m = ds.meta.vehicle.wheel_base_m;
    if (!(cfg.wheel_base_m > 0))
      throw Error("encoder odometry needs vehicle.wheel_base_m > 0 in meta.json (got " + std::to_string(cfg.wheel_base_m) + ")");
    return OdometrySource::Encoder;
  }
  if (odometry == "odometry") {
    if (ds.odometry.empty()) throw Error("--odometry odometry: " + ds.dir + " has no odometry.csv");
    return OdometrySource::Poses;
  }
  return OdometrySource::None;
}

}  // namespace

ReplayOptions plan_replay(const Dataset& ds, ReplayPlan& plan, VehicleLocalizerConfig& cfg) {
  LocalizerConfig& lc = cfg.localizer;
  const int sensor = ds.meta.sensor.beams;
  if (plan.beams == 0) plan.beams = sensor;
  if (sensor == 1 && plan.beams > 1 && ds.recording)
    throw Error("--beams " + std::to_string(plan.beams) + ": the recording's clouds have no ring field and their points do not come " +
                "laser by laser, so no beams can be told apart: record the driver's ring field (ring, line or channel), or " +
                "leave out --beams to use every point");
  if (plan.beams > sensor || sensor % plan.beams != 0)
    throw Error("--beams must divide the sensor's " + std::to_string(sensor) + " beams, got " + std::to_string(plan.beams));
  lc.scan.beams = plan.beams;
  lc.lidar_odometry = plan.lidar_odometry == "on";
  lc.scan.sensor_beams = sensor;
  ReplayOptions replay;
  replay.scans = choose_scans(ds, plan.scans, plan.every, plan.phase, plan.first, plan.count);
  if (!plan.cut.empty()) cut_scans(ds, plan.cut, plan.cut_clock == "close", replay);
  replay.rings = plan.beams < sensor;
  replay.realtime = plan.realtime;
  replay.odometry = choose_odometry(ds, plan.odometry, cfg);
  if (!replay.time_shift.empty() && replay.odometry != OdometrySource::None)
    throw Error("--cut-clock close needs --odometry lidar (the odometry's own clock cannot be closed over the cut)");
  // auto: on for scans that carry their points' times (the sensor says it sweeps), off otherwise.
  lc.compensate_motion = plan.deskew == "on" || (plan.deskew == "auto" && ds.has_point_times());
  if (ds.meta.sensor.rate_hz > 0) lc.sweep_s = 1.0 / ds.meta.sensor.rate_hz;
  return replay;
}

}  // namespace pl::client
