// Laser angles from the maker's angle file and from DIFOP packets.
#include "robosense_calibration.hpp"

#include <cmath>
#include <cstdlib>

#include "pl/common/error.hpp"

namespace pl::lidar::robosense {
namespace {

std::string_view trimmed(std::string_view s) {
  const auto first = s.find_first_not_of(" \t\r");
  if (first == std::string_view::npos) return {};
  return s.substr(first, s.find_last_not_of(" \t\r") - first + 1);
}

// One field of a line, in 0.01° toward zero as the maker's driver reads it (float, times 100, truncated).
int centidegrees(std::string_view field, const std::string& name, std::size_t line, const char* what) {
  const std::string text(trimmed(field));
  const char* begin = text.c_str();
  char* end = nullptr;
  const float v = std::strtof(begin, &end);
  if (text.empty() || end != begin + text.size() || !std::isfinite(v) || !(std::fabs(v) < 90.0f))
    fail_at(name, line, std::string(what) + " in degrees, a number within ±90", text);
  return static_cast<int>(v * 100.0f);
}

}  // namespace

Angles parse_angle_file(std::string_view text, const std::string& name) {
  Angles a;
  std::size_t line = 0;
  while (!text.empty()) {
    ++line;
    const auto eol = text.find('\n');
    const std::string_view row = trimmed(text.substr(0, eol));
    text = eol == std::string_view::npos ? std::string_view{} : text.substr(eol + 1);
    if (row.empty()) continue;
    const auto comma = row.find(',');
    if (comma != std::string_view::npos && row.find(',', comma + 1) != std::string_view::npos)
      fail_at(name, line, "\"elevation,azimuth offset\" (two fields)", std::string(row));
    a.elevation_deg.push_back(centidegrees(row.substr(0, comma), name, line, "the elevation") / 100.0);
    a.azimuth_offset.push_back(
        comma == std::string_view::npos ? 0 : centidegrees(row.substr(comma + 1), name, line, "the azimuth offset"));
  }
  if (a.elevation_deg.empty()) fail_at(name, 0, "one line a laser: \"elevation,azimuth offset\" in degrees", "no angles");
  return a;
}

Difop read_difop(std::string_view packet, const Model& m) {
  const auto* b = reinterpret_cast<const unsigned char*>(packet.data());
  Difop d;
  d.rpm = static_cast<int>(be16(b + kRpmAt));
  d.return_mode = b[kReturnModeAt];
  Angles a;
  for (int l = 0; l < m.lasers; ++l) {
    if (m.family == Family::Rs16) {
      // Unsigned, 0.0001°: the first eight lasers point down.
      const std::uint32_t v = be24(b + kRs16PitchAt + 3 * l);
      if (v > 900000) return d;
      a.elevation_deg.push_back((l < 8 ? -1.0 : 1.0) * v * 1e-4);
      a.azimuth_offset.push_back(0);
    } else {
      const unsigned char* e = b + kHeliosElevationsAt + 3 * l;
      const unsigned char* h = b + kHeliosOffsetsAt + 3 * l;
      const int ev = static_cast<int>(be16(e + 1)), hv = static_cast<int>(be16(h + 1));
      if (e[0] > 1 || h[0] > 1 || ev >= 9000 || hv >= 9000) return d;  // an empty table reads 0xFF
      a.elevation_deg.push_back((e[0] ? -ev : ev) / 100.0);
      a.azimuth_offset.push_back(h[0] ? -hv : hv);
    }
  }
  d.angles = std::move(a);
  return d;
}

}  // namespace pl::lidar::robosense
