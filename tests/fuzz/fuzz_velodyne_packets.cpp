// Fuzz target: a run of Velodyne data packets (from a recording or the network: any bytes) and a
// calibration file, fed to one decoder. Input: byte 0 picks the model option (0: told by the
// packets), byte 1 the cut azimuth, bytes 2-3 the length of the calibration text that follows; then
// packets, each a 2-byte length and its bytes. A calibration the decoder refuses (pl::Error) is
// replaced by a valid one of the laser count the first packet's product id needs. Refusing with
// pl::Error is the decoder's job; every point that comes back must be finite and in range, and the
// counts must add up.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "pl/common/error.hpp"
#include "pl/lidar/decoder.hpp"

namespace {

const char* const kModels[] = {"", "VLP-16", "VLP-16 Hi-Res", "VLP-32C", "HDL-32E", "HDL-64E S2", "HDL-64E S3", "VLS-128"};
const int kModelLasers[] = {0, 16, 16, 32, 32, 64, 64, 128};

// A valid calibration of n lasers (made once per count: YAML parsing is most of a run's time), with
// offsets and the two-point and focal corrections on every eighth.
const std::string& calibration(int n) {
  static std::string made[129];
  std::string& y = made[n];
  if (!y.empty()) return y;
  y = "lasers:\n";
  for (int i = 0; i < n; ++i) {
    y += "- {laser_id: " + std::to_string(i) + ", rot_correction: " + std::to_string(0.01 * (i % 7 - 3)) +
         ", vert_correction: " + std::to_string(-0.4 + 0.8 * i / n);
    if (i % 8 == 0)
      y += ", dist_correction: 0.01, dist_correction_x: 0.02, dist_correction_y: -0.01, vert_offset_correction: 0.2,"
           " horiz_offset_correction: 0.026, two_pt_correction_available: true, focal_distance: 1000,"
           " focal_slope: 1.5, min_intensity: 5, max_intensity: 250";
    y += "}\n";
  }
  return y;
}

int lasers_for_product(std::uint8_t product) {
  switch (product) {
    case 0x22: case 0x24: return 16;
    case 0x21: case 0x28: return 32;
    case 0xA1: return 128;
    default: return 64;
  }
}

void check(const pl::lidar::PacketDecoder& d, const std::vector<pl::lidar::Sweep>& sweeps, std::size_t& points) {
  const int channels = d.info().channels;
  for (const auto& s : sweeps) {
    if (s.points.empty()) std::abort();
    for (const auto& p : s.points) {
      if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z) || !std::isfinite(p.time_s)) std::abort();
      if (p.channel >= channels || !(p.intensity >= 0 && p.intensity <= 255)) std::abort();
      if (!(p.azimuth_deg >= 0 && p.azimuth_deg < 360) || !(p.time_s >= 0)) std::abort();
      if (!(p.distance_m >= 0.3f && p.distance_m <= 300)) std::abort();
    }
    points += s.points.size();
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 4) return 0;
  const int model = data[0] % 8;
  pl::lidar::DecoderOptions opt;
  opt.model = kModels[model];
  opt.cut_azimuth_deg = data[1] * 360.0 / 256;
  std::size_t at = 4;
  const std::size_t cal_size = std::min<std::size_t>(data[2] | data[3] << 8, size - at);
  opt.calibration_text.assign(reinterpret_cast<const char*>(data + at), cal_size);
  at += cal_size;
  std::vector<std::string_view> packets;
  while (at + 2 <= size) {
    const std::size_t n = std::min<std::size_t>(data[at] | data[at + 1] << 8, size - at - 2);
    packets.emplace_back(reinterpret_cast<const char*>(data + at + 2), n);
    at += 2 + n;
  }

  std::unique_ptr<pl::lidar::PacketDecoder> d;
  try {
    d = pl::lidar::make_decoder(pl::lidar::Vendor::Velodyne, opt);
  } catch (const pl::Error&) {
    const std::uint8_t product = !packets.empty() && packets[0].size() == 1206 ? static_cast<std::uint8_t>(packets[0][1205]) : 0;
    opt.calibration_text = calibration(model ? kModelLasers[model] : lasers_for_product(product));
    d = pl::lidar::make_decoder(pl::lidar::Vendor::Velodyne, opt);
  }
  std::vector<pl::lidar::Sweep> sweeps;
  std::size_t points = 0, added = 0;
  std::int64_t stamp = 1'700'000'000'000'000'000;
  try {
    for (const auto& p : packets) {
      ++added;
      d->add(p, stamp, sweeps);
      stamp += 1'327'104;
      check(*d, sweeps, points);
      sweeps.clear();
    }
  } catch (const pl::Error&) {
    return 0;  // a model the packets name that it cannot decode, or a calibration that does not fit
  }
  d->finish(sweeps);
  check(*d, sweeps, points);
  const auto& c = d->counts();
  if (c.packets != added || c.skipped > c.packets || c.points != points) std::abort();
  return 0;
}
