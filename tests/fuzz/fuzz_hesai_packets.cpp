// Fuzz target: a run of Hesai packets through one decoder, and an angle-correction file.
// Input: one byte of settings (bits 0-2: the model whose made-up calibration to use, 7: the input's
// own; bit 3: name that model in the options; bits 4-5: the cut azimuth), a 2-byte length and that
// many bytes of calibration text, then packets, each a 2-byte little-endian length and its bytes.
// Refusing with pl::Error is fine (a calibration that is not one, or that fits no model the packets
// name); what comes out must be finite, of a channel the sensor has, and counted.
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

struct Model {
  const char* name;
  int channels;
};
constexpr Model kModels[7] = {{"Pandar40P", 40},   {"Pandar64", 64},   {"PandarQT64", 64},  {"PandarQT128", 128},
                              {"PandarXT16", 16},  {"PandarXT32", 32}, {"PandarXT32M", 32}};

std::string made_up_calibration(int channels) {
  std::string text = "Laser id,Elevation,Azimuth\n";
  for (int c = 0; c < channels; ++c)
    text += std::to_string(c + 1) + "," + std::to_string(-15.0 + 0.25 * c) + "," + std::to_string((c % 3) - 1) + "\n";
  return text;
}

void check(const pl::lidar::Sweep& s, const pl::lidar::SensorInfo& info, const pl::lidar::DecoderOptions& o) {
  for (const auto& p : s.points) {
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z) || !std::isfinite(p.time_s)) std::abort();
    if (p.channel >= info.channels) std::abort();
    if (!(p.azimuth_deg >= 0 && p.azimuth_deg < 360)) std::abort();
    if (p.distance_m < o.min_range_m - 1e-3 || p.distance_m > o.max_range_m + 1e-3) std::abort();
    if (!(p.intensity >= 0 && p.intensity <= 255)) std::abort();
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 3) return 0;
  const int settings = data[0];
  const std::size_t text_size = std::min<std::size_t>(data[1] | data[2] << 8, size - 3);
  const std::string text(reinterpret_cast<const char*>(data + 3), text_size);
  std::size_t at = 3 + text_size;

  pl::lidar::DecoderOptions o;
  const int model = settings & 7;
  o.calibration_text = model == 7 ? text : made_up_calibration(kModels[model].channels);
  if (model < 7 && (settings & 8)) o.model = kModels[model].name;
  const double cuts[4] = {0.0, 90.0, 180.0, 359.99};
  o.cut_azimuth_deg = cuts[(settings >> 4) & 3];
  if (model < 7) {
    try {  // the calibration parser on the input's text too
      pl::lidar::DecoderOptions own = o;
      own.model.clear();
      own.calibration_text = text.empty() ? std::string("x") : text;
      (void)pl::lidar::make_decoder(pl::lidar::Vendor::Hesai, own);
    } catch (const pl::Error&) {
    }
  }

  std::unique_ptr<pl::lidar::PacketDecoder> decoder;
  try {
    decoder = pl::lidar::make_decoder(pl::lidar::Vendor::Hesai, o);
  } catch (const pl::Error&) {
    return 0;
  }
  std::vector<pl::lidar::Sweep> out;
  std::size_t fed = 0;
  try {
    while (at + 2 <= size) {
      const std::size_t n = std::min<std::size_t>(data[at] | data[at + 1] << 8, size - at - 2);
      // A copy of exactly the packet's bytes: reading past them is the sanitizer's to see.
      const std::string packet(reinterpret_cast<const char*>(data + at + 2), n);
      at += 2 + n;
      ++fed;
      decoder->add(packet, static_cast<std::int64_t>(fed), out);
    }
    decoder->finish(out);
  } catch (const pl::Error&) {
    return 0;
  }
  const auto& counts = decoder->counts();
  if (counts.packets != fed || counts.skipped > counts.packets || counts.sweeps != out.size()) std::abort();
  if (counts.skipped > 0 && counts.last_problem.empty()) std::abort();
  std::size_t points = 0;
  const auto info = decoder->info();
  for (const auto& s : out) {
    check(s, info, o);
    points += s.points.size();
  }
  if (points != counts.points) std::abort();
  return 0;
}
