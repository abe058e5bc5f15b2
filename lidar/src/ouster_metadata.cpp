// Ouster metadata JSON -> Metadata: each field found in the nested layout first, then the flat one;
// each checked for its type and range, and against the others (angles a beam, the window within
// the frame), with the line of its key in every error.
#include "ouster_metadata.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <nlohmann/json.hpp>

#include "pl/common/error.hpp"

namespace pl::lidar::ouster {

namespace {

using nlohmann::json;

// The SDK's transforms when the metadata gives none (millimetres).
constexpr std::array<double, 16> kLidarToSensor = {-1, 0, 0, 0, 0, -1, 0, 0, 0, 0, 1, 36.18, 0, 0, 0, 1};

const char* const kProfileNames[] = {"LEGACY", "RNG19_RFL8_SIG16_NIR16", "RNG19_RFL8_SIG16_NIR16_DUAL", "RNG15_RFL8_NIR8"};

std::string shown(const json& v) {
  std::string s = v.dump();
  return s.size() > 60 ? s.substr(0, 57) + "..." : s;
}

// Looks fields up in both layouts and names the line of a field's key in its errors.
class Fields {
 public:
  Fields(const json& root, std::string_view text, const std::string& name) : root_(root), text_(text), name_(name) {}

  // `key` under the nested layout's `section`, else under the flat layout's `flat_section` (or at
  // the top when that is null). Null when neither has it.
  const json* find(const char* section, const char* flat_section, const char* key) const {
    if (const json* v = in(root_, section, key)) return v;
    if (flat_section) return in(root_, flat_section, key);
    auto it = root_.find(key);
    return it == root_.end() ? nullptr : &*it;
  }

  [[noreturn]] void fail(const char* key, const std::string& expected, const json* found) const {
    fail_at(name_, line_of(key), std::string(key) + " " + expected, found ? shown(*found) : std::string());
  }

  double number(const json* v, const char* key, double lo, double hi) const {
    if (!v->is_number()) fail(key, "a number", v);
    const double x = v->get<double>();
    if (!(x >= lo && x <= hi))
      fail(key, "a number in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]", v);
    return x;
  }

  int integer(const json* v, const char* key, int lo, int hi) const {
    if (!v->is_number_integer()) fail(key, "an integer", v);
    const auto x = v->get<std::int64_t>();
    if (x < lo || x > hi) fail(key, "an integer in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]", v);
    return static_cast<int>(x);
  }

  std::string text(const json* v, const char* key) const {
    if (!v->is_string()) fail(key, "a string", v);
    return v->get<std::string>();
  }

  std::vector<double> numbers(const json* v, const char* key, std::size_t count_wanted, const std::string& why) const {
    if (!v->is_array()) fail(key, "an array of numbers", v);
    std::vector<double> out;
    for (const json& e : *v) {
      if (e.is_array()) fail(key, "one number a beam (per-pixel angles, as an Ouster DF sensor gives, are not read)", v);
      if (!e.is_number() || !std::isfinite(e.get<double>())) fail(key, "an array of numbers", &e);
      out.push_back(e.get<double>());
    }
    if (count_wanted && out.size() != count_wanted)
      fail(key, std::to_string(count_wanted) + " numbers (" + why + "), found " + std::to_string(out.size()), nullptr);
    return out;
  }

 private:
  static const json* in(const json& root, const char* section, const char* key) {
    if (!section) return nullptr;
    auto s = root.find(section);
    if (s == root.end() || !s->is_object()) return nullptr;
    auto v = s->find(key);
    return v == s->end() ? nullptr : &*v;
  }

  std::size_t line_of(const char* key) const {
    const std::size_t at = text_.find("\"" + std::string(key) + "\"");
    if (at == std::string_view::npos) return 0;
    return 1 + static_cast<std::size_t>(std::count(text_.begin(), text_.begin() + static_cast<std::ptrdiff_t>(at), '\n'));
  }

  const json& root_;
  std::string_view text_;
  const std::string& name_;
};

double default_beam_origin_mm(const std::string& prod_line) {
  if (prod_line.rfind("OS-0-", 0) == 0) return 27.67;
  if (prod_line.rfind("OS-1-", 0) == 0) return 15.806;
  if (prod_line.rfind("OS-2-", 0) == 0) return 13.762;
  return 12.163;  // the first generation's
}

// "1024x10" -> columns and frames a second.
bool parse_lidar_mode(const std::string& mode, int& columns, int& fps) {
  const std::size_t x = mode.find('x');
  if (x == std::string::npos || x == 0 || x + 1 >= mode.size()) return false;
  char* end = nullptr;
  const long c = std::strtol(mode.c_str(), &end, 10);
  if (end != mode.c_str() + x) return false;
  const long f = std::strtol(mode.c_str() + x + 1, &end, 10);
  if (*end != '\0' || c < 1 || c > 65535 || f < 1 || f > 100) return false;
  columns = static_cast<int>(c);
  fps = static_cast<int>(f);
  return true;
}

std::array<double, 16> transform(const Fields& f, const json* v, const char* key) {
  const std::vector<double> m = f.numbers(v, key, 16, "a row-major 4x4 matrix");
  std::array<double, 16> out{};
  std::copy(m.begin(), m.end(), out.begin());
  if (out[12] != 0 || out[13] != 0 || out[14] != 0 || out[15] != 1) f.fail(key, "a last row of 0 0 0 1", v);
  return out;
}

void read_data_format(const Fields& f, Metadata& m) {
  int mode_columns = 0, mode_fps = 0;
  if (const json* v = f.find("config_params", nullptr, "lidar_mode")) {
    if (!parse_lidar_mode(f.text(v, "lidar_mode"), mode_columns, mode_fps))
      f.fail("lidar_mode", "a mode like 1024x10 (columns x frames a second)", v);
  }
  if (const json* v = f.find("lidar_data_format", "data_format", "columns_per_frame"))
    m.columns_per_frame = f.integer(v, "columns_per_frame", 1, 65535);
  else if (mode_columns)
    m.columns_per_frame = mode_columns;
  else
    f.fail("lidar_mode", "in the metadata (or data_format.columns_per_frame): the columns of a frame", nullptr);
  if (const json* v = f.find("lidar_data_format", "data_format", "fps")) m.fps = f.number(v, "fps", 1, 100);
  else m.fps = mode_fps;

  if (const json* v = f.find("lidar_data_format", "data_format", "columns_per_packet"))
    m.columns_per_packet = f.integer(v, "columns_per_packet", 1, m.columns_per_frame);
  else if (const json* c = f.find("config_params", nullptr, "columns_per_packet"))
    m.columns_per_packet = f.integer(c, "columns_per_packet", 1, m.columns_per_frame);

  const int beams = beams_of(m.prod_line);
  if (const json* v = f.find("lidar_data_format", "data_format", "pixels_per_column"))
    m.pixels_per_column = f.integer(v, "pixels_per_column", 1, 512);
  else if (beams)
    m.pixels_per_column = beams;
  else if (const json* a = f.find("beam_intrinsics", nullptr, "beam_altitude_angles"); a && a->is_array())
    m.pixels_per_column = static_cast<int>(std::min<std::size_t>(a->size(), 512));
  if (m.pixels_per_column < 1) f.fail("pixels_per_column", "in the metadata (or beam_altitude_angles)", nullptr);

  m.column_window_first = 0;
  m.column_window_last = m.columns_per_frame - 1;
  if (const json* v = f.find("lidar_data_format", "data_format", "column_window")) {
    if (!v->is_array() || v->size() != 2) f.fail("column_window", "two column numbers [first, last]", v);
    m.column_window_first = f.integer(&(*v)[0], "column_window", 0, m.columns_per_frame - 1);
    m.column_window_last = f.integer(&(*v)[1], "column_window", 0, m.columns_per_frame - 1);
  }

  const json* p = f.find("lidar_data_format", "data_format", "udp_profile_lidar");
  if (!p) p = f.find("config_params", nullptr, "udp_profile_lidar");
  if (p) {
    const std::string name = f.text(p, "udp_profile_lidar");
    bool known = false;
    for (int i = 0; i < 4; ++i)
      if (name == kProfileNames[i]) m.profile = static_cast<Profile>(i), known = true;
    if (!known)
      f.fail("udp_profile_lidar", "a packet profile this decoder reads (LEGACY, RNG19_RFL8_SIG16_NIR16, "
             "RNG19_RFL8_SIG16_NIR16_DUAL, RNG15_RFL8_NIR8)", p);
  }
  if (const json* v = f.find("config_params", nullptr, "return_order")) {
    const std::string order = f.text(v, "return_order");
    if (order == "STRONGEST_TO_WEAKEST") m.return_order = ReturnOrder::StrongestFirst;
    else if (order == "NEAREST_TO_FARTHEST") m.return_order = ReturnOrder::NearestFirst;
    else if (order == "FARTHEST_TO_NEAREST") m.return_order = ReturnOrder::FarthestFirst;
    else f.fail("return_order", "STRONGEST_TO_WEAKEST, NEAREST_TO_FARTHEST or FARTHEST_TO_NEAREST", v);
  }
  if (const json* v = f.find("config_params", nullptr, "udp_port_lidar"))
    m.udp_port_lidar = f.integer(v, "udp_port_lidar", 0, 65535);
}

void read_beams(const Fields& f, Metadata& m) {
  const auto rows = static_cast<std::size_t>(m.pixels_per_column);
  const char* why = "one a beam: pixels_per_column";
  const json* alt = f.find("beam_intrinsics", nullptr, "beam_altitude_angles");
  if (!alt) f.fail("beam_altitude_angles", "in the metadata: the beams' elevations", nullptr);
  m.beam_altitude_deg = f.numbers(alt, "beam_altitude_angles", rows, why);
  const json* az = f.find("beam_intrinsics", nullptr, "beam_azimuth_angles");
  if (!az) f.fail("beam_azimuth_angles", "in the metadata: the beams' azimuth offsets", nullptr);
  m.beam_azimuth_deg = f.numbers(az, "beam_azimuth_angles", rows, why);
  for (std::size_t i = 0; i < rows; ++i) {
    if (std::abs(m.beam_altitude_deg[i]) > 90) f.fail("beam_altitude_angles", "angles within +-90 degrees", alt);
    if (std::abs(m.beam_azimuth_deg[i]) > 360) f.fail("beam_azimuth_angles", "angles within +-360 degrees", az);
  }

  if (const json* v = f.find("beam_intrinsics", nullptr, "lidar_origin_to_beam_origin_mm"))
    m.lidar_origin_to_beam_origin_mm = f.number(v, "lidar_origin_to_beam_origin_mm", -1000, 1000);
  else
    m.lidar_origin_to_beam_origin_mm = default_beam_origin_mm(m.prod_line);
  m.beam_to_lidar = {1, 0, 0, m.lidar_origin_to_beam_origin_mm, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  if (const json* v = f.find("beam_intrinsics", nullptr, "beam_to_lidar_transform"))
    m.beam_to_lidar = transform(f, v, "beam_to_lidar_transform");
  m.lidar_to_sensor = kLidarToSensor;
  if (const json* v = f.find("lidar_intrinsics", nullptr, "lidar_to_sensor_transform"))
    m.lidar_to_sensor = transform(f, v, "lidar_to_sensor_transform");
}

}  // namespace

const char* profile_name(Profile p) { return kProfileNames[static_cast<int>(p)]; }

int beams_of(const std::string& prod_line) {
  // "OS-<range>-<beams>[-<variant>]"
  if (prod_line.rfind("OS-", 0) != 0) return 0;
  const std::size_t dash = prod_line.find('-', 3);
  if (dash == std::string::npos) return 0;
  const int beams = std::atoi(prod_line.c_str() + dash + 1);
  return beams == 16 || beams == 32 || beams == 64 || beams == 128 ? beams : 0;
}

Metadata parse_metadata(std::string_view text, const std::string& name) {
  json root;
  try {
    root = json::parse(text.begin(), text.end());
  } catch (const json::parse_error& e) {
    const std::size_t at = std::min<std::size_t>(e.byte > 0 ? e.byte - 1 : 0, text.size());
    const auto line = 1 + static_cast<std::size_t>(std::count(text.begin(), text.begin() + static_cast<std::ptrdiff_t>(at), '\n'));
    fail_at(name, line, "the sensor's metadata JSON (" + std::string(e.what()) + ")");
  } catch (const json::exception& e) {  // a number beyond a double, and the like: no position given
    fail_at(name, 0, "the sensor's metadata JSON (" + std::string(e.what()) + ")");
  }
  if (!root.is_object()) fail_at(name, 1, "a JSON object (the Ouster sensor's metadata)", shown(root));
  const Fields f(root, text, name);

  Metadata m;
  if (const json* v = f.find("sensor_info", nullptr, "prod_line")) m.prod_line = f.text(v, "prod_line");
  read_data_format(f, m);
  read_beams(f, m);
  return m;
}

}  // namespace pl::lidar::ouster
