// What a drive tells the map service (pl-localize's report options): the vehicle's position and
// health while it drives (StatusReporter) and, when it ends, its change report (docs/map-updates.md)
// written to a file and/or put in the report spool, which then sends what waits (ReportOutbox).
#pragma once

#include <Eigen/Geometry>
#include <cstddef>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "pl/client/report_outbox.hpp"
#include "pl/client/status_reporter.hpp"
#include "pl/client/vehicle_localizer.hpp"

namespace pl::client {

struct DriveReportsConfig {
  std::string file;                 // the change report as JSON (what the service takes); empty: none
  std::string spool;                // the report spool (ReportOutboxConfig::dir); empty: none
  std::string server;               // the map service: where the spool sends and the status goes
  std::string token;                // a token of the report role
  std::string vehicle = "vehicle";  // the vehicle's id (drives of one vehicle are not independent evidence)
  std::string drive;                // the drive's id; empty: the drive folder's name and the start time
  double start = -1;                // the drive's start, seconds since 1970; < 0: now minus the drive's span
  double status_every_s = 0;        // how often the status is sent, s; 0: never
  // Whether there is a change report to make: the localizer must keep change evidence.
  bool change_report() const { return !file.empty() || !spool.empty(); }
};

class DriveReports {
 public:
  // Opens the spool (one that cannot be written is said at once: pl::Error) and starts the status
  // reporter, for the map of `loc_cfg` and with its tile client's CA file and plain-HTTP choice; sets
  // loc_cfg.changes.enabled when there is a change report to make. Make it before the localizer,
  // with every other setting made: the localizer's callback may use it until the localizer stops.
  DriveReports(DriveReportsConfig cfg, VehicleLocalizerConfig& loc_cfg);
  // Hands each scan's pose of the base and health over to the status reporter, when there is one.
  void watch(VehicleLocalizer& loc, const Eigen::Isometry3d& base_from_lidar);
  // After the drive (span: its seconds), when there is a change report to make: the localizer's
  // evidence as a report, checked as the service checks it, written to the file (whole or not at
  // all) and put in the spool, which then sends what waits.
  void finish(const VehicleLocalizer& loc, const std::string& drive_dir, double span);
  // After finish: what was reported, as pl-localize's summary lines to `out` (the change report
  // and its evidence, the status sent, the spool) and the reports the full spool dropped to `err`.
  void print_summary(const VehicleLocalizer& loc, std::FILE* out, std::FILE* err) const;

 private:
  DriveReportsConfig cfg_;
  std::string map_;
  double voxel_m_;  // of the change evidence
  std::unique_ptr<ReportOutbox> outbox_;
  std::unique_ptr<StatusReporter> status_;
  std::size_t tiles_ = 0, bytes_ = 0;  // the change report's
  std::vector<std::string> dropped_;    // reports the full spool dropped
  OutboxSend sent_;
};

}  // namespace pl::client
