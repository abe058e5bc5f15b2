// Options, vendor names and the choice of decoder.
#include <cmath>

#include "decoders.hpp"
#include "pl/common/error.hpp"

namespace pl::lidar {

const char* vendor_name(Vendor v) {
  switch (v) {
    case Vendor::Velodyne: return "Velodyne";
    case Vendor::Hesai: return "Hesai";
    case Vendor::RoboSense: return "RoboSense";
    case Vendor::Ouster: return "Ouster";
  }
  return "?";
}

void DecoderOptions::validate() const {
  if (!(min_range_m >= 0) || !(max_range_m > min_range_m))
    throw Error("lidar decoder: max_range_m " + std::to_string(max_range_m) + " must exceed min_range_m " +
                std::to_string(min_range_m) + " >= 0");
  if (!(cut_azimuth_deg >= 0 && cut_azimuth_deg < 360))
    throw Error("lidar decoder: cut_azimuth_deg " + std::to_string(cut_azimuth_deg) + " must lie in [0, 360)");
}

std::optional<Vendor> vendor_of_packet(std::string_view p) {
  auto at = [&](std::size_t i) { return static_cast<unsigned char>(p[i]); };
  if (p.size() == 1206 && at(0) == 0xFF && at(1) == 0xEE) return Vendor::Velodyne;
  if (p.size() >= 12 && at(0) == 0xEE && at(1) == 0xFF) return Vendor::Hesai;
  if (p.size() >= 4 && ((at(0) == 0x55 && at(1) == 0xAA && at(2) == 0x05) || (at(0) == 0xA5 && at(1) == 0xFF && at(2) == 0x00 && at(3) == 0x5A)))
    return Vendor::RoboSense;
  return std::nullopt;
}

std::unique_ptr<PacketDecoder> make_decoder(Vendor vendor, const DecoderOptions& options) {
  options.validate();
  switch (vendor) {
    case Vendor::Velodyne: return make_velodyne_decoder(options);
    case Vendor::Hesai: return make_hesai_decoder(options);
    case Vendor::RoboSense: return make_robosense_decoder(options);
    case Vendor::Ouster: return make_ouster_decoder(options);
  }
  throw Error("lidar decoder: unknown vendor");
}

}  // namespace pl::lidar
