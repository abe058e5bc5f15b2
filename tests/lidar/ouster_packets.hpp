// A test-side writer of Ouster metadata and lidar packets, from the published layouts (Ouster's
// sensor manual and the SDK's packet format), apart from the decoder's reading of them:
//   LEGACY: per column a 16-byte header (timestamp u64 ns, measurement id u16, frame id u16, encoder
//     count u32), 12-byte pixels (range in bits 0-19 of a u32, mm; reflectivity at byte 4), a u32
//     status (0xFFFFFFFF valid); no packet header.
//   RNG19_RFL8_SIG16_NIR16 / _DUAL / RNG15_RFL8_NIR8: a 32-byte packet header (type 1, frame id,
//     init id u24, serial number u40) and a 32-byte footer; per column a 12-byte header (timestamp,
//     measurement id, status u16 bit 0 valid); pixels of 12 bytes (range bits 0-18, reflectivity at
//     4), 16 bytes (range bits 0-18 + reflectivity at 3, second return at 4 and 7), or 4 bytes
//     (range bits 0-14 in 8 mm units, reflectivity at 2).
#pragma once

#include <array>
#include <cstdint>
#include <sstream>
#include <string>
#include <vector>

namespace pl::test::ouster {

enum class Profile { Legacy, Single, Dual, LowData };

inline const char* profile_text(Profile p) {
  switch (p) {
    case Profile::Legacy: return "LEGACY";
    case Profile::Single: return "RNG19_RFL8_SIG16_NIR16";
    case Profile::Dual: return "RNG19_RFL8_SIG16_NIR16_DUAL";
    case Profile::LowData: return "RNG15_RFL8_NIR8";
  }
  return "";
}

// What the metadata says of a sensor.
struct Spec {
  std::string prod_line = "OS-1-32-G";
  Profile profile = Profile::Legacy;
  int pixels = 32;
  int columns_per_packet = 16;
  int columns = 512;  // a frame's
  int fps = 10;
  int window_first = 0, window_last = 511;
  std::vector<double> altitude, azimuth;  // degrees, by row
  double origin_mm = 15.806;              // lidar_origin_to_beam_origin_mm
  std::array<double, 16> lidar_to_sensor = {-1, 0, 0, 0, 0, -1, 0, 0, 0, 0, 1, 36.18, 0, 0, 0, 1};

  Spec() {
    for (int i = 0; i < pixels; ++i) {
      altitude.push_back(16.5 - i * 1.05);
      azimuth.push_back(i % 4 == 0 ? 4.2 : i % 4 == 1 ? 1.4 : i % 4 == 2 ? -1.4 : -4.2);
    }
  }
  std::size_t pixel_size() const { return profile == Profile::Dual ? 16 : profile == Profile::LowData ? 4 : 12; }
  std::size_t column_size() const {
    return (profile == Profile::Legacy ? 20 : 12) + static_cast<std::size_t>(pixels) * pixel_size();
  }
  std::size_t packet_size() const {
    return (profile == Profile::Legacy ? 0 : 64) + static_cast<std::size_t>(columns_per_packet) * column_size();
  }
};

template <typename T>
std::string json_list(const T& v) {
  std::ostringstream s;
  s.precision(17);
  s << "[";
  for (std::size_t i = 0; i < v.size(); ++i) s << (i ? ", " : "") << v[i];
  s << "]";
  return s.str();
}

// The metadata as firmware up to 2.3 writes it (flat), or as 2.4 and the SDK do (nested).
inline std::string metadata_json(const Spec& s, bool nested) {
  std::ostringstream o;
  const std::string mode = "\"" + std::to_string(s.columns) + "x" + std::to_string(s.fps) + "\"";
  const std::string format = "{\n  \"pixels_per_column\": " + std::to_string(s.pixels) + ",\n  \"columns_per_packet\": " +
                             std::to_string(s.columns_per_packet) + ",\n  \"columns_per_frame\": " + std::to_string(s.columns) +
                             ",\n  \"column_window\": [" + std::to_string(s.window_first) + ", " + std::to_string(s.window_last) +
                             "],\n  \"pixel_shift_by_row\": " + json_list(std::vector<int>(static_cast<std::size_t>(s.pixels), 0)) +
                             ",\n  \"udp_profile_lidar\": \"" + profile_text(s.profile) + "\"\n}";
  if (nested) {
    o << "{\n\"sensor_info\": {\"prod_line\": \"" << s.prod_line << "\", \"prod_sn\": \"992100000001\"},\n"
      << "\"config_params\": {\"lidar_mode\": " << mode << ", \"udp_port_lidar\": 7502},\n"
      << "\"beam_intrinsics\": {\n\"beam_altitude_angles\": " << json_list(s.altitude) << ",\n\"beam_azimuth_angles\": "
      << json_list(s.azimuth) << ",\n\"lidar_origin_to_beam_origin_mm\": " << s.origin_mm
      << ",\n\"beam_to_lidar_transform\": [1, 0, 0, " << s.origin_mm << ", 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]},\n"
      << "\"lidar_intrinsics\": {\"lidar_to_sensor_transform\": " << json_list(s.lidar_to_sensor) << "},\n"
      << "\"imu_intrinsics\": {\"imu_to_sensor_transform\": [1, 0, 0, 6.253, 0, 1, 0, -11.775, 0, 0, 1, 7.645, 0, 0, 0, 1]},\n"
      << "\"calibration_status\": {},\n"
      << "\"lidar_data_format\": " << format << "\n}\n";
  } else {
    o << "{\n\"beam_altitude_angles\": " << json_list(s.altitude) << ",\n\"beam_azimuth_angles\": " << json_list(s.azimuth)
      << ",\n\"data_format\": " << format << ",\n\"lidar_mode\": " << mode << ",\n\"lidar_origin_to_beam_origin_mm\": " << s.origin_mm
      << ",\n\"lidar_to_sensor_transform\": " << json_list(s.lidar_to_sensor) << ",\n\"prod_line\": \"" << s.prod_line
      << "\",\n\"udp_port_lidar\": 7502\n}\n";
  }
  return o.str();
}

struct Return {
  std::uint32_t range_mm = 0;
  std::uint8_t reflectivity = 0;
};

struct Column {
  std::uint16_t measurement_id = 0;
  std::uint64_t timestamp_ns = 0;
  bool valid = true;
  std::vector<std::array<Return, 2>> pixels;  // by row (the second return in the dual profile only)
};

inline void put(std::string& b, std::size_t at, std::uint64_t v, int bytes) {
  for (int i = 0; i < bytes; ++i) b[at + static_cast<std::size_t>(i)] = static_cast<char>(v >> (8 * i) & 0xFF);
}

// One lidar packet of columns_per_packet columns.
inline std::string packet(const Spec& s, std::uint16_t frame_id, const std::vector<Column>& cols, std::uint32_t init_id = 77) {
  std::string b(s.packet_size(), '\0');
  const bool legacy = s.profile == Profile::Legacy;
  if (!legacy) {
    put(b, 0, 1, 2);
    put(b, 2, frame_id, 2);
    put(b, 4, init_id, 3);
    put(b, 7, 992100000001ull, 5);
  }
  for (std::size_t c = 0; c < cols.size() && c < static_cast<std::size_t>(s.columns_per_packet); ++c) {
    const Column& col = cols[c];
    const std::size_t at = (legacy ? 0 : 32) + c * s.column_size();
    put(b, at, col.timestamp_ns, 8);
    put(b, at + 8, col.measurement_id, 2);
    if (legacy) {
      put(b, at + 10, frame_id, 2);
      put(b, at + 12, col.measurement_id * 90112u / static_cast<unsigned>(s.columns), 4);
      put(b, at + s.column_size() - 4, col.valid ? 0xFFFFFFFFu : 0u, 4);
    } else {
      put(b, at + 10, col.valid ? 1 : 0, 2);
    }
    for (std::size_t r = 0; r < col.pixels.size() && r < static_cast<std::size_t>(s.pixels); ++r) {
      const std::size_t p = at + (legacy ? 16 : 12) + r * s.pixel_size();
      const auto& ret = col.pixels[r];
      switch (s.profile) {
        case Profile::Legacy:
        case Profile::Single:
          put(b, p, ret[0].range_mm, 4);
          put(b, p + 4, ret[0].reflectivity, 1);
          put(b, p + 6, 1234, 2);  // signal, near-infrared: not read
          put(b, p + 8, 99, 2);
          break;
        case Profile::Dual:
          put(b, p, ret[0].range_mm, 3);
          put(b, p + 3, ret[0].reflectivity, 1);
          put(b, p + 4, ret[1].range_mm, 3);
          put(b, p + 7, ret[1].reflectivity, 1);
          break;
        case Profile::LowData:
          put(b, p, ret[0].range_mm / 8, 2);
          put(b, p + 2, ret[0].reflectivity, 1);
          put(b, p + 3, 7, 1);
          break;
      }
    }
  }
  return b;
}

// A whole frame: every packet, column m timestamped t0 + m * dt, its pixels from `pixel(m, row)`.
template <typename F>
std::vector<std::string> frame(const Spec& s, std::uint16_t frame_id, std::uint64_t t0, std::uint64_t dt, F pixel) {
  std::vector<std::string> out;
  for (int first = 0; first < s.columns; first += s.columns_per_packet) {
    std::vector<Column> cols;
    for (int m = first; m < first + s.columns_per_packet; ++m) {
      Column c;
      c.measurement_id = static_cast<std::uint16_t>(m);
      c.timestamp_ns = t0 + static_cast<std::uint64_t>(m) * dt;
      c.valid = s.window_first <= s.window_last ? (m >= s.window_first && m <= s.window_last)
                                                : (m >= s.window_first || m <= s.window_last);
      for (int r = 0; r < s.pixels; ++r) c.pixels.push_back(pixel(m, r));
      cols.push_back(c);
    }
    out.push_back(packet(s, frame_id, cols));
  }
  return out;
}

}  // namespace pl::test::ouster
