// Hesai packet layouts (the makers' user manuals, chapter "Point Cloud Data Packet") and their checks.
#include "hesai_packet.hpp"

#include <array>
#include <cctype>

#include "pl/common/error.hpp"
#include "pl/common/text.hpp"

namespace pl::lidar {
namespace {

// The 22-byte tail of the Pandar40P and Pandar64: 5 reserved, shutdown flag, 2 reserved, motor speed,
// microseconds, return mode, factory byte, date. The 24-byte XT tail: 10 reserved, return mode, motor
// speed, date, microseconds, factory byte. The 24-byte QT64 tail: 10 reserved, motor speed,
// microseconds, return mode, factory byte, date. The QT128 tail follows the body's CRC and 17 bytes
// of functional safety: 5 reserved, mode flag, 6 reserved, return mode, motor speed, date,
// microseconds, factory byte, UDP sequence, CRC; 32 bytes of signature may follow.
constexpr std::array<HesaiLayout, 7> kLayouts = {{
    // model                    name           ch  blk hdr maj mark unit tail  mode rpm  us  date loop  min   max   range
    {HesaiModel::Pandar40P, "Pandar40P", 40, 10, 0, 0, 2, 3, 1240, 14, 8, 10, 16, -1, 1262, 1266, 0.3, 200.0},
    {HesaiModel::Pandar64, "Pandar64", 64, 6, 8, 0, 0, 3, 1172, 14, 8, 10, 16, -1, 1194, 1198, 0.3, 200.0},
    {HesaiModel::PandarQT64, "PandarQT64", 64, 4, 12, 3, 0, 4, 1044, 16, 10, 12, 18, -1, 1068, 1072, 0.1, 60.0},
    {HesaiModel::PandarQT128, "PandarQT128", 128, 2, 12, 3, 0, 4, 1061, 12, 13, 21, 15, 5, 1095, 1127, 0.05, 50.0},
    {HesaiModel::PandarXT16, "PandarXT16", 16, 8, 12, 6, 0, 4, 540, 10, 11, 19, 13, -1, 564, 568, 0.05, 120.0},
    {HesaiModel::PandarXT32, "PandarXT32", 32, 8, 12, 6, 0, 4, 1052, 10, 11, 19, 13, -1, 1076, 1080, 0.05, 120.0},
    {HesaiModel::PandarXT32M, "PandarXT32M", 32, 6, 12, 6, 0, 4, 792, 10, 11, 19, 13, -1, 816, 820, 0.5, 300.0},
}};

std::uint8_t byte_at(std::string_view p, std::size_t i) { return static_cast<std::uint8_t>(p[i]); }

std::uint32_t u32_at(std::string_view p, std::size_t i) {
  return static_cast<std::uint32_t>(byte_at(p, i)) | static_cast<std::uint32_t>(byte_at(p, i + 1)) << 8 |
         static_cast<std::uint32_t>(byte_at(p, i + 2)) << 16 | static_cast<std::uint32_t>(byte_at(p, i + 3)) << 24;
}

// Days from 1970-01-01 to a date of the proleptic Gregorian calendar.
std::int64_t days_since_epoch(int year, int month, int day) {
  const int y = year - (month <= 2 ? 1 : 0);
  const int era = (y >= 0 ? y : y - 399) / 400;
  const int year_of_era = y - era * 400;
  const int day_of_year = (153 * (month + (month > 2 ? -3 : 9)) + 2) / 5 + day - 1;
  const int day_of_era = year_of_era * 365 + year_of_era / 4 - year_of_era / 100 + day_of_year;
  return static_cast<std::int64_t>(era) * 146097 + day_of_era - 719468;
}

// The tail's date (year, month, day, hour, minute, second): years since 1900 on XT and QT; since 2000 on
// the Pandar40P and Pandar64 by their manuals, though a Pandar64 counting from 1900 sends 120 for 2020,
// so a year byte of 100 or more counts from 1900 there too.
bool read_date(const HesaiLayout& layout, std::string_view p, std::int64_t& seconds) {
  const std::size_t at = static_cast<std::size_t>(layout.tail + layout.date_at);
  const int raw_year = byte_at(p, at), month = byte_at(p, at + 1), day = byte_at(p, at + 2);
  const int hour = byte_at(p, at + 3), minute = byte_at(p, at + 4), second = byte_at(p, at + 5);
  if (month < 1 || month > 12 || day < 1 || day > 31 || hour > 23 || minute > 59 || second > 60) return false;
  const bool since_2000 = layout.header_bytes < 12 && raw_year < 100;
  const int year = raw_year + (since_2000 ? 2000 : 1900);
  seconds = days_since_epoch(year, month, day) * 86400 + hour * 3600 + minute * 60 + second;
  return true;
}

bool same_name(std::string_view a, std::string_view b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i)
    if (std::tolower(static_cast<unsigned char>(a[i])) != std::tolower(static_cast<unsigned char>(b[i]))) return false;
  return true;
}

}  // namespace

const HesaiLayout& hesai_layout(HesaiModel model) { return kLayouts[static_cast<std::size_t>(model)]; }

const HesaiLayout* find_hesai_layout(std::string_view name) {
  for (const auto& l : kLayouts) {
    const std::string_view full = l.name;
    if (same_name(name, full) || same_name(name, full.substr(6))) return &l;
  }
  return nullptr;
}

std::string hesai_model_names() {
  std::string names;
  for (const auto& l : kLayouts) names += (names.empty() ? "" : ", ") + std::string(l.name);
  return names;
}

int hesai_returns_of(std::uint8_t return_mode) {
  switch (return_mode) {
    case 0x33: case 0x34: case 0x37: case 0x38: return 1;               // first, second, strongest, last
    case 0x39: case 0x3a: case 0x3b: case 0x3c: case 0x3e: return 2;    // the dual-return pairs
    case 0x3d: return 3;                                                // first, last, strongest
    default: return 0;
  }
}

const HesaiLayout* identify_hesai_packet(std::string_view p, std::string& why) {
  if (p.size() >= 2 && byte_at(p, 0) == 0xFF && byte_at(p, 1) == 0xEE) return &hesai_layout(HesaiModel::Pandar40P);
  if (p.size() < 12 || byte_at(p, 0) != 0xEE || byte_at(p, 1) != 0xFF) {
    why = p.size() < 12 ? format_text("a packet of %zu bytes, too short for any Hesai header", p.size())
                        : format_text("no Hesai start marker (0xEEFF, or 0xFFEE of a Pandar40P block): %02x %02x",
                                      byte_at(p, 0), byte_at(p, 1));
    return nullptr;
  }
  const int major = byte_at(p, 2), minor = byte_at(p, 3), lasers = byte_at(p, 6), blocks = byte_at(p, 7);
  if (major == 64 && minor == 6) return &hesai_layout(HesaiModel::Pandar64);  // 8-byte header: lasers, blocks
  if (major == 1 && minor == 4)
    throw Error("Hesai packets of protocol 1.4 (PandarAT128, Pandar128E3X/E4X, OT128) are not decoded here; "
                "this decoder reads " + hesai_model_names());
  for (const auto& l : kLayouts)
    if (l.protocol_major != 0 && l.protocol_major == major && l.channels == lasers && l.blocks == blocks) return &l;
  why = format_text("a Hesai header of protocol %d.%d with %d lasers and %d blocks, no model this decoder reads (%s)",
                    major, minor, lasers, blocks, hesai_model_names().c_str());
  return nullptr;
}

bool read_hesai_packet(const HesaiLayout& l, std::string_view p, HesaiPacket& out, std::string& problem) {
  if (p.size() != static_cast<std::size_t>(l.min_bytes) && p.size() != static_cast<std::size_t>(l.max_bytes)) {
    problem = format_text("a %s packet has %d or %d bytes, this one %zu", l.name, l.min_bytes, l.max_bytes, p.size());
    return false;
  }
  int unit_mm = 4;
  if (l.header_bytes == 0) {
    for (int b = 0; b < l.blocks; ++b) {
      const std::size_t at = static_cast<std::size_t>(b * l.block_bytes());
      if (byte_at(p, at) != 0xFF || byte_at(p, at + 1) != 0xEE) {
        problem = format_text("%s block %d lacks its 0xFFEE marker", l.name, b);
        return false;
      }
    }
  } else {
    const bool short_header = l.header_bytes == 8;
    const int lasers = byte_at(p, short_header ? 2 : 6), blocks = byte_at(p, short_header ? 3 : 7);
    const bool version_ok = short_header || byte_at(p, 2) == l.protocol_major;
    if (byte_at(p, 0) != 0xEE || byte_at(p, 1) != 0xFF || !version_ok || lasers != l.channels || blocks != l.blocks) {
      problem = format_text("not a %s header (0xEEFF, %d lasers, %d blocks): %02x %02x, %d lasers, %d blocks", l.name,
                            l.channels, l.blocks, byte_at(p, 0), byte_at(p, 1), lasers, blocks);
      return false;
    }
    unit_mm = byte_at(p, short_header ? 5 : 9);
    if (unit_mm == 0) {
      problem = format_text("%s header with a distance unit of 0 mm", l.name);
      return false;
    }
  }
  const std::size_t tail = static_cast<std::size_t>(l.tail);
  const std::uint8_t mode = byte_at(p, tail + static_cast<std::size_t>(l.return_mode_at));
  const int returns = hesai_returns_of(mode);
  if (returns == 0 || l.blocks % returns != 0) {
    problem = format_text("%s return mode 0x%02x is none of the maker's", l.name, mode);
    return false;
  }
  out.bytes_ = reinterpret_cast<const std::uint8_t*>(p.data());
  out.layout = &l;
  for (int b = 0; b < l.blocks; ++b) {
    if (out.azimuth_cdeg(b) >= 36000) {
      problem = format_text("%s block %d has azimuth %.2f deg, past 360", l.name, b, out.azimuth_cdeg(b) / 100.0);
      return false;
    }
  }
  std::int64_t seconds = 0;
  if (!read_date(l, p, seconds)) {
    problem = format_text("%s tail has a date that is not one", l.name);
    return false;
  }
  out.returns = returns;
  out.return_mode = mode;
  out.unit_m = unit_mm / 1000.0;
  out.time_ns = seconds * 1'000'000'000 + static_cast<std::int64_t>(u32_at(p, tail + l.micros_at)) * 1000;
  out.motor_rpm = byte_at(p, tail + l.motor_rpm_at) | byte_at(p, tail + l.motor_rpm_at + 1) << 8;
  out.loop = l.loop_flag_at >= 0 ? (byte_at(p, tail + l.loop_flag_at) & 1) : 0;
  return true;
}

}  // namespace pl::lidar
