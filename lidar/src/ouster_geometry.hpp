// Where an Ouster pixel's return lies in the sensor frame: the Ouster SDK's XYZ look-up table, made
// of per-beam and per-column sines and cosines instead of a table of every pixel.
//   In the lidar frame (millimetres) the column's encoder angle is te = 2 pi (1 - m / W) for
// measurement id m of W columns, the beam's azimuth offset ta = -beam_azimuth, its elevation
// phi = beam_altitude. The beam's unit vector is d = (cos(te + ta) cos phi, sin(te + ta) cos phi,
// sin phi); the beam leaves from o = (cos te * bx, sin te * bx, bz) (bx, bz: beam_to_lidar's x and z
// translations), and a range r (measured as if from the lidar origin, offset by n = |(bx, bz)|)
// lies at o + (r - n) d. lidar_to_sensor then takes it to the sensor frame (x forward, z up).
//   The sensor turns clockwise seen from above: azimuth_deg() is the column's encoder angle plus the
// beam's azimuth offset, 0 facing the lidar frame's +x (the sensor frame's -x, the connector side).
#pragma once

#include <array>
#include <vector>

#include "ouster_metadata.hpp"

namespace pl::lidar::ouster {

class BeamGeometry {
 public:
  explicit BeamGeometry(const Metadata& m);

  // The point of a range (mm) of beam `row` in column `m`, in the sensor frame, metres.
  std::array<double, 3> point(std::size_t row, std::size_t m, double range_mm) const {
    const Beam& b = beams_[row];
    const Col& c = cols_[m];
    const double ca = c.cos * b.cos_az - c.sin * b.sin_az;  // cos(te + ta)
    const double sa = c.sin * b.cos_az + c.cos * b.sin_az;
    const double along = range_mm - origin_norm_;
    const double x = along * ca * b.cos_alt + c.cos * origin_x_;
    const double y = along * sa * b.cos_alt + c.sin * origin_x_;
    const double z = along * b.sin_alt + origin_z_;
    const auto& t = to_sensor_;
    return {(t[0] * x + t[1] * y + t[2] * z + t[3]) * 1e-3, (t[4] * x + t[5] * y + t[6] * z + t[7]) * 1e-3,
            (t[8] * x + t[9] * y + t[10] * z + t[11]) * 1e-3};
  }

  // The beam's azimuth (degrees, [0, 360), clockwise seen from above; see the top of this file).
  double azimuth_deg(std::size_t row, std::size_t m) const {
    double a = cols_[m].encoder_deg + beams_[row].azimuth_deg;
    a -= 360.0 * static_cast<int>(a / 360.0);
    if (a < 0) a += 360.0;
    return a >= 360.0 ? 0.0 : a;
  }

 private:
  struct Beam {
    double cos_az, sin_az, cos_alt, sin_alt, azimuth_deg;
  };
  struct Col {
    double cos, sin, encoder_deg;
  };
  std::vector<Beam> beams_;
  std::vector<Col> cols_;
  double origin_x_ = 0, origin_z_ = 0, origin_norm_ = 0;
  std::array<double, 16> to_sensor_{};
};

}  // namespace pl::lidar::ouster
