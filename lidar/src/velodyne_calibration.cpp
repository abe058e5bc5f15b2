// The Velodyne calibration YAML: parsing with yaml-cpp, every error naming the file, line and field.
#include "velodyne_calibration.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <numeric>
#include <sstream>

#include "pl/common/error.hpp"
#include "pl/common/text.hpp"

namespace pl::lidar {
namespace {

constexpr double kHalfPi = 1.5707963267948966;
constexpr double kTwoPi = 6.283185307179586;

// One field's range and unit, for the value check and its message.
struct Range {
  double lo, hi;
  const char* unit;
};

class CalibrationReader {
 public:
  explicit CalibrationReader(const std::string& source) : source_(source) {}

  [[noreturn]] void fail(const YAML::Node& where, const std::string& field, const std::string& expected,
                         const std::string& found = {}) const {
    fail_line(line_of(where), field, expected, found);
  }

  [[noreturn]] void fail_line(std::size_t line, const std::string& field, const std::string& expected,
                              const std::string& found = {}) const {
    std::string msg = source_;
    if (line > 0) msg += ":" + std::to_string(line);
    msg += ": " + field + ": expected " + expected;
    if (!found.empty()) msg += ", found \"" + printable(found, 60) + "\"";
    throw Error(msg);
  }

  static std::size_t line_of(const YAML::Node& node) {
    const YAML::Mark m = node.Mark();
    return m.is_null() ? 0 : static_cast<std::size_t>(m.line) + 1;
  }

  // The number under `key`, or `fallback` when the key is absent and not `required`.
  double number(const YAML::Node& map, const char* key, const std::string& field, const Range& range,
                bool required, double fallback) const {
    const YAML::Node node = map[key];
    if (!node) {
      if (required) fail(map, field, std::string("a field ") + key);
      return fallback;
    }
    if (!node.IsScalar()) fail(node, field, "a number", "a list or map");
    const std::string& text = node.Scalar();
    double value = 0;
    if (!parse_double(text, value) || !std::isfinite(value)) fail(node, field, "a number", text);
    if (value < range.lo || value > range.hi)
      fail(node, field, format_text("a number in [%g, %g] (%s)", range.lo, range.hi, range.unit), text);
    return value;
  }

  bool flag(const YAML::Node& map, const char* key, const std::string& field) const {
    const YAML::Node node = map[key];
    if (!node) return false;
    if (node.IsScalar()) {
      const std::string& t = node.Scalar();
      if (t == "true" || t == "True" || t == "1") return true;
      if (t == "false" || t == "False" || t == "0") return false;
      fail(node, field, "true or false", t);
    }
    fail(node, field, "true or false", "a list or map");
  }

 private:
  std::string source_;
};

VelodyneLaser read_laser(const CalibrationReader& r, const YAML::Node& node, const std::string& at) {
  const Range angle_rot{-kTwoPi, kTwoPi, "radians"};
  const Range angle_vert{-kHalfPi, kHalfPi, "radians"};
  const Range metres{-100, 100, "metres"};
  const Range intensity{0, 255, "0-255"};
  const Range focal{-1e6, 1e6, "the maker's units"};
  VelodyneLaser l;
  l.rot_correction = r.number(node, "rot_correction", at + ".rot_correction", angle_rot, true, 0);
  l.vert_correction = r.number(node, "vert_correction", at + ".vert_correction", angle_vert, true, 0);
  l.dist_correction = r.number(node, "dist_correction", at + ".dist_correction", metres, false, 0);
  l.dist_correction_x = r.number(node, "dist_correction_x", at + ".dist_correction_x", metres, false, 0);
  l.dist_correction_y = r.number(node, "dist_correction_y", at + ".dist_correction_y", metres, false, 0);
  l.two_pt_correction_available = r.flag(node, "two_pt_correction_available", at + ".two_pt_correction_available");
  l.vert_offset_correction =
      r.number(node, "vert_offset_correction", at + ".vert_offset_correction", metres, false, 0);
  l.horiz_offset_correction =
      r.number(node, "horiz_offset_correction", at + ".horiz_offset_correction", metres, false, 0);
  l.min_intensity = std::floor(r.number(node, "min_intensity", at + ".min_intensity", intensity, false, 0));
  l.max_intensity = std::floor(r.number(node, "max_intensity", at + ".max_intensity", intensity, false, 255));
  if (l.min_intensity > l.max_intensity)
    r.fail(node, at + ".min_intensity", format_text("at most max_intensity %g", l.max_intensity),
           format_text("%g", l.min_intensity));
  l.focal_distance = r.number(node, "focal_distance", at + ".focal_distance", focal, false, 0);
  l.focal_slope = r.number(node, "focal_slope", at + ".focal_slope", Range{-1e3, 1e3, "the maker's units"}, false, 0);
  return l;
}

VelodyneCalibration read_calibration(const CalibrationReader& r, const YAML::Node& doc, const std::string& source) {
  if (!doc.IsMap()) r.fail(doc, "the file", "a map with a `lasers:` list (the Velodyne calibration YAML)");
  const YAML::Node list = doc["lasers"];
  if (!list || !list.IsSequence() || list.size() == 0)
    r.fail(list ? list : doc, "lasers", "a list of one entry per laser");
  const std::size_t n = list.size();
  if (n > 128) r.fail(list, "lasers", "at most 128 lasers", std::to_string(n));
  if (const YAML::Node count = doc["num_lasers"]) {
    const double stated = r.number(doc, "num_lasers", "num_lasers", Range{1, 128, "lasers"}, true, 0);
    if (stated != static_cast<double>(n))
      r.fail(count, "num_lasers", "the number of entries under lasers, " + std::to_string(n), count.Scalar());
  }
  if (doc["distance_resolution"])
    r.number(doc, "distance_resolution", "distance_resolution", Range{1e-4, 1, "metres"}, true, 0);

  VelodyneCalibration cal;
  cal.source = source;
  cal.lasers.resize(n);
  std::vector<bool> seen(n, false);
  for (std::size_t i = 0; i < n; ++i) {
    const YAML::Node node = list[i];
    const std::string at = "lasers[" + std::to_string(i) + "]";
    if (!node.IsMap()) r.fail(node, at, "a map of one laser's corrections");
    const double id = r.number(node, "laser_id", at + ".laser_id", Range{0, static_cast<double>(n - 1), "laser ids"},
                               true, 0);
    if (id != std::floor(id)) r.fail(node["laser_id"], at + ".laser_id", "a whole number", node["laser_id"].Scalar());
    const auto k = static_cast<std::size_t>(id);
    if (seen[k]) r.fail(node["laser_id"], at + ".laser_id", "each laser_id once", node["laser_id"].Scalar());
    seen[k] = true;
    cal.lasers[k] = read_laser(r, node, at);
  }
  return cal;
}

}  // namespace

VelodyneCalibration parse_velodyne_calibration(const std::string& text, const std::string& source) {
  const CalibrationReader r(source);
  try {
    return read_calibration(r, YAML::Load(text), source);
  } catch (const YAML::Exception& e) {
    r.fail_line(e.mark.is_null() ? 0 : static_cast<std::size_t>(e.mark.line) + 1, "YAML", "valid YAML", e.msg);
  }
}

VelodyneCalibration load_velodyne_calibration(const DecoderOptions& options) {
  if (!options.calibration_text.empty())
    return parse_velodyne_calibration(options.calibration_text, "calibration text");
  if (options.calibration_path.empty()) return {};
  std::ifstream in(options.calibration_path, std::ios::binary);
  if (!in) throw Error(options.calibration_path + ": cannot open the Velodyne calibration file");
  std::ostringstream text;
  text << in.rdbuf();
  return parse_velodyne_calibration(text.str(), options.calibration_path);
}

std::vector<std::uint16_t> velodyne_rings(const VelodyneCalibration& calibration) {
  const auto& lasers = calibration.lasers;
  std::vector<std::size_t> order(lasers.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    return lasers[a].vert_correction < lasers[b].vert_correction;
  });
  std::vector<std::uint16_t> ring(lasers.size());
  for (std::size_t r = 0; r < order.size(); ++r) ring[order[r]] = static_cast<std::uint16_t>(r);
  return ring;
}

}  // namespace pl::lidar
