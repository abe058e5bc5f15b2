// Fuzz target: the RoboSense decoder (lidar/src/robosense*.cpp) on any run of packets, with or without
// an angle file. Input: one byte of settings (bits 0-1 the model: none, RS-LiDAR-16, Helios-16P,
// Helios-32; bit 2: an angle file follows; bits 3-4 the cut azimuth: 0°, 90°, 180°, 359.99°), then with
// bit 2 a 2-byte big-endian length and the angle file's text, then packets, each a 2-byte big-endian
// length and its bytes. Refusing with pl::Error is the decoder's job; every point that comes back must
// be finite, on a channel the sensor has, within the range limits, at an azimuth in [0°, 360°).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <string_view>
#include <vector>

#include "pl/common/error.hpp"
#include "pl/lidar/decoder.hpp"

namespace {

void check(const std::vector<pl::lidar::Sweep>& sweeps, const pl::lidar::PacketDecoder& d, const pl::lidar::DecoderOptions& o) {
  const pl::lidar::SensorInfo info = d.info();
  for (const auto& s : sweeps) {
    if (s.points.empty()) std::abort();
    for (const auto& p : s.points) {
      if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z) || !std::isfinite(p.time_s)) std::abort();
      if (p.channel >= info.channels || !(p.azimuth_deg >= 0 && p.azimuth_deg < 360)) std::abort();
      if (!(p.distance_m >= static_cast<float>(o.min_range_m) && p.distance_m <= static_cast<float>(o.max_range_m))) std::abort();
      if (!(std::abs(p.elevation_deg) < 90) || !(p.intensity >= 0 && p.intensity <= 255)) std::abort();
      // The point lies where its distance says (the lens sits 4 cm off the axis).
      if (std::abs(std::sqrt(p.x * p.x + p.y * p.y + p.z * p.z) - p.distance_m) > 0.05f) std::abort();
    }
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  static const char* const kModels[] = {"", "RS-LiDAR-16", "Helios-16P", "Helios-32"};
  static const double kCuts[] = {0, 90, 180, 359.99};
  pl::lidar::DecoderOptions o;
  o.model = kModels[data[0] & 3];
  o.cut_azimuth_deg = kCuts[data[0] >> 3 & 3];
  o.min_range_m = 0.2;
  std::size_t at = 1;
  auto length = [&]() -> std::size_t {
    if (at + 2 > size) {
      at = size;
      return 0;
    }
    const std::size_t n = static_cast<std::size_t>(data[at]) << 8 | data[at + 1];
    at += 2;
    return std::min(n, size - at);
  };
  if (data[0] & 4) {
    const std::size_t n = length();
    o.calibration_text.assign(reinterpret_cast<const char*>(data + at), n);
    at += n;
    if (o.calibration_text.empty()) o.calibration_text = "\n";  // empty text would mean "no file"
  }
  std::vector<pl::lidar::Sweep> sweeps;
  try {
    auto d = pl::lidar::make_decoder(pl::lidar::Vendor::RoboSense, o);
    while (at + 2 <= size) {
      const std::size_t n = length();
      d->add(std::string_view(reinterpret_cast<const char*>(data + at), n), 1000000000, sweeps);
      at += n;
      check(sweeps, *d, o);
      sweeps.clear();
    }
    d->finish(sweeps);
    check(sweeps, *d, o);
    const auto& c = d->counts();
    if (c.skipped > c.packets) std::abort();
  } catch (const pl::Error&) {
  }
  return 0;
}
