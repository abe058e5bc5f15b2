// A Velodyne return to a point: each laser's calibration, precomputed in the float the makers'
// drivers compute in, and the sine and cosine of every 0.01-degree azimuth step.
#pragma once

#include <cstdint>
#include <vector>

#include "pl/lidar/decoder.hpp"
#include "velodyne_calibration.hpp"

namespace pl::lidar {

class VelodyneGeometry {
 public:
  VelodyneGeometry(const VelodyneCalibration& calibration, float distance_unit_m);

  // Metres: the raw count times the model's unit, plus the laser's distance correction.
  float distance_m(int laser, std::uint16_t raw) const {
    return static_cast<float>(raw) * unit_m_ + lasers_[laser].dist_correction;
  }
  // The laser's azimuth in 0.01 degree, [0, 36000): the firing's (the block's azimuth and its share
  // of the step to the next column) less the laser's rot_correction, rounded to the step.
  int azimuth(int laser, float firing_azimuth) const;
  // x y z (the ROS frame: x forward, y left, z up) and intensity of a return of `distance` metres
  // at `azimuth` (0.01 degree); raw_distance and raw_intensity as the packet has them.
  void place(int laser, float distance, int azimuth, std::uint16_t raw_distance, std::uint8_t raw_intensity,
             Point& p) const;
  float elevation_deg(int laser) const { return lasers_[laser].elevation_deg; }

 private:
  struct Laser {
    double rot_units = 0;  // rot_correction in 0.01 degree
    float cos_vert = 1, sin_vert = 0, elevation_deg = 0;
    float dist_correction = 0, dist_correction_x = 0, dist_correction_y = 0;
    bool two_point = false;
    float vert_offset = 0, horiz_offset = 0;
    float min_intensity = 0, max_intensity = 255;
    float focal_offset = 0, focal_slope = 0;
  };
  std::vector<Laser> lasers_;
  float unit_m_;
  const float* cos_;  // 36000 entries each, shared by every decoder
  const float* sin_;
};

}  // namespace pl::lidar
