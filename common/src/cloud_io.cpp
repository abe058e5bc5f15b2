#include "pl/common/cloud_io.hpp"

#include <cctype>
#include <cerrno>
#include <cfloat>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <memory>
#include <set>

#include "pl/common/error.hpp"
#include "pl/common/scan.hpp"
#include "pl/common/text.hpp"

namespace pl {

void write_pcd(const std::string& path, const Points3d& points, const std::vector<float>& intensity,
               const std::optional<GeoPoint>& origin) {
  if (!intensity.empty() && intensity.size() != points.size()) throw Error("write_pcd: one intensity per point expected");
  for (const auto& p : points)
    if (!(p.cwiseAbs().maxCoeff() < 1.0e5))
      throw Error(path + ": coordinates beyond 100 km do not fit float32 PCD fields; write the cloud in a local frame");
  std::unique_ptr<std::FILE, int (*)(std::FILE*)> f(std::fopen(path.c_str(), "wb"), &std::fclose);
  if (!f) throw Error(path + ": cannot write");
  std::fprintf(f.get(), "# .PCD v0.7 - Point Cloud Data file format\n");
  if (origin) std::fprintf(f.get(), "# origin %.10f %.10f %.4f\n", origin->lat_deg, origin->lon_deg, origin->alt_m);
  std::fprintf(f.get(),
               "VERSION 0.7\nFIELDS x y z intensity\nSIZE 4 4 4 4\n"
               "TYPE F F F F\nCOUNT 1 1 1 1\nWIDTH %zu\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS %zu\nDATA binary\n",
               points.size(), points.size());
  std::vector<float> buf;
  buf.reserve(4 * 65536);
  for (std::size_t i = 0; i < points.size(); ++i) {
    buf.push_back(static_cast<float>(points[i].x()));
    buf.push_back(static_cast<float>(points[i].y()));
    buf.push_back(static_cast<float>(points[i].z()));
    buf.push_back(intensity.empty() ? 0.0f : intensity[i]);
    if (buf.size() >= 4 * 65536 || i + 1 == points.size()) {
      if (std::fwrite(buf.data(), sizeof(float), buf.size(), f.get()) != buf.size()) throw Error(path + ": write failed (disk full?)");
      buf.clear();
    }
  }
  if (std::fclose(f.release()) != 0) throw Error(path + ": write failed (disk full?)");
}


namespace {

// Size arithmetic on counts from a header: false when the result does not fit (a hostile header can
// declare any count; wrapping around would make a huge body look small).
bool checked_mul(std::size_t a, std::size_t b, std::size_t& out) { return !__builtin_mul_overflow(a, b, &out); }
bool checked_add(std::size_t a, std::size_t b, std::size_t& out) { return !__builtin_add_overflow(a, b, &out); }

std::string slurp(const std::string& path) {
  std::unique_ptr<std::FILE, int (*)(std::FILE*)> f(std::fopen(path.c_str(), "rb"), &std::fclose);
  if (!f) throw Error(path + ": cannot open (" + std::strerror(errno) + ")");
  std::string bytes;
  char buf[65536];
  std::size_t got;
  while ((got = std::fread(buf, 1, sizeof(buf), f.get())) > 0) bytes.append(buf, got);
  if (std::ferror(f.get())) throw Error(path + ": cannot read (" + std::strerror(errno) + ")");
  return bytes;
}

// The header line that starts at `pos`, without its '\n' and a trailing '\r'; moves `pos` past it.
// False when no '\n' ends it: a header never runs to the end of the file.
bool take_line(std::string_view text, std::size_t& pos, std::string_view& line) {
  const std::size_t end = text.find('\n', pos);
  if (end == std::string_view::npos) return false;
  line = text.substr(pos, end - pos);
  pos = end + 1;
  if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
  return true;
}

// A count or size of a header: decimal digits only (no sign, no fraction), and it must fit.
bool parse_count(std::string_view text, std::size_t& out) {
  if (text.empty()) return false;
  const auto res = std::from_chars(text.data(), text.data() + text.size(), out);
  return res.ec == std::errc() && res.ptr == text.data() + text.size();
}

std::string quoted(std::string_view text) { return "\"" + printable(text, 80) + "\""; }

struct Field {
  std::string name;
  char type = 'F';  // F float, I signed, U unsigned
  std::size_t size = 4;
  std::size_t count = 1;
  std::size_t offset = 0;  // bytes into a binary record
  std::size_t column = 0;  // values into an ascii line
};

// The scalars this reader decodes: float32/64 and 8- to 64-bit integers. Anything else is refused
// when the header is read, so that no field decodes to a silent NaN.
bool supported_scalar(char type, std::size_t size) {
  if (type == 'F') return size == 4 || size == 8;
  if (type == 'I' || type == 'U') return size == 1 || size == 2 || size == 4 || size == 8;
  return false;
}

double read_scalar(const char* p, const Field& f) {
  switch (f.type) {
    case 'F':
      if (f.size == 4) { float v; std::memcpy(&v, p, 4); return v; }
      if (f.size == 8) { double v; std::memcpy(&v, p, 8); return v; }
      break;
    case 'I':
      if (f.size == 1) { std::int8_t v; std::memcpy(&v, p, 1); return v; }
      if (f.size == 2) { std::int16_t v; std::memcpy(&v, p, 2); return v; }
      if (f.size == 4) { std::int32_t v; std::memcpy(&v, p, 4); return v; }
      if (f.size == 8) { std::int64_t v; std::memcpy(&v, p, 8); return static_cast<double>(v); }
      break;
    case 'U':
      if (f.size == 1) { std::uint8_t v; std::memcpy(&v, p, 1); return v; }
      if (f.size == 2) { std::uint16_t v; std::memcpy(&v, p, 2); return v; }
      if (f.size == 4) { std::uint32_t v; std::memcpy(&v, p, 4); return v; }
      if (f.size == 8) { std::uint64_t v; std::memcpy(&v, p, 8); return static_cast<double>(v); }
      break;
  }
  return NAN;  // not reached: supported_scalar() vetted every field
}

bool is_intensity_name(const std::string& n) {
  return n == "intensity" || n == "reflectance" || n == "scalar_intensity" || n == "i" || n == "remission";
}

// The records' shape: each field's byte offset and ascii column, from the sizes and counts.
struct RecordShape {
  std::size_t stride = 0;   // bytes a binary record
  std::size_t columns = 0;  // values an ascii line
};

RecordShape lay_out(std::vector<Field>& fields, const std::string& name) {
  RecordShape shape;
  for (auto& f : fields) {
    f.offset = shape.stride;
    f.column = shape.columns;
    std::size_t bytes = 0;
    if (!checked_mul(f.size, f.count, bytes) || !checked_add(shape.stride, bytes, shape.stride) ||
        !checked_add(shape.columns, f.count, shape.columns))
      throw Error(name + ": field " + quoted(f.name) + " has COUNT " + std::to_string(f.count) +
                  ": the record size overflows (a damaged header?)");
  }
  return shape;
}

// Where x, y, z and the intensity are among the fields.
struct Roles {
  std::size_t x = 0, y = 0, z = 0;
  std::optional<std::size_t> intensity;
};

Roles find_roles(const std::vector<Field>& fields, const std::string& name) {
  std::optional<std::size_t> x, y, z;
  Roles r;
  for (std::size_t k = 0; k < fields.size(); ++k) {
    if (fields[k].name == "x") x = k;
    if (fields[k].name == "y") y = k;
    if (fields[k].name == "z") z = k;
    if (!r.intensity && is_intensity_name(fields[k].name)) r.intensity = k;
  }
  if (!x || !y || !z) throw Error(name + ": needs x, y and z fields");
  r.x = *x, r.y = *y, r.z = *z;
  return r;
}

// float32 holds the intensity: a value beyond its range would become inf, so it is refused.
float to_intensity(double v, std::size_t i, const std::string& name) {
  if (!(std::abs(v) <= FLT_MAX))
    throw Error(name + ": point " + std::to_string(i + 1) + " has an intensity that is not a finite float32 value");
  return static_cast<float>(v);
}

void check_finite(const Eigen::Vector3d& p, std::size_t i, const std::string& name) {
  if (!p.allFinite())
    throw Error(name + ": point " + std::to_string(i + 1) + " has a non-finite coordinate (NaN or inf; drop invalid points first)");
}

// `what` names the declared count for messages ("POINTS", "element vertex").
void fill_binary(Cloud& cloud, const std::vector<Field>& fields, const Roles& r, const RecordShape& shape, std::size_t n,
                 std::string_view data, const std::string& name, const std::string& what) {
  std::size_t need = 0;
  const bool fits = checked_mul(n, shape.stride, need);
  if (!fits || need > data.size())
    throw Error(name + ": " + what + " " + std::to_string(n) + " needs " +
                (fits ? std::to_string(need) : std::string("more than 2^64")) + " bytes of binary data (" +
                std::to_string(shape.stride) + " a point), the file has " + std::to_string(data.size()) +
                " after the header (truncated?)");
  cloud.points.resize(n);
  if (r.intensity) cloud.intensity.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    const char* rec = data.data() + i * shape.stride;
    auto value = [&](std::size_t k) { return read_scalar(rec + fields[k].offset, fields[k]); };
    cloud.points[i] = Eigen::Vector3d(value(r.x), value(r.y), value(r.z));
    check_finite(cloud.points[i], i, name);
    if (r.intensity) cloud.intensity[i] = to_intensity(value(*r.intensity), i, name);
  }
}

void fill_ascii(Cloud& cloud, const std::vector<Field>& fields, const Roles& r, const RecordShape& shape, std::size_t n,
                std::string_view data, const std::string& name, const std::string& what) {
  // A point is a line of `columns` values of at least one character, each followed by a separator
  // (the last line may lack its newline): fewer bytes cannot hold the points declared, so the
  // declared count is refused before it sizes anything.
  std::size_t per_point = 0, need = 0;
  const bool fits = checked_mul(shape.columns, 2, per_point) && checked_mul(n, per_point, need);
  if (n > 0 && (!fits || need - 1 > data.size()))
    throw Error(name + ": " + what + " " + std::to_string(n) + " needs at least " +
                (fits ? std::to_string(need - 1) : std::string("2^64")) + " bytes of ascii data (a line of " +
                std::to_string(shape.columns) + " values a point), the file has " + std::to_string(data.size()) +
                " after the header (truncated?)");
  cloud.points.resize(n);
  if (r.intensity) cloud.intensity.resize(n);
  std::size_t pos = 0;
  for (std::size_t i = 0; i < n;) {
    if (pos >= data.size()) throw Error(name + ": truncated: expected " + std::to_string(n) + " points, found " + std::to_string(i));
    std::size_t end = data.find('\n', pos);
    if (end == std::string_view::npos) end = data.size();
    const auto v = split_fields(data.substr(pos, end - pos), " \t\r");
    pos = end + 1;
    if (v.empty()) continue;  // blank lines carry no point
    if (v.size() < shape.columns)
      throw Error(name + ": point " + std::to_string(i + 1) + " has " + std::to_string(v.size()) + " values, expected " +
                  std::to_string(shape.columns));
    double x, y, z;
    if (!parse_double(v[fields[r.x].column], x) || !parse_double(v[fields[r.y].column], y) ||
        !parse_double(v[fields[r.z].column], z))
      throw Error(name + ": point " + std::to_string(i + 1) + " has a coordinate that is not a number");
    cloud.points[i] = Eigen::Vector3d(x, y, z);
    if (r.intensity) {
      double val = 0;
      if (!parse_double(v[fields[*r.intensity].column], val))
        throw Error(name + ": point " + std::to_string(i + 1) + " has an intensity that is not a number");
      cloud.intensity[i] = to_intensity(val, i, name);
    }
    ++i;
  }
}

void fill(Cloud& cloud, std::vector<Field>& fields, std::size_t n, std::string_view data, bool binary,
          const std::string& name, const std::string& what) {
  const Roles roles = find_roles(fields, name);
  const RecordShape shape = lay_out(fields, name);
  if (binary)
    fill_binary(cloud, fields, roles, shape, n, data, name, what);
  else
    fill_ascii(cloud, fields, roles, shape, n, data, name, what);
}

// ---- PCD ----

struct PcdHeader {
  std::vector<Field> fields;
  std::vector<std::string_view> sizes, types, counts;  // one per field, matched once the header is read
  std::optional<std::size_t> width, height, points;
  std::string_view data;  // the DATA encoding
  std::optional<GeoPoint> origin;
  std::size_t body = 0;  // where the records start
};

// "# origin LAT LON ALT", written by write_pcd. Other comments, and this one malformed, are comments.
void read_origin_comment(std::string_view line, PcdHeader& h, const std::string& name) {
  const auto o = split_fields(line.substr(9), " \t");
  GeoPoint g;
  if (o.size() != 3 || !parse_double(o[0], g.lat_deg) || !parse_double(o[1], g.lon_deg) || !parse_double(o[2], g.alt_m)) return;
  if (std::abs(g.lat_deg) > 90.0 || std::abs(g.lon_deg) > 180.0)
    throw Error(name + ": \"# origin LAT LON ALT\" must have lat in [-90, 90] and lon in [-180, 180] degrees, found " + quoted(line));
  h.origin = g;
}

std::size_t pcd_count(const std::vector<std::string_view>& words, const std::string& name) {
  std::size_t v = 0;
  if (words.size() != 2 || !parse_count(words[1], v))
    throw Error(name + ": PCD " + std::string(words[0]) + " needs one whole number >= 0, found " + quoted(words.size() > 1 ? words[1] : ""));
  return v;
}

// One header line; true at DATA, the last one.
bool read_pcd_header_line(std::string_view line, PcdHeader& h, std::set<std::string>& seen, const std::string& name) {
  if (line.rfind("# origin ", 0) == 0) {
    read_origin_comment(line, h, name);
    return false;
  }
  const auto words = split_fields(line, " \t");
  if (words.empty() || words[0][0] == '#') return false;  // blank or a comment
  const std::string key(words[0]);
  auto values = [&] { return std::vector<std::string_view>(words.begin() + 1, words.end()); };
  if (key != "FIELDS" && key != "SIZE" && key != "TYPE" && key != "COUNT" && key != "WIDTH" && key != "HEIGHT" &&
      key != "POINTS" && key != "DATA" && key != "VERSION" && key != "VIEWPOINT")
    throw Error(name + ": unexpected PCD header line " + quoted(line));
  // A repeated key would make its fields or counts ambiguous.
  if (!seen.insert(key).second) throw Error(name + ": PCD header has " + key + " twice");
  if (key == "FIELDS") {
    for (std::size_t k = 1; k < words.size(); ++k) h.fields.push_back({std::string(words[k])});
  } else if (key == "SIZE") {
    h.sizes = values();
  } else if (key == "TYPE") {
    h.types = values();
  } else if (key == "COUNT") {
    h.counts = values();
  } else if (key == "WIDTH") {
    h.width = pcd_count(words, name);
  } else if (key == "HEIGHT") {
    h.height = pcd_count(words, name);
  } else if (key == "POINTS") {
    h.points = pcd_count(words, name);
  } else if (key == "DATA") {
    h.data = words.size() > 1 ? words[1] : std::string_view();
    return true;
  }
  return false;
}

// SIZE, TYPE and COUNT into the fields: one of each per field, and a scalar this reader decodes.
void describe_pcd_fields(PcdHeader& h, const std::string& name) {
  const std::size_t n = h.fields.size();
  if (h.sizes.size() != n || h.types.size() != n || (!h.counts.empty() && h.counts.size() != n))
    throw Error(name + ": FIELDS names " + std::to_string(n) + " fields but SIZE has " + std::to_string(h.sizes.size()) +
                " values, TYPE " + std::to_string(h.types.size()) + " and COUNT " + std::to_string(h.counts.size()) +
                ": give one SIZE, TYPE and COUNT per field");
  for (std::size_t k = 0; k < n; ++k) {
    Field& f = h.fields[k];
    const bool size_ok = parse_count(h.sizes[k], f.size);
    f.type = h.types[k].size() == 1 ? h.types[k][0] : '?';
    if (!size_ok || !supported_scalar(f.type, f.size))
      throw Error(name + ": field " + quoted(f.name) + " is TYPE " + printable(h.types[k], 16) + " SIZE " + printable(h.sizes[k], 16) +
                  ", which this reader cannot decode (F with SIZE 4 or 8, I or U with SIZE 1, 2, 4 or 8)");
    if (!h.counts.empty() && (!parse_count(h.counts[k], f.count) || f.count == 0))
      throw Error(name + ": field " + quoted(f.name) + " has COUNT " + quoted(h.counts[k]) + ": expected a whole number >= 1");
  }
}

// POINTS, or WIDTH x HEIGHT when it is missing (or 0, as some writers leave it).
std::size_t pcd_point_count(const PcdHeader& h, const std::string& name) {
  if (h.points && *h.points > 0) return *h.points;
  std::size_t n = 0;
  if (!checked_mul(h.width.value_or(0), h.height.value_or(1), n))
    throw Error(name + ": WIDTH " + std::to_string(h.width.value_or(0)) + " x HEIGHT " + std::to_string(h.height.value_or(1)) +
                " overflows: the header is damaged");
  return n;
}

}  // namespace

Cloud parse_pcd(std::string_view bytes, const std::string& name) {
  PcdHeader h;
  std::set<std::string> seen;
  std::size_t pos = 0;
  std::string_view line;
  bool at_data = false;
  while (!at_data && take_line(bytes, pos, line)) at_data = read_pcd_header_line(line, h, seen, name);
  if (!at_data || h.data.empty()) throw Error(name + ": header has no DATA line (is this a PCD file?)");
  describe_pcd_fields(h, name);
  const std::size_t n = pcd_point_count(h, name);
  const bool binary = h.data == "binary";
  if (!binary && h.data != "ascii")
    throw Error(name + ": PCD DATA " + printable(h.data, 40) +
                " is not supported (ascii or binary; convert with pcl_convert_pcd_ascii_binary FILE OUT 1)");
  Cloud cloud;
  fill(cloud, h.fields, n, bytes.substr(pos), binary, name, "POINTS");
  cloud.origin = h.origin;
  return cloud;
}

Cloud read_pcd(const std::string& path) { return parse_pcd(slurp(path), path); }

namespace {

// ---- PLY ----

struct PlyHeader {
  std::vector<Field> fields;  // the vertex element's properties
  std::size_t vertices = 0;
  bool binary = false;
};

Field ply_property(const std::vector<std::string_view>& w, std::string_view line, const std::string& name) {
  if (w.size() < 3 || w[1] == "list") throw Error(name + ": vertex properties must be scalars, found " + quoted(line));
  const std::string_view t = w[1];
  Field f{std::string(w[2])};
  if (t == "float" || t == "float32") f.type = 'F', f.size = 4;
  else if (t == "double" || t == "float64") f.type = 'F', f.size = 8;
  else if (t == "uchar" || t == "uint8") f.type = 'U', f.size = 1;
  else if (t == "char" || t == "int8") f.type = 'I', f.size = 1;
  else if (t == "ushort" || t == "uint16") f.type = 'U', f.size = 2;
  else if (t == "short" || t == "int16") f.type = 'I', f.size = 2;
  else if (t == "uint" || t == "uint32") f.type = 'U', f.size = 4;
  else if (t == "int" || t == "int32") f.type = 'I', f.size = 4;
  else throw Error(name + ": PLY property type " + printable(t, 40) + " is not supported");
  return f;
}

PlyHeader read_ply_header(std::string_view bytes, std::size_t& pos, const std::string& name) {
  PlyHeader h;
  bool in_vertex = false, seen_vertex = false;
  std::string_view line;
  while (true) {
    if (!take_line(bytes, pos, line)) throw Error(name + ": PLY header has no end_header line");
    const auto w = split_fields(line, " \t");
    if (w.empty()) continue;
    if (w[0] == "end_header") break;
    if (w[0] == "format") {
      if (w.size() < 2) throw Error(name + ": bad PLY format line");
      if (w[1] == "ascii") h.binary = false;
      else if (w[1] == "binary_little_endian") h.binary = true;
      else throw Error(name + ": PLY format " + printable(w[1], 40) + " is not supported (ascii or binary_little_endian)");
    } else if (w[0] == "element") {
      std::size_t count = 0;
      if (w.size() != 3 || !parse_count(w[2], count))
        throw Error(name + ": expected \"element NAME COUNT\" (COUNT a whole number >= 0), found " + quoted(line));
      in_vertex = w[1] == "vertex";
      if (in_vertex && seen_vertex) throw Error(name + ": two vertex elements");
      // The records of an element before the vertices would have to be skipped, and those with
      // list properties have no fixed size: this reader needs the vertices first.
      if (!seen_vertex && !in_vertex)
        throw Error(name + ": PLY element " + printable(w[1], 40) + " comes before the vertex element; the vertex element must come first");
      if (in_vertex) seen_vertex = true, h.vertices = count;
    } else if (w[0] == "property" && in_vertex) {
      h.fields.push_back(ply_property(w, line, name));
    }
  }
  if (!seen_vertex) throw Error(name + ": PLY has no vertex element");
  return h;
}

}  // namespace

Cloud parse_ply(std::string_view bytes, const std::string& name) {
  if (bytes.substr(0, 3) != "ply") throw Error(name + ": not a PLY file (it must start with \"ply\")");
  std::size_t pos = 0;
  PlyHeader h = read_ply_header(bytes, pos, name);
  Cloud cloud;
  fill(cloud, h.fields, h.vertices, bytes.substr(pos), h.binary, name, "element vertex");
  return cloud;
}

Cloud read_ply(const std::string& path) { return parse_ply(slurp(path), path); }

namespace {

std::string lower_extension(const std::string& name) {
  const auto dot = name.find_last_of('.');
  std::string ext = dot == std::string::npos ? "" : name.substr(dot + 1);
  for (auto& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return ext;
}

Cloud cloud_of_scan(const Scan& scan) {
  Cloud cloud;
  cloud.points.reserve(scan.size());
  cloud.intensity.reserve(scan.size());
  for (const auto& p : scan) {
    cloud.points.emplace_back(p.x, p.y, p.z);
    cloud.intensity.push_back(p.intensity);
  }
  return cloud;
}

[[noreturn]] void unknown_format(const std::string& name) {
  throw Error(name + ": unknown cloud format (expected .pcd, .ply or .bin)");
}

}  // namespace

Cloud parse_cloud(std::string_view bytes, const std::string& name) {
  const std::string ext = lower_extension(name);
  if (ext == "pcd") return parse_pcd(bytes, name);
  if (ext == "ply") return parse_ply(bytes, name);
  if (ext == "bin") return cloud_of_scan(parse_kitti_bin(bytes, name));
  unknown_format(name);
}

Cloud read_cloud(const std::string& path) {
  const std::string ext = lower_extension(path);
  if (ext == "pcd") return read_pcd(path);
  if (ext == "ply") return read_ply(path);
  if (ext == "bin") return cloud_of_scan(read_kitti_bin(path));
  unknown_format(path);
}

}  // namespace pl
