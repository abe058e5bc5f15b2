// A Velodyne return to a point. The makers' formula (HDL-64E manual, "calculating XYZ"): with
// distance d, elevation v, the laser's azimuth a (the block's, less rot_correction), vertical
// offset vo and horizontal offset ho, in the sensor's frame (x right, y forward)
//   x = ((d + cx) cos v - vo sin v) sin a - ho cos a
//   y = ((d + cy) cos v - vo sin v) cos a + ho sin a
//   z =  (d + cy) sin v + vo cos v
// where cx, cy are the HDL-64E's two-point distance corrections (else 0); then x forward = y,
// y left = -x. Intensity: the HDL-64E adds focal_slope * |256 (1 - f/13100)^2 - 256 (1 - raw/65535)^2|
// (f the focal distance), then clamps to [min_intensity, max_intensity].
#include "velodyne_geometry.hpp"

#include <algorithm>
#include <cmath>

#include "velodyne_model.hpp"

namespace pl::lidar {
namespace {

constexpr int kAzimuthSteps = 36000;
constexpr double kPi = 3.14159265358979323846;

struct TrigTable {
  std::vector<float> cos, sin;
  TrigTable() : cos(kAzimuthSteps), sin(kAzimuthSteps) {
    for (int i = 0; i < kAzimuthSteps; ++i) {
      const auto rad = static_cast<float>(0.01 * i * kPi / 180.0);
      cos[i] = std::cos(rad);
      sin[i] = std::sin(rad);
    }
  }
};

const TrigTable& trig() {
  static const TrigTable table;
  return table;
}

}  // namespace

VelodyneGeometry::VelodyneGeometry(const VelodyneCalibration& calibration, float distance_unit_m)
    : unit_m_(distance_unit_m), cos_(trig().cos.data()), sin_(trig().sin.data()) {
  lasers_.reserve(calibration.lasers.size());
  for (const VelodyneLaser& c : calibration.lasers) {
    Laser l;
    // The drivers keep the file's values as float; so does this, before any arithmetic.
    const auto rot = static_cast<float>(c.rot_correction);
    const auto vert = static_cast<float>(c.vert_correction);
    l.rot_units = static_cast<double>(rot) * 180.0 / kPi * 100.0;
    l.cos_vert = std::cos(vert);
    l.sin_vert = std::sin(vert);
    l.elevation_deg = static_cast<float>(c.vert_correction * 180.0 / kPi);
    l.dist_correction = static_cast<float>(c.dist_correction);
    l.dist_correction_x = static_cast<float>(c.dist_correction_x);
    l.dist_correction_y = static_cast<float>(c.dist_correction_y);
    l.two_point = c.two_pt_correction_available;
    l.vert_offset = static_cast<float>(c.vert_offset_correction);
    l.horiz_offset = static_cast<float>(c.horiz_offset_correction);
    l.min_intensity = static_cast<float>(c.min_intensity);
    l.max_intensity = static_cast<float>(c.max_intensity);
    const float focal = 1 - static_cast<float>(c.focal_distance) / 13100;
    l.focal_offset = 256 * focal * focal;
    l.focal_slope = static_cast<float>(c.focal_slope);
    lasers_.push_back(l);
  }
}

int VelodyneGeometry::azimuth(int laser, float firing_azimuth) const {
  auto a = static_cast<float>(static_cast<double>(firing_azimuth) - lasers_[laser].rot_units);
  if (a < 0) a += kAzimuthSteps;
  long steps = std::lround(a) % kAzimuthSteps;
  if (steps < 0) steps += kAzimuthSteps;
  return static_cast<int>(steps);
}

void VelodyneGeometry::place(int laser, float distance, int azimuth, std::uint16_t raw_distance,
                             std::uint8_t raw_intensity, Point& p) const {
  const Laser& l = lasers_[laser];
  const float cos_a = cos_[azimuth], sin_a = sin_[azimuth];
  float dx = 0, dy = 0;
  if (l.two_point) {
    // Linear in the point's |x| and |y| between the maker's two calibration distances.
    const float xy = distance * l.cos_vert - l.vert_offset * l.sin_vert;
    const float ax = std::abs(xy * sin_a - l.horiz_offset * cos_a);
    const float ay = std::abs(xy * cos_a + l.horiz_offset * sin_a);
    dx = (l.dist_correction - l.dist_correction_x) * (ax - 2.4f) / (25.04f - 2.4f) + l.dist_correction_x -
         l.dist_correction;
    dy = (l.dist_correction - l.dist_correction_y) * (ay - 1.93f) / (25.04f - 1.93f) + l.dist_correction_y -
         l.dist_correction;
  }
  const float xy_x = (distance + dx) * l.cos_vert - l.vert_offset * l.sin_vert;
  const float right = xy_x * sin_a - l.horiz_offset * cos_a;
  const float dist_y = distance + dy;
  const float xy_y = dist_y * l.cos_vert - l.vert_offset * l.sin_vert;
  const float forward = xy_y * cos_a + l.horiz_offset * sin_a;
  p.x = forward;
  p.y = -right;
  p.z = dist_y * l.sin_vert + l.vert_offset * l.cos_vert;

  float intensity = raw_intensity;
  if (l.focal_slope != 0) {
    const float near = 1 - static_cast<float>(raw_distance) / 65535;
    intensity += l.focal_slope * std::abs(l.focal_offset - 256 * near * near);
  }
  p.intensity = std::floor(std::clamp(intensity, l.min_intensity, l.max_intensity));
}

}  // namespace pl::lidar
