#include "pl/common/cloud_io.hpp"

#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <memory>

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

struct Field {
  std::string name;
  char type = 'F';  // F float, I signed, U unsigned
  int size = 4;
  int count = 1;
  std::size_t offset = 0;  // bytes into a binary record
};

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
  return NAN;
}

std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path + ": cannot open");
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

bool is_intensity_name(const std::string& n) {
  return n == "intensity" || n == "reflectance" || n == "scalar_intensity" || n == "i" || n == "remission";
}

// Fills the cloud from records described by `fields`: binary (`stride` bytes each) or ascii lines.
void fill(Cloud& cloud, const std::string& path, const std::vector<Field>& fields, std::size_t n, const std::string& body,
          std::size_t start, bool binary, std::size_t stride) {
  int ix = -1, iy = -1, iz = -1, ii = -1;
  for (std::size_t k = 0; k < fields.size(); ++k) {
    if (fields[k].name == "x") ix = static_cast<int>(k);
    if (fields[k].name == "y") iy = static_cast<int>(k);
    if (fields[k].name == "z") iz = static_cast<int>(k);
    if (ii < 0 && is_intensity_name(fields[k].name)) ii = static_cast<int>(k);
  }
  if (ix < 0 || iy < 0 || iz < 0) throw Error(path + ": needs x, y and z fields");
  cloud.points.resize(n);
  if (ii >= 0) cloud.intensity.resize(n);
  if (binary) {
    if (body.size() < start + n * stride)
      throw Error(path + ": truncated: " + std::to_string(n) + " points of " + std::to_string(stride) + " bytes need " +
                  std::to_string(start + n * stride) + " bytes, the file has " + std::to_string(body.size()));
    for (std::size_t i = 0; i < n; ++i) {
      const char* rec = body.data() + start + i * stride;
      cloud.points[i] = Eigen::Vector3d(read_scalar(rec + fields[ix].offset, fields[ix]), read_scalar(rec + fields[iy].offset, fields[iy]),
                                        read_scalar(rec + fields[iz].offset, fields[iz]));
      if (ii >= 0) cloud.intensity[i] = static_cast<float>(read_scalar(rec + fields[ii].offset, fields[ii]));
    }
  } else {
    std::size_t pos = start, line_no = 0, columns = 0;
    std::vector<std::size_t> column_of(fields.size());
    for (std::size_t k = 0; k < fields.size(); ++k) column_of[k] = columns, columns += static_cast<std::size_t>(fields[k].count);
    for (std::size_t i = 0; i < n; ++i) {
      std::size_t end = body.find('\n', pos);
      if (pos >= body.size()) throw Error(path + ": truncated: expected " + std::to_string(n) + " points, found " + std::to_string(i));
      if (end == std::string::npos) end = body.size();
      std::string_view line(body.data() + pos, end - pos);
      pos = end + 1;
      ++line_no;
      auto v = split_fields(line, " \t\r");
      if (v.empty()) { --i; continue; }
      if (v.size() < columns) throw Error(path + ": point " + std::to_string(i + 1) + " has " + std::to_string(v.size()) + " values, expected " + std::to_string(columns));
      double x, y, z;
      if (!parse_double(v[column_of[ix]], x) || !parse_double(v[column_of[iy]], y) || !parse_double(v[column_of[iz]], z))
        throw Error(path + ": point " + std::to_string(i + 1) + " has a coordinate that is not a number");
      cloud.points[i] = Eigen::Vector3d(x, y, z);
      if (ii >= 0) {
        double val = 0;
        parse_double(v[column_of[ii]], val);
        cloud.intensity[i] = static_cast<float>(val);
      }
    }
  }
  for (const auto& p : cloud.points)
    if (!p.allFinite()) throw Error(path + ": has a point with a non-finite coordinate");
}

}  // namespace

Cloud read_pcd(const std::string& path) {
  std::string body = slurp(path);
  std::vector<Field> fields;
  std::vector<int> sizes, counts;
  std::vector<char> types;
  std::optional<GeoPoint> origin;
  std::size_t points = 0, width = 0, height = 1, pos = 0;
  std::string data;
  while (pos < body.size()) {
    std::size_t end = body.find('\n', pos);
    if (end == std::string::npos) throw Error(path + ": header has no DATA line (is this a PCD file?)");
    std::string line = body.substr(pos, end - pos);
    pos = end + 1;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.rfind("# origin ", 0) == 0) {
      std::string values = line.substr(9);
      auto o = split_fields(values, " \t");
      GeoPoint g;
      if (o.size() == 3 && parse_double(o[0], g.lat_deg) && parse_double(o[1], g.lon_deg) && parse_double(o[2], g.alt_m)) origin = g;
      continue;
    }
    if (line.empty() || line[0] == '#') continue;
    auto words = split_fields(line, " \t");
    std::string key(words[0]);
    auto rest = [&](std::size_t k) { return std::string(words[k]); };
    if (key == "FIELDS") {
      for (std::size_t k = 1; k < words.size(); ++k) fields.push_back({rest(k)});
    } else if (key == "SIZE") {
      for (std::size_t k = 1; k < words.size(); ++k) sizes.push_back(std::atoi(rest(k).c_str()));
    } else if (key == "TYPE") {
      for (std::size_t k = 1; k < words.size(); ++k) types.push_back(words[k].empty() ? '?' : words[k][0]);
    } else if (key == "COUNT") {
      for (std::size_t k = 1; k < words.size(); ++k) counts.push_back(std::atoi(rest(k).c_str()));
    } else if (key == "WIDTH" && words.size() > 1) {
      width = std::strtoull(rest(1).c_str(), nullptr, 10);
    } else if (key == "HEIGHT" && words.size() > 1) {
      height = std::strtoull(rest(1).c_str(), nullptr, 10);
    } else if (key == "POINTS" && words.size() > 1) {
      points = std::strtoull(rest(1).c_str(), nullptr, 10);
    } else if (key == "DATA") {
      data = words.size() > 1 ? rest(1) : "";
      break;
    } else if (key != "VERSION" && key != "VIEWPOINT") {
      throw Error(path + ": unexpected PCD header line \"" + line + "\"");
    }
  }
  if (data.empty()) throw Error(path + ": header has no DATA line (is this a PCD file?)");
  if (sizes.size() != fields.size() || types.size() != fields.size())
    throw Error(path + ": FIELDS, SIZE and TYPE must name the same number of fields");
  if (counts.empty()) counts.assign(fields.size(), 1);
  if (points == 0) points = width * height;
  std::size_t stride = 0;
  for (std::size_t k = 0; k < fields.size(); ++k) {
    fields[k].size = sizes[k];
    fields[k].type = types[k];
    fields[k].count = counts[k];
    fields[k].offset = stride;
    stride += static_cast<std::size_t>(sizes[k] * counts[k]);
  }
  Cloud cloud;
  if (data == "ascii")
    fill(cloud, path, fields, points, body, pos, false, stride);
  else if (data == "binary")
    fill(cloud, path, fields, points, body, pos, true, stride);
  else
    throw Error(path + ": PCD DATA " + data + " is not supported (ascii or binary; convert with pcl_convert_pcd_ascii_binary FILE OUT 1)");
  cloud.origin = origin;
  return cloud;
}

Cloud read_ply(const std::string& path) {
  std::string body = slurp(path);
  if (body.rfind("ply", 0) != 0) throw Error(path + ": not a PLY file (it must start with \"ply\")");
  std::vector<Field> fields;
  std::size_t vertices = 0, pos = 0, stride = 0;
  bool in_vertex = false, binary = false, seen_vertex = false;
  while (true) {
    std::size_t end = body.find('\n', pos);
    if (end == std::string::npos) throw Error(path + ": PLY header has no end_header line");
    std::string line = body.substr(pos, end - pos);
    pos = end + 1;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    auto w = split_fields(line, " \t");
    if (w.empty()) continue;
    if (w[0] == "end_header") break;
    if (w[0] == "format") {
      if (w.size() < 2) throw Error(path + ": bad PLY format line");
      if (w[1] == "ascii") binary = false;
      else if (w[1] == "binary_little_endian") binary = true;
      else throw Error(path + ": PLY format " + std::string(w[1]) + " is not supported (ascii or binary_little_endian)");
    } else if (w[0] == "element") {
      in_vertex = w.size() > 2 && w[1] == "vertex";
      if (in_vertex) {
        if (seen_vertex) throw Error(path + ": two vertex elements");
        if (!fields.empty() || stride) throw Error(path + ": the vertex element must come first");
        seen_vertex = true;
        vertices = std::strtoull(std::string(w[2]).c_str(), nullptr, 10);
      }
    } else if (w[0] == "property" && in_vertex) {
      if (w.size() < 3 || w[1] == "list") throw Error(path + ": vertex properties must be scalars");
      std::string t(w[1]);
      Field f{std::string(w[2])};
      if (t == "float" || t == "float32") f.type = 'F', f.size = 4;
      else if (t == "double" || t == "float64") f.type = 'F', f.size = 8;
      else if (t == "uchar" || t == "uint8") f.type = 'U', f.size = 1;
      else if (t == "char" || t == "int8") f.type = 'I', f.size = 1;
      else if (t == "ushort" || t == "uint16") f.type = 'U', f.size = 2;
      else if (t == "short" || t == "int16") f.type = 'I', f.size = 2;
      else if (t == "uint" || t == "uint32") f.type = 'U', f.size = 4;
      else if (t == "int" || t == "int32") f.type = 'I', f.size = 4;
      else throw Error(path + ": PLY property type " + t + " is not supported");
      f.offset = stride;
      stride += static_cast<std::size_t>(f.size);
      fields.push_back(f);
    }
  }
  if (!seen_vertex) throw Error(path + ": PLY has no vertex element");
  Cloud cloud;
  fill(cloud, path, fields, vertices, body, pos, binary, stride);
  return cloud;
}

Cloud read_cloud(const std::string& path) {
  auto dot = path.find_last_of('.');
  std::string ext = dot == std::string::npos ? "" : path.substr(dot + 1);
  for (auto& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (ext == "pcd") return read_pcd(path);
  if (ext == "ply") return read_ply(path);
  if (ext == "bin") {
    Scan scan = read_kitti_bin(path);
    Cloud cloud;
    for (const auto& p : scan) {
      cloud.points.emplace_back(p.x, p.y, p.z);
      cloud.intensity.push_back(p.intensity);
    }
    return cloud;
  }
  throw Error(path + ": unknown cloud format (expected .pcd, .ply or .bin)");
}

}  // namespace pl
