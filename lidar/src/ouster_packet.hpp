// Where things lie in an Ouster lidar packet, per profile (the Ouster SDK's packet format, read
// there): all fields little-endian.
//   LEGACY: no packet header or footer. Each column: a 16-byte header (timestamp u64 ns at 0,
//     measurement id u16 at 8, frame id u16 at 10, encoder count u32 at 12), its pixels, then a
//     4-byte status (bit 0: the column is valid).
//   Others: a 32-byte packet header (packet type u16 at 0, 1 for lidar; frame id u16 at 2;
//     initialization id u24 at 4; serial number u40 at 7), the columns, a 32-byte footer. Each
//     column: a 12-byte header (timestamp u64 at 0, measurement id u16 at 8, status u16 at 10,
//     bit 0 valid), then its pixels.
//   Pixels: LEGACY 12 bytes, range u32 bits 0-19 (mm), reflectivity u8 at 4;
//     RNG19_RFL8_SIG16_NIR16 12 bytes, range bits 0-18, reflectivity u8 at 4;
//     RNG19_RFL8_SIG16_NIR16_DUAL 16 bytes, range bits 0-18 with reflectivity u8 at 3, the second
//     return's range bits 0-18 of the u32 at 4 with its reflectivity u8 at 7;
//     RNG15_RFL8_NIR8 4 bytes, range u16 bits 0-14 in units of 8 mm, reflectivity u8 at 2.
// The caller checks a packet's size against packet_size() before reading any of it.
#pragma once

#include <cstddef>
#include <cstdint>

#include "ouster_metadata.hpp"

namespace pl::lidar::ouster {

inline std::uint16_t u16_at(const std::uint8_t* p) { return static_cast<std::uint16_t>(p[0] | p[1] << 8); }
inline std::uint32_t u32_at(const std::uint8_t* p) {
  return static_cast<std::uint32_t>(p[0]) | static_cast<std::uint32_t>(p[1]) << 8 |
         static_cast<std::uint32_t>(p[2]) << 16 | static_cast<std::uint32_t>(p[3]) << 24;
}
inline std::uint64_t u64_at(const std::uint8_t* p) {
  return static_cast<std::uint64_t>(u32_at(p)) | static_cast<std::uint64_t>(u32_at(p + 4)) << 32;
}

struct Return {
  std::uint32_t range_mm = 0;  // 0: no return
  std::uint8_t reflectivity = 0;
};

struct ColumnHeader {
  std::uint64_t timestamp_ns = 0;  // the sensor's clock
  std::uint16_t measurement_id = 0;
  bool valid = false;
};

class PacketLayout {
 public:
  PacketLayout(Profile profile, int pixels, int columns) : profile_(profile), pixels_(static_cast<std::size_t>(pixels)),
      columns_(static_cast<std::size_t>(columns)) {
    const bool legacy = profile == Profile::Legacy;
    header_ = legacy ? 0 : 32;
    footer_ = legacy ? 0 : 32;
    column_header_ = legacy ? 16 : 12;
    column_footer_ = legacy ? 4 : 0;
    pixel_ = profile == Profile::Dual ? 16 : profile == Profile::LowData ? 4 : 12;
  }

  Profile profile() const { return profile_; }
  int returns() const { return profile_ == Profile::Dual ? 2 : 1; }
  std::size_t column_size() const { return column_header_ + pixels_ * pixel_ + column_footer_; }
  std::size_t packet_size() const { return header_ + columns_ * column_size() + footer_; }
  std::size_t columns() const { return columns_; }

  const std::uint8_t* column(const std::uint8_t* packet, std::size_t i) const { return packet + header_ + i * column_size(); }

  // Packet header fields (LEGACY: the frame id of the first column; no type, no init id).
  std::uint16_t packet_type(const std::uint8_t* packet) const { return header_ ? u16_at(packet) : 1; }
  std::uint16_t frame_id(const std::uint8_t* packet) const { return header_ ? u16_at(packet + 2) : u16_at(packet + 10); }
  std::uint32_t init_id(const std::uint8_t* packet) const { return header_ ? u32_at(packet + 4) & 0xFFFFFFu : 0; }

  ColumnHeader column_header(const std::uint8_t* col) const {
    ColumnHeader h;
    h.timestamp_ns = u64_at(col);
    h.measurement_id = u16_at(col + 8);
    h.valid = (profile_ == Profile::Legacy ? u32_at(col + column_header_ + pixels_ * pixel_) : u16_at(col + 10)) & 1u;
    return h;
  }

  // The returns of pixel `row` of a column: fills `out` (returns() of them).
  void pixel(const std::uint8_t* col, std::size_t row, Return* out) const {
    const std::uint8_t* p = col + column_header_ + row * pixel_;
    switch (profile_) {
      case Profile::Legacy: out[0] = {u32_at(p) & 0xFFFFFu, p[4]}; break;
      case Profile::Single: out[0] = {u32_at(p) & 0x7FFFFu, p[4]}; break;
      case Profile::Dual:
        out[0] = {u32_at(p) & 0x7FFFFu, p[3]};
        out[1] = {u32_at(p + 4) & 0x7FFFFu, p[7]};
        break;
      case Profile::LowData: out[0] = {static_cast<std::uint32_t>(u16_at(p) & 0x7FFFu) * 8u, p[2]}; break;
    }
  }

 private:
  Profile profile_;
  std::size_t pixels_, columns_;
  std::size_t header_ = 0, footer_ = 0, column_header_ = 0, column_footer_ = 0, pixel_ = 0;
};

}  // namespace pl::lidar::ouster
