// Every scan of a drive prepared as the localizer does (beam choice, field-of-view and range crops,
// voxel grid), with the points in and out and the time each took. pl-dataset scans.
#pragma once

#include <cstddef>
#include <functional>
#include <string>

#include "pl/common/scan.hpp"
#include "pl/recordings/dataset.hpp"

namespace pl::dataset {

// The preparation's defaults here: all beams, 360 degrees, 2 to 100 m, 0.2 m voxels.
inline ScanPrepConfig scan_stats_defaults() {
  ScanPrepConfig c;
  c.voxel_m = 0.2;
  return c;
}

struct ScanStats {
  std::size_t scans = 0;
  double median_in = 0, median_out = 0, median_ms = 0;  // points a scan before and after; ms a scan
};

// Prepares every scan with `cfg` (its sensor_beams from the dataset). With a `timing_path`, writes
// frame,points_in,points_out,prepare_ms per scan there. Throws pl::Error for a bad config or an
// unwritable timing file (before any scan is read).
ScanStats prepare_every_scan(const Dataset& ds, ScanPrepConfig cfg, const std::string& timing_path = "",
                             const std::function<void(std::size_t, std::size_t)>& progress = {});
// "prepared N scans: ..." and "points a scan: ..." lines.
std::string scan_stats_text(const ScanStats& s, const ScanPrepConfig& cfg);

}  // namespace pl::dataset
