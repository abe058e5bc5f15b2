// The Velodyne calibration file: the makers' YAML as their ROS drivers read it, one entry per laser
// (`lasers:` list with laser_id, rot_correction, vert_correction, dist_correction, ...). Angles are
// radians and lengths metres, as in the file.
#pragma once

#include <string>
#include <vector>

#include "pl/lidar/decoder.hpp"

namespace pl::lidar {

struct VelodyneLaser {
  double rot_correction = 0;   // rad: the laser looks at the block's azimuth minus this
  double vert_correction = 0;  // rad: elevation
  double dist_correction = 0;  // m, added to every distance
  // The HDL-64E's two-point distance correction, used when two_pt_correction_available.
  double dist_correction_x = 0;
  double dist_correction_y = 0;
  bool two_pt_correction_available = false;
  double vert_offset_correction = 0;   // m
  double horiz_offset_correction = 0;  // m
  // Intensity: clamped to [min, max]; focal_slope > 0 adds the HDL-64E's distance compensation.
  double min_intensity = 0;
  double max_intensity = 255;
  double focal_distance = 0;
  double focal_slope = 0;
};

struct VelodyneCalibration {
  std::string source;                 // the file it came from ("calibration text" when given as text)
  std::vector<VelodyneLaser> lasers;  // by laser_id, 0..n-1; empty: no calibration given
};

// Throws pl::Error "SOURCE:LINE: lasers[I].FIELD: expected ..., found ..." for a file that is not
// YAML, lacks a field, has a value out of range, or numbers its lasers other than 0..n-1 once each.
VelodyneCalibration parse_velodyne_calibration(const std::string& text, const std::string& source);

// From the options: calibration_text wins over calibration_path; neither gives no lasers.
VelodyneCalibration load_velodyne_calibration(const DecoderOptions& options);

// Rank of each laser's elevation, 0 = lowest (ties by laser id).
std::vector<std::uint16_t> velodyne_rings(const VelodyneCalibration& calibration);

}  // namespace pl::lidar
