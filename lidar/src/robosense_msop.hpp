// One RoboSense MSOP packet -> its blocks' azimuths and times and its returns as points, for the
// settings the decoder has learnt (model, angles, return mode, rotation rate, range limits).
#pragma once

#include <array>
#include <cstdint>
#include <string_view>
#include <vector>

#include "pl/lidar/decoder.hpp"
#include "robosense_calibration.hpp"
#include "robosense_format.hpp"

namespace pl::lidar::robosense {

// What turns a packet's slots into points. Channels are the lasers ranked by elevation, 0 = lowest
// (the maker's driver numbers them so).
struct Geometry {
  const Model* model = nullptr;
  SlotPlan plan;
  std::vector<float> cos_el, sin_el, elevation_deg;                        // by laser
  std::vector<int> azimuth_offset;                                         // by laser, 0.01°
  std::vector<std::uint16_t> channel;                                      // by laser
  ReturnType first = ReturnType::Strongest, second = ReturnType::Unknown;  // single return: first only
  int nominal_step = 20;  // 0.01°: the turn between blocks where the next block's azimuth is not at hand
  int rpm = 600;
  float min_m = 0, max_m = 0;
};

// The return mode code of a DIFOP packet: dual, or the single return's type.
struct ReturnMode {
  bool dual = false;
  ReturnType first = ReturnType::Strongest, second = ReturnType::Unknown;
};
ReturnMode return_mode(Family family, std::uint8_t code);

Geometry make_geometry(const Model& m, const Angles& a, ReturnMode mode, int rpm, double min_m, double max_m);

struct DecodedPacket {
  std::array<int, kBlocks> azimuth{};                  // 0.01°, as the block reports it
  std::array<std::int64_t, kBlocks> time_ns{};         // of the block's first firing
  std::array<std::size_t, kBlocks + 1> first_point{};  // points of block k: [first_point[k], first_point[k+1])
  std::vector<Point> points;                           // time_s left 0: point_ns holds their times
  std::vector<std::int64_t> point_ns;
};

// Why a packet of model `m` cannot be decoded (wrong magic, a block without its flag, an azimuth past
// 359.99°, an unknown distance unit), or nullptr when it can. `p` is kPacketBytes long.
const char* check_msop(std::string_view p, const Model& m);

// The packet's time: the sensor's (calendar time or seconds since 1970), or `receive_ns` where the
// sensor's calendar time is not a date.
std::int64_t packet_time_ns(std::string_view p, Family family, std::int64_t receive_ns);

// A packet check_msop accepted.
void decode_msop(std::string_view p, std::int64_t receive_ns, const Geometry& g, DecodedPacket& out);

}  // namespace pl::lidar::robosense
