// Velodyne data packets for tests, written from the published layout: 12 blocks of 100 bytes (a
// 2-byte flag naming the bank of 32 lasers, the azimuth in 0.01 degree, 32 returns of a 2-byte
// distance count and a reflectivity byte), the time stamp (4 bytes, microseconds past the hour) and
// the factory bytes (return mode, product id), all little-endian. And the calibration YAML.
#pragma once

#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <string>
#include <string_view>

namespace pl::lidar::velodyne_test {

constexpr std::uint8_t kStrongest = 0x37, kLast = 0x38, kDual = 0x39;
constexpr std::uint8_t kVlp16 = 0x22, kVlp32C = 0x28, kHdl32E = 0x21, kVls128 = 0xA1;
constexpr std::uint16_t kBank[4] = {0xEEFF, 0xDDFF, 0xCCFF, 0xBBFF};
constexpr double kPi = 3.14159265358979323846;

class PacketWriter {
 public:
  PacketWriter& block(int b, std::uint16_t flag, std::uint16_t azimuth) {
    put16(100 * b, flag);
    put16(100 * b + 2, azimuth);
    return *this;
  }
  PacketWriter& ret(int b, int slot, std::uint16_t distance, std::uint8_t intensity) {
    put16(100 * b + 4 + 3 * slot, distance);
    bytes_[100 * b + 6 + 3 * slot] = intensity;
    return *this;
  }
  PacketWriter& tail(std::uint32_t toh_us, std::uint8_t return_mode, std::uint8_t product) {
    for (int i = 0; i < 4; ++i) bytes_[1200 + i] = static_cast<std::uint8_t>(toh_us >> (8 * i));
    bytes_[1204] = return_mode;
    bytes_[1205] = product;
    return *this;
  }
  std::string str() const { return std::string(reinterpret_cast<const char*>(bytes_.data()), bytes_.size()); }
  std::array<std::uint8_t, 1206>& bytes() { return bytes_; }

 private:
  void put16(int at, std::uint16_t v) {
    bytes_[at] = static_cast<std::uint8_t>(v);
    bytes_[at + 1] = static_cast<std::uint8_t>(v >> 8);
  }
  std::array<std::uint8_t, 1206> bytes_{};
};

// One laser's entry of the calibration YAML (angles in degrees here, radians in the file).
struct LaserCal {
  double elevation_deg = 0, rot_deg = 0;
  double dist = 0, dist_x = 0, dist_y = 0, vert_offset = 0, horiz_offset = 0;
  bool two_point = false;
  double focal_distance = 0, focal_slope = 0;
  int min_intensity = 0, max_intensity = 255;
};

// The makers' YAML for `lasers` lasers, laser i as `cal(i)` says.
inline std::string calibration_yaml(int lasers, const std::function<LaserCal(int)>& cal) {
  std::string y = "lasers:\n";
  for (int i = 0; i < lasers; ++i) {
    const LaserCal c = cal(i);
    auto num = [](double v) {
      char buf[40];
      std::snprintf(buf, sizeof buf, "%.17g", v);
      return std::string(buf);
    };
    y += "    - {\n        dist_correction: " + num(c.dist) + ",\n        dist_correction_x: " + num(c.dist_x) +
         ",\n        dist_correction_y: " + num(c.dist_y) + ",\n        focal_distance: " + num(c.focal_distance) +
         ",\n        focal_slope: " + num(c.focal_slope) + ",\n        horiz_offset_correction: " + num(c.horiz_offset) +
         ",\n        laser_id: " + std::to_string(i) + ",\n        max_intensity: " + std::to_string(c.max_intensity) +
         ",\n        min_intensity: " + std::to_string(c.min_intensity) +
         ",\n        rot_correction: " + num(c.rot_deg * kPi / 180) +
         ",\n        two_pt_correction_available: " + (c.two_point ? "true" : "false") +
         ",\n        vert_correction: " + num(c.elevation_deg * kPi / 180) +
         ",\n        vert_offset_correction: " + num(c.vert_offset) + ",\n    }\n";
  }
  return y + "num_lasers: " + std::to_string(lasers) + "\ndistance_resolution: 0.002\n";
}

// A plain calibration: elevations spread from -15 degrees up by 30/(n-1), laser i turned by
// rot_deg(i) (VLP-16 style interleaving is not needed for the tests).
inline std::string plain_calibration(int lasers, double rot_step_deg = 0) {
  return calibration_yaml(lasers, [&](int i) {
    LaserCal c;
    c.elevation_deg = -15 + 30.0 * i / (lasers - 1);
    c.rot_deg = rot_step_deg * (i % 4 - 1.5);
    return c;
  });
}

// Where the makers' formula puts a return (no offsets): the ROS frame, x forward, y left.
struct Xyz {
  double x, y, z;
};
inline Xyz place(double distance_m, double elevation_deg, double azimuth_deg) {
  const double v = elevation_deg * kPi / 180, a = azimuth_deg * kPi / 180;
  return {distance_m * std::cos(v) * std::cos(a), -distance_m * std::cos(v) * std::sin(a), distance_m * std::sin(v)};
}

}  // namespace pl::lidar::velodyne_test
