// Fuzz target: Ouster lidar packets (a pcap's or an ouster_ros bag's, from any sensor or none) fed
// to one decoder, and the metadata JSON it is made from.
//   Input: a selector byte, a 2-byte length L and L bytes of metadata text, then packets, each a
// 2-byte little-endian length and its bytes. The text is always given to the metadata parser; with
// the selector's bit 3 set, a decoder made from it (if it is accepted) takes the packets; otherwise
// a small built-in sensor (8 beams, 4 columns a packet, 64 a frame) of the profile bits 0-1 name,
// its metadata flat or nested (bit 2), with a column window that wraps (bit 4).
// Checked: every point finite and within the range limits, its channel a beam of the sensor, its
// azimuth in [0, 360), its time not before the sweep's stamp; the counts agree with what came out.
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <string_view>
#include <vector>

#include "../lidar/ouster_packets.hpp"
#include "pl/common/error.hpp"
#include "pl/lidar/decoder.hpp"

namespace {

namespace ot = pl::test::ouster;

std::string builtin_metadata(std::uint8_t selector) {
  ot::Spec s;
  s.profile = static_cast<ot::Profile>(selector & 3);
  s.prod_line = "OS-0-32";
  s.pixels = 8;
  s.columns_per_packet = 4;
  s.columns = 64;
  s.altitude.resize(8);
  s.azimuth.resize(8);
  if (selector & 16) s.window_first = 60, s.window_last = 11;
  else s.window_last = 63;
  return ot::metadata_json(s, selector & 4);
}

void check(const pl::lidar::PacketDecoder& d, const std::vector<pl::lidar::Sweep>& sweeps, const pl::lidar::DecoderOptions& o) {
  const int channels = d.info().channels;
  std::size_t points = 0;
  for (const auto& s : sweeps) {
    if (s.points.empty()) std::abort();
    for (const auto& p : s.points) {
      if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z) || !std::isfinite(p.time_s)) std::abort();
      if (p.channel >= channels || p.time_s < 0 || !(p.azimuth_deg >= 0 && p.azimuth_deg < 360)) std::abort();
      if (p.distance_m < o.min_range_m - 1e-3 || p.distance_m > o.max_range_m + 1e-3) std::abort();
      if (p.intensity < 0 || p.intensity > 255) std::abort();
    }
    points += s.points.size();
  }
  const auto& c = d.counts();
  if (c.points != points || c.sweeps != sweeps.size() || c.skipped > c.packets) std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::string_view in(reinterpret_cast<const char*>(data), size);
  if (in.size() < 3) return 0;
  const auto selector = static_cast<std::uint8_t>(in[0]);
  const std::size_t text_size = static_cast<std::uint8_t>(in[1]) | static_cast<std::size_t>(static_cast<std::uint8_t>(in[2])) << 8;
  in.remove_prefix(3);
  const std::string_view text = in.substr(0, text_size);
  in.remove_prefix(text.size());

  pl::lidar::DecoderOptions o;
  o.min_range_m = 0.5;
  o.max_range_m = 200;
  std::unique_ptr<pl::lidar::PacketDecoder> decoder;
  if (!text.empty()) {
    o.calibration_text = std::string(text);
    try {
      decoder = pl::lidar::make_decoder(pl::lidar::Vendor::Ouster, o);
    } catch (const pl::Error&) {
    }
  }
  if (!(selector & 8) || !decoder) {
    o.calibration_text = builtin_metadata(selector);
    decoder = pl::lidar::make_decoder(pl::lidar::Vendor::Ouster, o);
  }

  std::vector<pl::lidar::Sweep> sweeps;
  std::int64_t stamp = 1'000'000'000;
  while (in.size() >= 2) {
    const std::size_t n = static_cast<std::uint8_t>(in[0]) | static_cast<std::size_t>(static_cast<std::uint8_t>(in[1])) << 8;
    in.remove_prefix(2);
    const std::string_view packet = in.substr(0, n);
    in.remove_prefix(packet.size());
    decoder->add(packet, stamp, sweeps);
    stamp += 100'000;
  }
  decoder->finish(sweeps);
  check(*decoder, sweeps, o);
  return 0;
}
