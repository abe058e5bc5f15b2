// Hesai angle-correction CSV files.
#include "hesai_calibration.hpp"

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <sstream>

#include "pl/common/error.hpp"
#include "pl/common/text.hpp"

namespace pl::lidar {
namespace {

constexpr long long kMaxLaserId = 512;  // Hesai's largest sensors have 128

std::string_view trimmed(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r')) s.remove_suffix(1);
  return s;
}

// Comma-separated fields, empty ones kept (",," is a missing number, not a skipped column).
std::vector<std::string_view> csv_fields(std::string_view line) {
  std::vector<std::string_view> fields;
  std::size_t start = 0;
  for (;;) {
    const std::size_t comma = line.find(',', start);
    fields.push_back(trimmed(line.substr(start, comma == std::string_view::npos ? std::string_view::npos : comma - start)));
    if (comma == std::string_view::npos) return fields;
    start = comma + 1;
  }
}

}  // namespace

HesaiCalibration parse_hesai_calibration(std::string_view text, const std::string& source) {
  if (text.substr(0, 3) == "\xEF\xBB\xBF") text.remove_prefix(3);  // a UTF-8 byte-order mark
  HesaiCalibration cal;
  cal.source = source;
  std::vector<std::size_t> line_of_id;  // by id - 1; 0: not seen
  std::size_t line_number = 0, start = 0;
  bool seen_row = false;
  while (start < text.size()) {
    const std::size_t end = std::min(text.find('\n', start), text.size());
    const std::string_view line = trimmed(text.substr(start, end - start));
    start = end + 1;
    ++line_number;
    if (line.empty() || line.front() == '#') continue;
    const auto fields = csv_fields(line);
    double number = 0;
    if (!seen_row && !fields[0].empty() && !parse_double(fields[0], number)) {
      seen_row = true;  // the header row
      continue;
    }
    seen_row = true;
    const std::string row(line);
    if (fields.size() != 3) fail_at(source, line_number, "3 fields: laser id, elevation, azimuth offset (degrees)", row);
    long long id = 0;
    double elevation = 0, azimuth = 0;
    if (!parse_int(fields[0], id) || id < 1 || id > kMaxLaserId)
      fail_at(source, line_number, "a laser id from 1 to 512 in field 1", row);
    if (!parse_double(fields[1], elevation) || elevation < -90 || elevation > 90)
      fail_at(source, line_number, "an elevation from -90 to 90 degrees in field 2", row);
    if (!parse_double(fields[2], azimuth) || azimuth < -180 || azimuth > 180)
      fail_at(source, line_number, "an azimuth offset from -180 to 180 degrees in field 3", row);
    const std::size_t channel = static_cast<std::size_t>(id - 1);
    if (channel >= line_of_id.size()) {
      line_of_id.resize(channel + 1, 0);
      cal.elevation_deg.resize(channel + 1, 0.0);
      cal.azimuth_offset_deg.resize(channel + 1, 0.0);
    }
    if (line_of_id[channel] != 0)
      fail_at(source, line_number, format_text("laser id %lld once (line %zu has it too)", id, line_of_id[channel]), row);
    line_of_id[channel] = line_number;
    cal.elevation_deg[channel] = elevation;
    cal.azimuth_offset_deg[channel] = azimuth;
  }
  if (line_of_id.empty()) fail_at(source, 0, "rows of laser id, elevation, azimuth offset (a Hesai angle file)");
  for (std::size_t c = 0; c < line_of_id.size(); ++c)
    if (line_of_id[c] == 0)
      fail_at(source, 0, format_text("laser ids 1 to %zu, each once: %zu is missing", line_of_id.size(), c + 1));
  return cal;
}

HesaiCalibration load_hesai_calibration(const DecoderOptions& options) {
  if (!options.calibration_text.empty()) return parse_hesai_calibration(options.calibration_text, "the calibration text");
  if (options.calibration_path.empty()) return {};
  if (dir_exists(options.calibration_path)) throw Error(options.calibration_path + ": is a folder, expected a Hesai angle file");
  std::ifstream in(options.calibration_path, std::ios::binary);
  if (!in) throw Error(options.calibration_path + ": cannot open (" + std::strerror(errno) + ")");
  std::ostringstream text;
  text << in.rdbuf();
  return parse_hesai_calibration(text.str(), options.calibration_path);
}

}  // namespace pl::lidar
