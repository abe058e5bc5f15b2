// An Ouster sensor's metadata: the JSON the sensor serves and ouster_ros and the Ouster SDK write
// beside a recording (an ouster_ros bag carries it on its metadata topic). What the decoder needs of
// it: the packet profile and data format, the beam angles and the transforms to the sensor frame.
// Both layouts are read: the flat one (firmware up to 2.3: beam_altitude_angles, data_format,
// lidar_mode ... at the top) and the nested one (sensor_info, config_params, beam_intrinsics,
// lidar_intrinsics, lidar_data_format). Fields left out take the Ouster SDK's defaults.
#pragma once

#include <array>
#include <string>
#include <string_view>
#include <vector>

namespace pl::lidar::ouster {

// The lidar packet profiles read here (udp_profile_lidar); others are refused by name.
enum class Profile {
  Legacy,   // LEGACY: no packet header, 12-byte pixels, 20-bit range
  Single,   // RNG19_RFL8_SIG16_NIR16: 12-byte pixels, 19-bit range
  Dual,     // RNG19_RFL8_SIG16_NIR16_DUAL: 16-byte pixels, two returns
  LowData,  // RNG15_RFL8_NIR8: 4-byte pixels, range in units of 8 mm
};
const char* profile_name(Profile p);

// Which return comes first in a dual-return pixel (config_params.return_order).
enum class ReturnOrder { StrongestFirst, NearestFirst, FarthestFirst };

struct Metadata {
  std::string prod_line;  // "OS-1-64", "OS-0-32-U1"; empty when the file does not say
  Profile profile = Profile::Legacy;
  ReturnOrder return_order = ReturnOrder::StrongestFirst;
  int pixels_per_column = 0;  // beams
  int columns_per_packet = 16;
  int columns_per_frame = 0;
  int column_window_first = 0;  // the columns the sensor fills, both ends included (may wrap)
  int column_window_last = 0;
  double fps = 0;               // frames a second; 0 when the file does not say
  int udp_port_lidar = 0;       // 0 when the file does not say
  std::vector<double> beam_altitude_deg;  // by pixel row (row 0 is the top beam)
  std::vector<double> beam_azimuth_deg;   // offset from the column's encoder angle, by pixel row
  double lidar_origin_to_beam_origin_mm = 0;
  std::array<double, 16> beam_to_lidar{};    // row-major 4x4, millimetres
  std::array<double, 16> lidar_to_sensor{};  // row-major 4x4, millimetres
};

// Reads the metadata; `name` (the file, or "the metadata text") heads every error. Throws pl::Error
// "NAME:LINE: expected ..., found ..." naming the field that is missing, malformed or inconsistent.
Metadata parse_metadata(std::string_view text, const std::string& name);

// The beams of a product line ("OS-1-64-U2" -> 64), 0 when it names none.
int beams_of(const std::string& prod_line);

}  // namespace pl::lidar::ouster
