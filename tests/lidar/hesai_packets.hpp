// Test-side writer of Hesai point-cloud packets, from the makers' published layouts (user manuals,
// "Point Cloud Data Packet"): firings in, packets out, as each model sends them. Independent of the
// decoder's own tables, so that a test compares two readings of the manuals.
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

namespace pl::lidar::test {

struct HesaiFormat {
  const char* model;
  int channels, blocks;
  int header;        // 0: none (each block opens with 0xFFEE), 8: Pandar64, 12: XT and QT
  int major, minor;  // the 12-byte header's protocol version
  int unit;          // bytes per channel in a block
  int after_body;    // QT128: the body's CRC and the functional-safety part
  int tail;          // tail bytes the decoder reads
  int trailer;       // optional bytes after them (UDP sequence), counted in `size`
  int mode_at, rpm_at, micros_at, date_at, flag_at;  // in the tail; flag_at -1: none
  int year_base;

  int block_bytes() const { return (header == 0 ? 2 : 0) + 2 + channels * unit; }
  int tail_start() const { return header + blocks * block_bytes() + after_body; }
  int size() const { return tail_start() + tail + trailer; }
};

inline const std::vector<HesaiFormat>& hesai_formats() {
  static const std::vector<HesaiFormat> formats = {
      {"Pandar40P", 40, 10, 0, 0, 0, 3, 0, 22, 0, 14, 8, 10, 16, -1, 2000},
      {"Pandar64", 64, 6, 8, 0, 0, 3, 0, 22, 4, 14, 8, 10, 16, -1, 1900},
      {"PandarQT64", 64, 4, 12, 3, 1, 4, 0, 24, 4, 16, 10, 12, 18, -1, 1900},
      {"PandarQT128", 128, 2, 12, 3, 2, 4, 21, 34, 32, 12, 13, 21, 15, 5, 1900},
      {"PandarXT16", 16, 8, 12, 6, 1, 4, 0, 24, 4, 10, 11, 19, 13, -1, 1900},
      {"PandarXT32", 32, 8, 12, 6, 1, 4, 0, 24, 4, 10, 11, 19, 13, -1, 1900},
      {"PandarXT32M", 32, 6, 12, 6, 1, 4, 0, 24, 4, 10, 11, 19, 13, -1, 1900},
  };
  return formats;
}

inline const HesaiFormat& hesai_format(const std::string& model) {
  for (const auto& f : hesai_formats())
    if (model == f.model) return f;
  throw std::runtime_error("no Hesai format " + model);
}

struct HesaiBlock {
  std::uint16_t azimuth_cdeg = 0;
  std::vector<std::uint16_t> distance;     // by channel, in the packet's unit (4 mm); 0: no return
  std::vector<std::uint8_t> reflectivity;  // by channel
};

struct HesaiTail {
  std::uint8_t return_mode = 0x37;  // strongest
  std::uint16_t rpm = 600;
  int year = 2024, month = 5, day = 17, hour = 8, minute = 30, second = 12;
  std::uint32_t micros = 250000;
  std::uint8_t loop_flag = 0;       // QT128
};

// One packet of `format` holding `blocks` (as many as the format has).
inline std::string write_hesai_packet(const HesaiFormat& f, const std::vector<HesaiBlock>& blocks, const HesaiTail& t) {
  std::string p(static_cast<std::size_t>(f.size()), '\0');
  auto put8 = [&](int at, int v) { p[static_cast<std::size_t>(at)] = static_cast<char>(v & 0xFF); };
  auto put16 = [&](int at, int v) { put8(at, v); put8(at + 1, v >> 8); };
  auto put32 = [&](int at, std::uint32_t v) { put16(at, static_cast<int>(v & 0xFFFF)); put16(at + 2, static_cast<int>(v >> 16)); };
  if (f.header == 8) {
    put8(0, 0xEE), put8(1, 0xFF), put8(2, f.channels), put8(3, f.blocks), put8(5, 4);
  } else if (f.header == 12) {
    put8(0, 0xEE), put8(1, 0xFF), put8(2, f.major), put8(3, f.minor), put8(6, f.channels), put8(7, f.blocks);
    put8(9, 4), put8(10, 2), put8(11, 1);
  }
  for (int b = 0; b < f.blocks; ++b) {
    int at = f.header + b * f.block_bytes();
    if (f.header == 0) put8(at, 0xFF), put8(at + 1, 0xEE), at += 2;
    const HesaiBlock& block = blocks.at(static_cast<std::size_t>(b));
    put16(at, block.azimuth_cdeg);
    for (int c = 0; c < f.channels; ++c) {
      put16(at + 2 + c * f.unit, block.distance.at(static_cast<std::size_t>(c)));
      put8(at + 2 + c * f.unit + 2, block.reflectivity.at(static_cast<std::size_t>(c)));
    }
  }
  const int tail = f.tail_start();
  put8(tail + f.mode_at, t.return_mode);
  put16(tail + f.rpm_at, t.rpm);
  put32(tail + f.micros_at, t.micros);
  const int date[6] = {t.year - f.year_base, t.month, t.day, t.hour, t.minute, t.second};
  for (int i = 0; i < 6; ++i) put8(tail + f.date_at + i, date[i]);
  if (f.flag_at >= 0) put8(tail + f.flag_at, t.loop_flag);
  return p;
}

// Seconds since 1970 of the tail's date (the test's own count: days of each month walked).
inline std::int64_t hesai_tail_seconds(const HesaiTail& t) {
  auto leap = [](int y) { return (y % 4 == 0 && y % 100 != 0) || y % 400 == 0; };
  const int month_days[12] = {31, 28, 31, 30, 31, 30, 31, 31, 30, 31, 30, 31};
  std::int64_t days = 0;
  for (int y = 1970; y < t.year; ++y) days += leap(y) ? 366 : 365;
  for (int m = 1; m < t.month; ++m) days += month_days[m - 1] + (m == 2 && leap(t.year) ? 1 : 0);
  days += t.day - 1;
  return days * 86400 + t.hour * 3600 + t.minute * 60 + t.second;
}

// An angle file for `channels` lasers: elevations spread over [-15, 15] degrees out of channel
// order (channel c at rank (7 c) mod channels, so rings differ from channels), azimuth offsets of
// -1.5 to +1.5 degrees in four steps.
inline std::string hesai_angle_file(int channels, std::vector<double>* elevation = nullptr, std::vector<double>* offset = nullptr) {
  std::string text = "Laser id,Elevation,Azimuth\n";
  for (int c = 0; c < channels; ++c) {
    const int rank = (7 * c) % channels;
    const std::string el = std::to_string(channels == 1 ? 0.0 : -15.0 + 30.0 * rank / (channels - 1));
    const std::string off = std::to_string(-1.5 + (c % 4));
    if (elevation) elevation->push_back(std::stod(el));
    if (offset) offset->push_back(std::stod(off));
    text += std::to_string(c + 1) + "," + el + "," + off + "\n";
  }
  return text;
}

}  // namespace pl::lidar::test
