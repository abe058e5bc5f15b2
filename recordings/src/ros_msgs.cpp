// Decoding follows the two wire formats field by field (ros_cursor.hpp).
#include "pl/recordings/ros_msgs.hpp"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>

#include "ros_cursor.hpp"
#include "pl/common/error.hpp"

namespace pl::ros {
namespace {

using bag::Encoding;

// PointField datatypes.
enum : std::uint8_t { kInt8 = 1, kUint8, kInt16, kUint16, kInt32, kUint32, kFloat32, kFloat64 };
std::size_t type_size(std::uint8_t t) {
  switch (t) {
    case kInt8: case kUint8: return 1;
    case kInt16: case kUint16: return 2;
    case kInt32: case kUint32: case kFloat32: return 4;
    case kFloat64: return 8;
    default: return 0;
  }
}

struct Field {
  std::string name;
  std::uint32_t offset = 0;
  std::uint8_t type = 0;
  std::uint32_t count = 0;
};

// A field's value at a point as a double.
inline double value_at(const char* p, std::uint8_t type) {
  switch (type) {
    case kFloat32: { float v; std::memcpy(&v, p, 4); return v; }
    case kFloat64: { double v; std::memcpy(&v, p, 8); return v; }
    case kUint8: return static_cast<std::uint8_t>(*p);
    case kInt8: return static_cast<std::int8_t>(*p);
    case kUint16: { std::uint16_t v; std::memcpy(&v, p, 2); return v; }
    case kInt16: { std::int16_t v; std::memcpy(&v, p, 2); return v; }
    case kUint32: { std::uint32_t v; std::memcpy(&v, p, 4); return v; }
    case kInt32: { std::int32_t v; std::memcpy(&v, p, 4); return v; }
    default: return 0;
  }
}

const Field* find_field(const std::vector<Field>& fields, std::initializer_list<const char*> names) {
  for (const char* n : names)
    for (const Field& f : fields)
      if (f.name == n) return &f;
  return nullptr;
}

const char* type_name(std::uint8_t t) {
  static const char* const names[] = {"?", "int8", "uint8", "int16", "uint16", "int32", "uint32", "float32", "float64"};
  return t <= kFloat64 ? names[t] : "?";
}

std::string seconds_text(double s) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.4g s", s);
  return buf;
}

// The field's raw values as seconds from the header's stamp: the unit from the field's type and from
// the spread the values must have over a sweep, absolute times (near the stamp) made relative. Fills
// the cloud's time_* members; leaves `times` empty, with the reason, when no unit makes the values a
// sweep's times (a constant field, all zeros, or a spread far from one rotation).
void decide_times(PointCloud& out, const Field& f, const std::vector<double>& raw, double stamp_s, const SweepBounds& sweep) {
  out.time_field = f.name + " (" + type_name(f.type) + ")";
  auto set_aside = [&](const std::string& why) { out.time_set_aside = "field " + out.time_field + " set aside: " + why; };
  if (raw.empty()) return;
  double lo = raw.front(), hi = raw.front();
  for (double v : raw) {
    if (!std::isfinite(v)) return set_aside("a value is not finite");
    lo = std::min(lo, v), hi = std::max(hi, v);
  }
  if (hi == lo)
    return set_aside(std::string("all its values are ") + (lo == 0 ? "0" : std::to_string(lo)) + ": it carries no time");
  struct Unit {
    const char* name;
    double scale;
  };
  static const Unit kFloatUnits[] = {{"s", 1.0}, {"ms", 1e-3}, {"us", 1e-6}, {"ns", 1e-9}};
  static const Unit kIntUnits[] = {{"ns", 1e-9}, {"us", 1e-6}, {"ms", 1e-3}};
  const bool floating = f.type == kFloat32 || f.type == kFloat64;
  const Unit* units = floating ? kFloatUnits : kIntUnits;
  const std::size_t n_units = floating ? 4 : 3;
  for (std::size_t u = 0; u < n_units; ++u) {
    const double k = units[u].scale;
    const double span = (hi - lo) * k;
    const bool absolute = std::abs(lo * k - stamp_s) < 10.0;  // seconds since 1970, near the stamp
    const double offset = absolute ? stamp_s : 0.0;
    // Checked as kept, in float32 (0.99999999 s rounds to 1 s there); between lo and hi all are within.
    const float first = static_cast<float>(lo * k - offset), last = static_cast<float>(hi * k - offset);
    if (!(std::abs(first) < 1.0f && std::abs(last) < 1.0f)) continue;
    if (span < sweep.min_s || span > sweep.max_s) continue;
    out.time_unit = std::string(units[u].name) + (absolute ? ", absolute" : ", from the stamp");
    out.time_span_s = span;
    out.times.reserve(raw.size());
    for (double v : raw) out.times.push_back(static_cast<float>(v * k - offset));
    return;
  }
  set_aside("in no unit do its values (" + std::to_string(lo) + " to " + std::to_string(hi) + ") span a sweep (" +
            seconds_text(sweep.min_s) + " to " + seconds_text(sweep.max_s) + ") near the header's stamp");
}

}  // namespace

Header decode_header(std::string_view bytes, Encoding encoding, const std::string& name) {
  Cursor c(bytes, encoding, name);
  return c.header();
}

PointCloud decode_point_cloud2(std::string_view bytes, Encoding encoding, const std::string& name, const SweepBounds& sweep) {
  Cursor c(bytes, encoding, name);
  PointCloud out;
  out.header = c.header();
  const std::uint32_t height = c.u32("height"), width = c.u32("width");
  const std::uint32_t nfields = c.count("the fields", 13);
  std::vector<Field> fields(nfields);
  for (Field& f : fields) {
    f.name = c.str("a field's name");
    f.offset = c.u32("a field's offset");
    f.type = c.get<std::uint8_t>("a field's datatype");
    f.count = c.u32("a field's count");
    out.fields.push_back(f.name);
  }
  const bool big_endian = c.get<std::uint8_t>("is_bigendian") != 0;
  const std::uint32_t point_step = c.u32("point_step"), row_step = c.u32("row_step");
  const std::uint32_t size = c.count("the data", 1);
  const std::string_view data = c.bytes(size, "the data");
  c.get<std::uint8_t>("is_dense");

  auto refuse = [&](const std::string& problem) { throw Error(name + ": a PointCloud2 " + problem); };
  if (big_endian) refuse("is big-endian (is_bigendian true): not supported; record on a little-endian machine");
  for (const Field& f : fields) {
    const std::size_t s = type_size(f.type);
    if (s == 0) refuse("field \"" + f.name + "\" has unknown datatype " + std::to_string(f.type) + " (expected 1-8)");
    if (f.count == 0 || static_cast<std::uint64_t>(f.offset) + s > point_step)
      refuse("field \"" + f.name + "\" (offset " + std::to_string(f.offset) + ", " + std::to_string(s) + " bytes) lies outside the point's " +
             std::to_string(point_step) + " bytes");
  }
  const Field* fx = find_field(fields, {"x"});
  const Field* fy = find_field(fields, {"y"});
  const Field* fz = find_field(fields, {"z"});
  if (!fx || !fy || !fz) {
    std::string have;
    for (const Field& f : fields) have += (have.empty() ? "" : " ") + f.name;
    refuse("has no x, y and z fields (it has: " + (have.empty() ? std::string("none") : have) + "); a LiDAR scan needs them");
  }
  const std::uint64_t points = static_cast<std::uint64_t>(width) * height;
  if (points == 0) return out;  // (a height of billions over empty rows would loop for nothing)
  {
    if (static_cast<std::uint64_t>(width) * point_step > row_step)
      refuse("row of " + std::to_string(width) + " points of " + std::to_string(point_step) + " bytes does not fit its row_step " + std::to_string(row_step));
    const std::uint64_t needed = static_cast<std::uint64_t>(height - 1) * row_step + static_cast<std::uint64_t>(width) * point_step;
    if (needed > data.size())
      refuse("of " + std::to_string(width) + " x " + std::to_string(height) + " points needs " + std::to_string(needed) + " bytes of data, has " +
             std::to_string(data.size()) + " (the message is damaged)");
  }
  const Field* fi = find_field(fields, {"intensity", "reflectivity", "i"});
  const Field* fr = find_field(fields, {"ring", "line", "channel"});
  const Field* ft = find_field(fields, {"t", "time", "timestamp", "time_stamp", "time_offset", "offset_time"});
  const double stamp_s = static_cast<double>(out.header.stamp_ns) * 1e-9;
  std::vector<double> raw_times;
  out.points.reserve(points);
  if (fr) out.rings.reserve(points);
  if (ft) raw_times.reserve(points);
  for (std::uint32_t row = 0; row < height; ++row) {
    const char* line = data.data() + static_cast<std::size_t>(row) * row_step;
    for (std::uint32_t col = 0; col < width; ++col) {
      const char* p = line + static_cast<std::size_t>(col) * point_step;
      // As float32 (a float64 coordinate beyond its range becomes infinite there, and is dropped too).
      const float x = static_cast<float>(value_at(p + fx->offset, fx->type)), y = static_cast<float>(value_at(p + fy->offset, fy->type)),
                  z = static_cast<float>(value_at(p + fz->offset, fz->type));
      if (!std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z)) {
        ++out.dropped;
        continue;
      }
      float in = fi ? static_cast<float>(value_at(p + fi->offset, fi->type)) : 0.0f;
      if (!std::isfinite(in)) in = 0.0f;
      out.points.push_back({x, y, z, in});
      if (fr) {
        const double r = value_at(p + fr->offset, fr->type);
        if (!(r >= 0 && r < 65536)) refuse("point has ring " + std::to_string(r) + " (expected 0-65535)");
        out.rings.push_back(static_cast<std::uint16_t>(r));
      }
      if (ft) raw_times.push_back(value_at(p + ft->offset, ft->type));
    }
  }
  if (ft) decide_times(out, *ft, raw_times, stamp_s, sweep);
  return out;
}

Odometry decode_odometry(std::string_view bytes, Encoding encoding, const std::string& name) {
  Cursor c(bytes, encoding, name);
  Odometry o;
  o.header = c.header();
  o.child_frame_id = c.str("child_frame_id");
  o.pose = c.pose("the pose");
  o.pose_covariance = c.doubles<36>("the pose's covariance");
  o.linear = c.vec3("the linear velocity");
  o.angular = c.vec3("the angular velocity");
  c.doubles<36>("the twist's covariance");
  return o;
}

Twist decode_twist_stamped(std::string_view bytes, Encoding encoding, const std::string& name) {
  Cursor c(bytes, encoding, name);
  Twist t;
  t.header = c.header();
  t.linear = c.vec3("the linear velocity");
  t.angular = c.vec3("the angular velocity");
  return t;
}

NavSatFix decode_nav_sat_fix(std::string_view bytes, Encoding encoding, const std::string& name) {
  Cursor c(bytes, encoding, name);
  NavSatFix f;
  f.header = c.header();
  f.status = c.get<std::int8_t>("the status");
  f.service = c.get<std::uint16_t>("the service");
  f.latitude = c.f64("the latitude");
  f.longitude = c.f64("the longitude");
  f.altitude = c.f64("the altitude");
  f.covariance = c.doubles<9>("the position covariance");
  f.covariance_type = c.get<std::uint8_t>("the covariance type");
  return f;
}

Imu decode_imu(std::string_view bytes, Encoding encoding, const std::string& name) {
  Cursor c(bytes, encoding, name);
  Imu m;
  m.header = c.header();
  const double x = c.f64("the orientation"), y = c.f64("the orientation"), z = c.f64("the orientation"), w = c.f64("the orientation");
  const double n = std::sqrt(x * x + y * y + z * z + w * w);
  // An IMU without orientation sends zeros (and -1 in the covariance): identity then.
  if (n > 0.5 && n < 1.5) m.orientation = Eigen::Quaterniond(w, x, y, z).normalized();
  c.doubles<9>("the orientation's covariance");
  m.angular_velocity = c.vec3("the angular velocity");
  c.doubles<9>("the angular velocity's covariance");
  m.linear_acceleration = c.vec3("the linear acceleration");
  c.doubles<9>("the linear acceleration's covariance");
  return m;
}

std::vector<Transform, Eigen::aligned_allocator<Transform>> decode_tf_message(std::string_view bytes, Encoding encoding, const std::string& name) {
  Cursor c(bytes, encoding, name);
  const std::uint32_t n = c.count("the transforms", 64);
  std::vector<Transform, Eigen::aligned_allocator<Transform>> out(n);
  for (Transform& t : out) {
    t.header = c.header();
    t.child_frame_id = c.str("child_frame_id");
    t.pose = c.pose("the transform");
  }
  return out;
}

}  // namespace pl::ros
