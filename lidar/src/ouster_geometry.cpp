// The per-beam and per-column tables of BeamGeometry (the formula is in the header).
#include "ouster_geometry.hpp"

#include <cmath>

namespace pl::lidar::ouster {

BeamGeometry::BeamGeometry(const Metadata& m) : to_sensor_(m.lidar_to_sensor) {
  constexpr double kRad = M_PI / 180.0;
  beams_.reserve(m.beam_altitude_deg.size());
  for (std::size_t i = 0; i < m.beam_altitude_deg.size(); ++i) {
    const double az = -m.beam_azimuth_deg[i] * kRad;
    const double alt = m.beam_altitude_deg[i] * kRad;
    beams_.push_back({std::cos(az), std::sin(az), std::cos(alt), std::sin(alt), m.beam_azimuth_deg[i]});
  }
  const auto w = static_cast<std::size_t>(m.columns_per_frame);
  cols_.reserve(w);
  for (std::size_t c = 0; c < w; ++c) {
    const double turned = static_cast<double>(c) / static_cast<double>(w);
    const double te = 2.0 * M_PI * (1.0 - turned);
    cols_.push_back({std::cos(te), std::sin(te), 360.0 * turned});
  }
  origin_x_ = m.beam_to_lidar[3];
  origin_z_ = m.beam_to_lidar[11];
  origin_norm_ = origin_z_ != 0 ? std::hypot(origin_x_, origin_z_) : origin_x_;
}

}  // namespace pl::lidar::ouster
