// A RoboSense sensor's laser angles: from the maker's angle file (angle.csv) or from its DIFOP packets.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "robosense_format.hpp"

namespace pl::lidar::robosense {

struct Angles {
  std::vector<double> elevation_deg;  // by laser
  std::vector<int> azimuth_offset;    // by laser, 0.01°: added to the firing's azimuth
};

// The maker's angle file: one line a laser, "elevation,azimuth offset" in degrees (the offset may be
// left out), blank lines ignored. Values are taken as the maker's driver takes them: in single
// precision, to 0.01° toward zero. Throws pl::Error naming `name`, the line and the field.
Angles parse_angle_file(std::string_view text, const std::string& name);

// What a DIFOP packet (kPacketBytes long, with its magic) says, read for model `m`.
struct Difop {
  int rpm = 0;
  std::uint8_t return_mode = 0;
  std::optional<Angles> angles;  // none when the packet's angle table is empty or out of range
};
Difop read_difop(std::string_view packet, const Model& m);

}  // namespace pl::lidar::robosense
