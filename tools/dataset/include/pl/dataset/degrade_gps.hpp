// A copy of a drive with a consumer-grade GPS: every file of the source reached through a symlink
// (nothing copied) and a new gps.csv, the source's fixes thinned to a lower rate and moved by
// zero-mean Gaussian noise (white: independent from fix to fix). pl-dataset degrade-gps.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

#include "pl/recordings/dataset.hpp"

namespace pl::dataset {

struct DegradeGpsConfig {
  double rate_hz = 1.0;   // fixes kept a second, at most the source's rate
  double sigma_m = 1.5;   // noise per horizontal axis (east, north); 1.5 x sigma vertically
  std::uint64_t seed = 1; // same seed, same file
};

struct DegradeGpsReport {
  std::size_t scans = 0, links = 0, fixes = 0, source_fixes = 0;
  double span_s = 0;                     // of the source fixes
  double rms_east_m = 0, rms_north_m = 0, rms_up_m = 0;  // the noise as written (read back)
  double mean_horizontal_m = 0, max_horizontal_m = 0;
};

// The folder `out` must not exist, be empty, or be an earlier output of this function (marked by a
// .pl-degrade-gps file; it is replaced); it must not be the source or inside it. Throws pl::Error
// naming the problem and the fix, before anything is written.
DegradeGpsReport degrade_gps(const Dataset& ds, const std::string& out, const DegradeGpsConfig& cfg);
// The summary lines of pl-dataset degrade-gps.
std::string degrade_gps_text(const DegradeGpsReport& r, const std::string& source, const std::string& out, const DegradeGpsConfig& cfg);

}  // namespace pl::dataset
