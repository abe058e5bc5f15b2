// A recorded drive replayed through the VehicleLocalizer exactly as a vehicle program would feed it:
// odometry samples as they would have arrived, each scan handed over and its result waited for,
// fused poses read at the odometry rate (the ones a late result arrives too late for are output
// as they were before it). pl-localize is argument handling over this.
#pragma once

#include <cstdio>
#include <functional>
#include <string>
#include <vector>

#include "pl/client/vehicle_localizer.hpp"
#include "pl/common/dataset.hpp"
#include "pl/common/pose.hpp"

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

}  // namespace pl::client
