// A Hesai angle-correction file: one row per laser, "laser id, elevation, azimuth offset" (degrees),
// under an optional header row ("Laser id,Elevation,Azimuth" or "Channel,Elevation,Azimuth"). Laser
// ids run from 1; channel = id - 1. A point's azimuth is its block's azimuth plus its laser's offset.
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include "pl/lidar/decoder.hpp"

namespace pl::lidar {

struct HesaiCalibration {
  std::string source;                       // the file's path, or "the calibration text"
  std::vector<double> elevation_deg;        // by channel
  std::vector<double> azimuth_offset_deg;   // by channel
  int channels() const { return static_cast<int>(elevation_deg.size()); }
};

// Throws pl::Error "SOURCE:LINE: expected ..." for a row that is not three numbers in range, a
// repeated laser id, or ids that leave a gap.
HesaiCalibration parse_hesai_calibration(std::string_view text, const std::string& source);

// The options' calibration text, else the file at their path; no rows when neither is given.
HesaiCalibration load_hesai_calibration(const DecoderOptions& options);

}  // namespace pl::lidar
