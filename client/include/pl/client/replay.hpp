// A recorded drive replayed through the VehicleLocalizer exactly as a vehicle program would feed it:
// odometry samples as they would have arrived, each scan handed over and its result waited for,
// fused poses read at the odometry rate (the ones a late result arrives too late for are output
// as they were before it). pl-localize is argument handling over this.
#pragma once

#include <cstdio>
#include <functional>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "pl/client/vehicle_localizer.hpp"
#include "pl/common/pose.hpp"
#include "pl/recordings/dataset.hpp"

namespace pl::client {

class RunLog;  // pl/client/run_log.hpp

enum class OdometrySource { None, Encoder, Poses };

struct ReplayOptions {
  std::vector<std::size_t> scans;  // dataset indices to localize, in order (the first starts)
  // Seconds added to each of those scans' times (empty: none): a stretch cut out with the clock
  // closed over it is a kidnapping with no hint. Only without odometry (its times are not shifted).
  std::vector<double> time_shift;
  OdometrySource odometry = OdometrySource::None;
  bool rings = false;           // hand the rings over (needed when fewer beams are kept)
  bool realtime = false;        // wait for each scan's time on the wall clock
  std::FILE* timing = nullptr;  // per-scan CSV (header written here), optional
  std::function<void(std::size_t done, std::size_t total)> progress;
  // Starts the localizer (start, start_near) once the odometry up to the first scan is given.
  std::function<void(VehicleLocalizer&)> start;
  // Optional: the run written as it goes (pl-localize --log): every fused pose output, each scan with
  // its report, the ROI map's tiles when they change, the drive's GPS fixes over the replayed span.
  // Written after a scan's result and its latency are taken, so a log never changes the poses.
  RunLog* log = nullptr;
};

struct ReplayResult {
  Trajectory fused;     // at the odometry rate (TUM), or one per scan without odometry
  Trajectory per_scan;  // the fused pose of every scan
  std::size_t ok = 0, degraded = 0, lost = 0, outdated = 0, lidar_fused = 0;
  std::vector<double> registration_ms, total_ms;
  // The outdated-map share: of the fused scans, the mean share of scan points ICP found no map pair
  // for (1 - inlier share): what the map lacks, and the traffic.
  double unpaired_sum = 0;
  std::size_t unpaired_scans = 0;
  double unpaired_share() const { return unpaired_scans ? unpaired_sum / static_cast<double>(unpaired_scans) : 0.0; }
};

// The drive, scan by scan, after options.start. Throws pl::Error when the start failed (naming why).
ReplayResult replay(const Dataset& ds, VehicleLocalizer& loc, const ReplayOptions& options);

// What of a drive is replayed and how, as pl-localize's options say it (words as they take them);
// plan_replay and choose_start read it against the drive. Errors name the options.
struct ReplayPlan {
  std::string scans = "all";          // all, even or odd (by frame id)
  std::size_t every = 1, phase = 0;   // every k-th of those scans, from the phase-th (phase < every)
  std::size_t first = 0;              // then skip this many of them
  std::size_t count = std::numeric_limits<std::size_t>::max();  // and keep this many at most
  std::vector<std::size_t> cut;       // empty, or K,N: leave out N scans after the K-th of those kept
  std::string cut_clock = "keep";     // keep: the clock runs on over the cut; close: it does not
  std::string odometry = "auto";      // auto, encoder, odometry or lidar (plan_replay sets the one taken)
  int beams = 0;                      // every k-th ring kept; 0: all (plan_replay sets the count)
  std::string deskew = "auto";        // auto (on when the drive has point times), on or off
  std::string lidar_odometry = "on";  // on or off
  bool realtime = false;              // wait for each scan's time on the wall clock
  // x,y,z,yaw (degrees), gt, gps or global; empty: gps when the drive has fixes, else gt.
  std::string init;
  std::string init_search = "on";     // on: search round an x,y,z,yaw start; off: take it as it is
};

// The replay's scans, odometry and rings, and the settings taken from the drive (the beams kept,
// LiDAR odometry, motion compensation, the sweep time, the wheel base), as `plan` chooses them:
// the dataset indices of `plan.scans`, every `every`-th of them from the `phase`-th, then `first`
// and `count`, less the cut. Resolves plan.odometry and plan.beams. The start is choose_start's.
ReplayOptions plan_replay(const Dataset& ds, ReplayPlan& plan, VehicleLocalizerConfig& cfg);

// The start (options.start): ground truth, the first GPS fix (every heading searched), a pose given
// (searched within cfg.search.radius_m unless init_search is off), or none (global: the map's places).
// Returns the start's position in the map frame when it is known before the map is (not with
// global, nor a GPS fix placed about the map's origin). With gps, copies cfg.gps_search to cfg.search.
std::optional<Eigen::Vector3d> choose_start(const Dataset& ds, const ReplayPlan& plan, VehicleLocalizerConfig& cfg,
                                            ReplayOptions& options);
// A start outside the map finds nothing to register to: what to say before the drive, naming what
// would find the vehicle; "" when the start is in the map or not known.
std::string start_outside_map(const VehicleLocalizer& loc, const std::optional<Eigen::Vector3d>& start, const std::string& map);

}  // namespace pl::client
