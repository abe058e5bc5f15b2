// RoboSense packets written from the published layouts (RS-LiDAR-16 and RS-Helios-16P user manuals):
// returns placed in blocks and slots -> 1248-byte MSOP packets; rotation rate, return mode and laser
// angles -> DIFOP packets; angles -> the maker's angle file. For the decoder's tests and fuzz seeds.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <sstream>
#include <string>
#include <vector>

namespace pl::lidar::rs_test {

enum class Kind { Rs16, Helios };

struct Return {
  int slot = 0;           // 0-31 in the block
  std::uint16_t raw = 0;  // distance in the packet's unit (RS-LiDAR-16 5 mm; Helios 2.5 mm)
  std::uint8_t intensity = 0;
};

struct Block {
  int azimuth = 0;  // 0.01°
  std::vector<Return> returns;
};

inline void put16(std::string& s, std::size_t at, unsigned v) {
  s[at] = static_cast<char>(v >> 8 & 0xFF);
  s[at + 1] = static_cast<char>(v & 0xFF);
}

// An MSOP packet of 12 blocks (fewer given: the rest repeat the last azimuth, empty). Its time: for a
// Helios, seconds and microseconds since 1970; for an RS-LiDAR-16, 2024-03-01 12:00:00 UTC plus
// `us_after_noon` (below one minute).
inline std::string msop(Kind kind, const std::vector<Block>& blocks, std::int64_t helios_us, std::int64_t us_after_noon = 0) {
  std::string p(1248, '\0');
  const unsigned char rs16[8] = {0x55, 0xAA, 0x05, 0x0A, 0x5A, 0xA5, 0x50, 0xA0};
  const unsigned char helios[4] = {0x55, 0xAA, 0x05, 0x5A};
  if (kind == Kind::Rs16) {
    for (int i = 0; i < 8; ++i) p[i] = static_cast<char>(rs16[i]);
    const char when[6] = {24, 3, 1, 12, 0, static_cast<char>(us_after_noon / 1000000)};
    for (int i = 0; i < 6; ++i) p[20 + i] = when[i];
    put16(p, 26, static_cast<unsigned>(us_after_noon / 1000 % 1000));
    put16(p, 28, static_cast<unsigned>(us_after_noon % 1000));
  } else {
    for (int i = 0; i < 4; ++i) p[i] = static_cast<char>(helios[i]);
    p[17] = 1;  // 2.5 mm
    const std::int64_t s = helios_us / 1000000, us = helios_us % 1000000;
    for (int i = 0; i < 6; ++i) p[20 + i] = static_cast<char>(s >> (8 * (5 - i)) & 0xFF);
    put16(p, 26, static_cast<unsigned>(us >> 16));
    put16(p, 28, static_cast<unsigned>(us & 0xFFFF));
  }
  for (std::size_t k = 0; k < 12; ++k) {
    const std::size_t at = 42 + 100 * k;
    p[at] = static_cast<char>(0xFF);
    p[at + 1] = static_cast<char>(0xEE);
    const Block& b = blocks.empty() ? Block{} : blocks[std::min(k, blocks.size() - 1)];
    put16(p, at + 2, static_cast<unsigned>(b.azimuth));
    if (k >= blocks.size()) continue;
    for (const Return& r : b.returns) {
      put16(p, at + 4 + 3 * static_cast<std::size_t>(r.slot), r.raw);
      p[at + 6 + 3 * static_cast<std::size_t>(r.slot)] = static_cast<char>(r.intensity);
    }
  }
  p[1246] = 0x00;
  p[1247] = static_cast<char>(0xFF);
  return p;
}

// 12 empty blocks from `azimuth`, `step` apart (0.01°, past 360° wrapping).
inline std::vector<Block> turning(int azimuth, int step) {
  std::vector<Block> b(12);
  for (int k = 0; k < 12; ++k) b[static_cast<std::size_t>(k)].azimuth = (azimuth + k * step) % 36000;
  return b;
}

// A DIFOP packet. return_mode: Helios 0x00 dual, 0x04 strongest, 0x05 last, 0x06 first; RS-LiDAR-16
// 0x00 dual, 0x01 strongest, 0x02 last. Angles in degrees, by laser (an RS-LiDAR-16 has no azimuth
// offsets and keeps its elevations' magnitudes: its first 8 lasers point down). No angles: an empty
// table (all 0xFF).
inline std::string difop(Kind kind, int rpm, int return_mode, const std::vector<double>& elevation,
                         const std::vector<double>& offset = {}) {
  std::string p(1248, '\0');
  const unsigned char magic[8] = {0xA5, 0xFF, 0x00, 0x5A, 0x11, 0x11, 0x55, 0x55};
  for (int i = 0; i < 8; ++i) p[i] = static_cast<char>(magic[i]);
  put16(p, 8, static_cast<unsigned>(rpm));
  p[300] = static_cast<char>(return_mode);
  if (kind == Kind::Rs16) {
    for (std::size_t l = 0; l < 16; ++l) {
      const long v = elevation.empty() ? 0xFFFFFF : std::lround(std::fabs(elevation[l]) * 1e4);
      for (int i = 0; i < 3; ++i) p[1165 + 3 * l + static_cast<std::size_t>(i)] = static_cast<char>(v >> (8 * (2 - i)) & 0xFF);
    }
  } else {
    for (std::size_t l = 0; l < 32; ++l) {
      const bool has = l < elevation.size();
      const double e = has ? elevation[l] : 0, h = has && l < offset.size() ? offset[l] : 0;
      p[468 + 3 * l] = static_cast<char>(elevation.empty() ? 0xFF : e < 0);
      put16(p, 469 + 3 * l, elevation.empty() ? 0xFFFF : static_cast<unsigned>(std::lround(std::fabs(e) * 100)));
      p[564 + 3 * l] = static_cast<char>(elevation.empty() ? 0xFF : h < 0);
      put16(p, 565 + 3 * l, elevation.empty() ? 0xFFFF : static_cast<unsigned>(std::lround(std::fabs(h) * 100)));
    }
  }
  p[1246] = 0x0F;
  p[1247] = static_cast<char>(0xF0);
  return p;
}

// The maker's angle file: one line a laser, "elevation,azimuth offset" in degrees.
inline std::string angle_file(const std::vector<double>& elevation, const std::vector<double>& offset) {
  std::ostringstream s;
  for (std::size_t l = 0; l < elevation.size(); ++l) s << elevation[l] << "," << (l < offset.size() ? offset[l] : 0.0) << "\t\n";
  return s.str();
}

}  // namespace pl::lidar::rs_test
