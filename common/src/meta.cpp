#include "pl/common/meta.hpp"

#include <climits>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <nlohmann/json.hpp>

#include "pl/common/error.hpp"
#include "pl/common/text.hpp"

namespace pl {

using nlohmann::json;

std::vector<double> hdl64_vertical_angles_deg() {
  // Upper block: 32 lasers from +2.0 deg down in 1/3 deg steps; lower block: 32 lasers from -8.83 deg
  // down in 1/2 deg steps (the sensor's data sheet spacing; the lowest is about -24.3 deg).
  std::vector<double> a;
  for (int i = 0; i < 32; ++i) a.push_back(2.0 - i / 3.0);
  for (int i = 0; i < 32; ++i) a.push_back(-8.83 - 0.5 * i);
  return a;
}

namespace {

template <typename T>
T field(const json& j, const char* key, const std::string& path, const std::string& where, T fallback, bool required) {
  auto it = j.find(key);
  if (it == j.end()) {
    if (required) throw Error(path + ": missing \"" + where + key + "\"");
    return fallback;
  }
  try {
    return it->get<T>();
  } catch (const json::exception&) {
    throw Error(path + ": \"" + where + key + "\" has the wrong type (" + std::string(it->type_name()) + ")");
  }
}

// An int field. nlohmann's get<int>() converts a float with static_cast, which is undefined for
// 1e300: the value is checked to be a whole number that fits first.
int int_field(const json& j, const char* key, const std::string& path, const std::string& where, int fallback, bool required) {
  auto it = j.find(key);
  if (it == j.end()) {
    if (required) throw Error(path + ": missing \"" + where + key + "\"");
    return fallback;
  }
  double v = 0;
  if (it->is_number_integer() && !it->is_number_unsigned()) v = static_cast<double>(it->get<std::int64_t>());
  else if (it->is_number_unsigned()) v = static_cast<double>(it->get<std::uint64_t>());
  else if (it->is_number_float()) v = it->get<double>();
  else throw Error(path + ": \"" + where + key + "\" has the wrong type (" + std::string(it->type_name()) + "; expected a whole number)");
  if (!(v >= INT_MIN && v <= INT_MAX && v == std::floor(v)))
    throw Error(path + ": \"" + where + key + "\" must be a whole number, found " + printable(it->dump(), 40));
  return static_cast<int>(v);
}

}  // namespace

DatasetMeta read_meta(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw Error(path + ": cannot open");
  json j;
  try {
    j = json::parse(in);
  } catch (const json::exception& e) {
    // Not only parse_error: a number beyond double's range ("1e400") is an out_of_range error. The
    // message quotes the bytes last read, which may be anything: printable() keeps it one line.
    throw Error(path + ": not valid JSON: " + printable(e.what(), 300));
  }
  if (!j.is_object()) throw Error(path + ": expected a JSON object at the top level");
  DatasetMeta m;
  if (auto s = j.find("sensor"); s != j.end()) {
    if (!s->is_object()) throw Error(path + ": \"sensor\" must be an object");
    m.sensor.model = field<std::string>(*s, "model", path, "sensor.", m.sensor.model, false);
    m.sensor.beams = int_field(*s, "beams", path, "sensor.", 0, true);
    m.sensor.vertical_angles_deg = field<std::vector<double>>(*s, "vertical_angles_deg", path, "sensor.", {}, false);
    m.sensor.point_order = field<std::string>(*s, "point_order", path, "sensor.", m.sensor.point_order, false);
    m.sensor.fov_deg = field<double>(*s, "fov_deg", path, "sensor.", m.sensor.fov_deg, false);
    m.sensor.rate_hz = field<double>(*s, "rate_hz", path, "sensor.", m.sensor.rate_hz, false);
    m.sensor.max_range_m = field<double>(*s, "max_range_m", path, "sensor.", m.sensor.max_range_m, false);
    if (m.sensor.beams <= 0 || m.sensor.beams > 1024)
      throw Error(path + ": \"sensor.beams\" must be between 1 and 1024");
    if (!m.sensor.vertical_angles_deg.empty() && static_cast<int>(m.sensor.vertical_angles_deg.size()) != m.sensor.beams)
      throw Error(path + ": \"sensor.vertical_angles_deg\" has " + std::to_string(m.sensor.vertical_angles_deg.size()) +
                  " angles but \"sensor.beams\" is " + std::to_string(m.sensor.beams));
    if (m.sensor.point_order != "laser-by-laser" && m.sensor.point_order != "any")
      throw Error(path + ": \"sensor.point_order\" must be \"laser-by-laser\" or \"any\"");
    if (m.sensor.point_order == "any" && m.sensor.vertical_angles_deg.empty())
      throw Error(path + ": \"sensor.point_order\" \"any\" needs \"sensor.vertical_angles_deg\" to tell the rings");
  }
  if (auto v = j.find("vehicle"); v != j.end()) {
    if (!v->is_object()) throw Error(path + ": \"vehicle\" must be an object");
    m.vehicle.wheel_base_m = field<double>(*v, "wheel_base_m", path, "vehicle.", 0.0, false);
    auto arm = field<std::vector<double>>(*v, "gps_lever_arm_m", path, "vehicle.", {0, 0, 0}, false);
    if (arm.size() != 3) throw Error(path + ": \"vehicle.gps_lever_arm_m\" must be [x, y, z] in metres");
    m.vehicle.gps_lever_arm = Eigen::Vector3d(arm[0], arm[1], arm[2]);
  }
  if (auto o = j.find("origin"); o != j.end()) {
    if (!o->is_object()) throw Error(path + ": \"origin\" must be an object {lat, lon, alt}");
    GeoPoint g;
    g.lat_deg = field<double>(*o, "lat", path, "origin.", 0.0, true);
    g.lon_deg = field<double>(*o, "lon", path, "origin.", 0.0, true);
    g.alt_m = field<double>(*o, "alt", path, "origin.", 0.0, false);
    if (std::abs(g.lat_deg) > 90.0 || std::abs(g.lon_deg) > 180.0)
      throw Error(path + ": \"origin\" lat must be in [-90, 90] and lon in [-180, 180] degrees");
    m.origin = g;
  }
  return m;
}

void write_meta(const std::string& path, const DatasetMeta& m) {
  json j;
  j["sensor"] = {{"model", m.sensor.model},          {"beams", m.sensor.beams},
                 {"vertical_angles_deg", m.sensor.vertical_angles_deg},
                 {"point_order", m.sensor.point_order}, {"fov_deg", m.sensor.fov_deg},
                 {"rate_hz", m.sensor.rate_hz},      {"max_range_m", m.sensor.max_range_m}};
  j["vehicle"] = {{"wheel_base_m", m.vehicle.wheel_base_m},
                  {"gps_lever_arm_m", {m.vehicle.gps_lever_arm.x(), m.vehicle.gps_lever_arm.y(), m.vehicle.gps_lever_arm.z()}}};
  if (m.origin) j["origin"] = {{"lat", m.origin->lat_deg}, {"lon", m.origin->lon_deg}, {"alt", m.origin->alt_m}};
  std::ofstream out(path);
  if (!out) throw Error(path + ": cannot write");
  out << j.dump(2) << "\n";
  if (!out) throw Error(path + ": write failed");
}

}  // namespace pl
