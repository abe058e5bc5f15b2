#include "pl/common/cloud_io.hpp"

#include <liblzf/lzf.h>
#include <sys/stat.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cfloat>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <memory>
#include <nlohmann/json.hpp>
#include <set>

#include "pl/common/error.hpp"
#include "pl/common/scan.hpp"
#include "pl/common/text.hpp"
#include "cloud_fields.hpp"

namespace pl {

using namespace cloud_detail;

namespace {

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

// ---- The origin sidecar ----

// PCL and Open3D drop every header comment when they re-save a cloud, and with it the comment
// "# origin LAT LON ALT": the origin also goes into a file of its own beside the cloud, which a
// re-save leaves alone.
std::string origin_sidecar(const std::string& pcd_path) { return pcd_path + ".origin.json"; }

bool valid_origin(const GeoPoint& g) {
  return std::abs(g.lat_deg) <= 90.0 && std::abs(g.lon_deg) <= 180.0 && std::isfinite(g.alt_m);
}

std::string describe(const GeoPoint& g) {
  char buf[160];
  std::snprintf(buf, sizeof(buf), "lat %.10f lon %.10f alt %.4f", g.lat_deg, g.lon_deg, g.alt_m);
  return buf;
}

void write_origin_sidecar(const std::string& path, const GeoPoint& g) {
  nlohmann::ordered_json j;  // in the order a reader expects: lat, lon, alt
  j["lat"] = g.lat_deg;
  j["lon"] = g.lon_deg;
  j["alt"] = g.alt_m;
  j["frame"] = "ENU";
  const std::string text = j.dump(2) + "\n";
  std::unique_ptr<std::FILE, int (*)(std::FILE*)> f(std::fopen(path.c_str(), "wb"), &std::fclose);
  if (!f) throw Error(path + ": cannot write (" + std::strerror(errno) + ")");
  if (std::fwrite(text.data(), 1, text.size(), f.get()) != text.size() || std::fclose(f.release()) != 0)
    throw Error(path + ": write failed (disk full?)");
}

// The origin recorded beside a PCD, or nothing when there is no such file.
std::optional<GeoPoint> read_origin_sidecar(const std::string& path) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) {
    if (errno == ENOENT) return std::nullopt;
    throw Error(path + ": cannot open (" + std::strerror(errno) + ")");
  }
  // An origin takes a hundred bytes: anything far larger is some other file under this name.
  if (S_ISREG(st.st_mode) && st.st_size > 65536)
    throw Error(path + ": " + std::to_string(st.st_size) + " bytes is not an origin file; remove or rename it");
  const std::string text = slurp(path);
  const std::string expected = " (expected {\"lat\": DEGREES, \"lon\": DEGREES, \"alt\": METRES, \"frame\": \"ENU\"})";
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception& e) {
    // A number beyond double's range is an out_of_range error, not a parse_error: both land here.
    throw Error(path + ": not valid JSON: " + printable(e.what(), 300) + expected);
  }
  if (!j.is_object()) throw Error(path + ": not an origin" + expected);
  auto number = [&](const char* key) {
    const auto it = j.find(key);
    if (it == j.end()) throw Error(path + ": missing \"" + key + "\"" + expected);
    if (!it->is_number()) throw Error(path + ": \"" + key + "\" must be a number, not a JSON " + it->type_name() + expected);
    return it->get<double>();
  };
  const GeoPoint g{number("lat"), number("lon"), number("alt")};
  if (const auto frame = j.find("frame"); frame != j.end() && !(frame->is_string() && frame->get<std::string>() == "ENU"))
    throw Error(path + ": \"frame\" must be \"ENU\" (the cloud's x east, y north, z up about the origin), found " +
                (frame->is_string() ? in_quotes(frame->get<std::string>()) : "a JSON " + std::string(frame->type_name())));
  if (!valid_origin(g))
    throw Error(path + ": the origin must have lat in [-90, 90] and lon in [-180, 180] degrees, found " + describe(g));
  return g;
}

// The comment keeps 10 decimals of a degree and 4 of a metre: a tolerance of 1e-9 degrees (about
// 0.1 mm) and 1 mm lets both records of one origin agree, and no two maps' origins.
bool same_origin(const GeoPoint& a, const GeoPoint& b) {
  double dlon = std::abs(a.lon_deg - b.lon_deg);
  dlon = std::min(dlon, 360.0 - dlon);  // -180 and 180 degrees are one meridian
  return std::abs(a.lat_deg - b.lat_deg) <= 1e-9 && dlon <= 1e-9 && std::abs(a.alt_m - b.alt_m) <= 1e-3;
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

}  // namespace

void write_pcd(const std::string& path, const Points3d& points, const std::vector<float>& intensity,
               const std::optional<GeoPoint>& origin) {
  if (!intensity.empty() && intensity.size() != points.size()) throw Error("write_pcd: one intensity per point expected");
  if (origin && !valid_origin(*origin))
    throw Error(path + ": the origin must have lat in [-90, 90] and lon in [-180, 180] degrees and a finite alt, found " +
                describe(*origin));
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
      if (std::fwrite(buf.data(), sizeof(float), buf.size(), f.get()) != buf.size())
        throw Error(path + ": write failed (disk full?)");
      buf.clear();
    }
  }
  if (std::fclose(f.release()) != 0) throw Error(path + ": write failed (disk full?)");
  const std::string sidecar = origin_sidecar(path);
  if (origin) {
    write_origin_sidecar(sidecar, *origin);
  } else if (std::remove(sidecar.c_str()) != 0 && errno != ENOENT) {
    // An earlier cloud's origin file left beside this one would give it that cloud's origin.
    throw Error(sidecar + ": cannot remove (" + std::strerror(errno) + "); it records the origin of an earlier cloud at " + path +
                ", written again now without an origin: delete it");
  }
}

namespace {

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
    throw Error(name + ": \"# origin LAT LON ALT\" must have lat in [-90, 90] and lon in [-180, 180] degrees, found " +
                in_quotes(line));
  h.origin = g;
}

std::size_t pcd_count(const std::vector<std::string_view>& words, const std::string& name) {
  std::size_t v = 0;
  if (words.size() != 2 || !parse_count(words[1], v))
    throw Error(name + ": PCD " + std::string(words[0]) + " needs one whole number >= 0, found " +
                in_quotes(words.size() > 1 ? words[1] : ""));
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
    throw Error(name + ": unexpected PCD header line " + in_quotes(line));
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
      throw Error(name + ": field " + in_quotes(f.name) + " is TYPE " + printable(h.types[k], 16) + " SIZE " +
                  printable(h.sizes[k], 16) +
                  ", which this reader cannot decode (F with SIZE 4 or 8, I or U with SIZE 1, 2, 4 or 8)");
    if (!h.counts.empty() && (!parse_count(h.counts[k], f.count) || f.count == 0))
      throw Error(name + ": field " + in_quotes(f.name) + " has COUNT " + in_quotes(h.counts[k]) +
                  ": expected a whole number >= 1");
  }
}

// POINTS, which must be WIDTH x HEIGHT when the header gives both (HEIGHT 1 when missing), or WIDTH
// x HEIGHT when POINTS is missing.
std::size_t pcd_point_count(const PcdHeader& h, const std::string& name) {
  std::optional<std::size_t> grid;
  if (h.width) {
    std::size_t wh = 0;
    if (!checked_mul(*h.width, h.height.value_or(1), wh))
      throw Error(name + ": WIDTH " + std::to_string(*h.width) + " x HEIGHT " + std::to_string(h.height.value_or(1)) +
                  " overflows: the header is damaged");
    grid = wh;
  }
  // PCL refuses such a file too: one of the two counts is wrong, and which one decides where the
  // points end.
  if (h.points && grid && *h.points != *grid)
    throw Error(name + ": POINTS " + std::to_string(*h.points) + " but WIDTH " + std::to_string(*h.width) + " x HEIGHT " +
                std::to_string(h.height.value_or(1)) + " = " + std::to_string(*grid) +
                ": the header contradicts itself; make POINTS equal WIDTH x HEIGHT (for an unorganised cloud, WIDTH = POINTS "
                "and HEIGHT 1)");
  return h.points ? *h.points : grid.value_or(0);
}

// The most bytes LZF data unpacks to, a multiple of its size: its densest token is a long back
// reference, 3 bytes that repeat up to 264 bytes already unpacked.
constexpr std::uint64_t kLzfMaxExpansion = 88;

// DATA binary_compressed, as PCL and Open3D write it: the compressed and the uncompressed size
// (uint32 each), then that many bytes of LZF data (anything after them is ignored, as PCL writes a
// file in whole pages). Unpacked, the points are stored field by field: every point's x, then every
// point's y, and so on, each value SIZE x COUNT bytes.
//
// Padding fields "_" hold nothing: PCL's writer leaves them out of the header and the data, and its
// reader skips them in the columns, while Open3D's reader expects their columns in. Both are read,
// told apart by the uncompressed size, which differs whenever a padding field has bytes.
void fill_pcd_compressed(Cloud& cloud, std::vector<Field>& fields, std::size_t n, std::string_view data,
                         const std::string& name) {
  const Roles roles = find_roles(fields, name);
  const RecordShape shape = lay_out(fields, name);
  if (data.size() < 8)
    throw Error(name + ": DATA binary_compressed needs 8 bytes after the header (the compressed and the uncompressed size), " +
                "the file has " + std::to_string(data.size()) + " (truncated?)");
  std::uint32_t compressed = 0, uncompressed = 0;
  std::memcpy(&compressed, data.data(), 4);
  std::memcpy(&uncompressed, data.data() + 4, 4);
  std::size_t packed_stride = 0;  // the bytes of a point without padding; it cannot overflow where shape.stride did not
  for (const auto& f : fields)
    if (f.name != "_") packed_stride += f.size * f.count;
  std::size_t packed = 0, padded = 0;
  const bool packed_fits = checked_mul(n, packed_stride, packed), padded_fits = checked_mul(n, shape.stride, padded);
  const bool with_padding = padded_fits && uncompressed == padded && packed_stride != shape.stride;
  if (!(packed_fits && uncompressed == packed) && !with_padding)
    throw Error(name + ": binary_compressed data unpacks to " + std::to_string(uncompressed) + " bytes, but POINTS " +
                std::to_string(n) + " of " + std::to_string(packed_stride) + " bytes need " +
                (packed_fits ? std::to_string(packed) : std::string("more than 2^64")) +
                (packed_stride != shape.stride ? " (" + (padded_fits ? std::to_string(padded) : std::string("more than 2^64")) +
                                                     " with the padding fields \"_\")"
                                               : std::string()) +
                ": the header and the data disagree (a damaged file?)");
  if (compressed > data.size() - 8)
    throw Error(name + ": binary_compressed data of " + std::to_string(compressed) +
                " bytes runs past the end of the file, which has " + std::to_string(data.size() - 8) +
                " after the sizes (truncated?)");
  std::vector<char> plain;
  if (uncompressed > 0) {
    // lzf_decompress reads one byte even of empty input.
    if (compressed == 0)
      throw Error(name + ": binary_compressed data of 0 bytes cannot unpack to " + std::to_string(uncompressed) +
                  " (a damaged file?)");
    // A few bytes must not make the reader allocate gigabytes before the data turns out short.
    if (compressed * kLzfMaxExpansion < uncompressed)
      throw Error(name + ": binary_compressed data of " + std::to_string(compressed) + " bytes cannot unpack to " +
                  std::to_string(uncompressed) + " (LZF unpacks to at most " + std::to_string(kLzfMaxExpansion) +
                  " times its size): a damaged file");
    plain.resize(uncompressed);
    const unsigned got = lzf_decompress(data.data() + 8, compressed, plain.data(), uncompressed);
    if (got != uncompressed)
      throw Error(name + ": binary_compressed data is corrupt: its " + std::to_string(compressed) + " bytes of LZF " +
                  (got == 0 ? std::string("do not unpack") : "unpack to " + std::to_string(got) + " bytes") +
                  " where the header says " + std::to_string(uncompressed) + " (a damaged file?)");
  }
  BinaryLayout layout;
  std::size_t column = 0;  // where the next field's values start, per point
  for (const auto& f : fields) {
    const bool stored = with_padding || f.name != "_";
    layout.base.push_back(stored ? n * column : 0);  // a padding field left out is never read: no field of a role is "_"
    layout.step.push_back(f.size * f.count);
    if (stored) column += f.size * f.count;
  }
  decode_binary(cloud, fields, roles, layout, n, std::string_view(plain.data(), plain.size()), NonFinite::Drop, name);
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
  Cloud cloud;
  if (h.data == "binary_compressed")
    fill_pcd_compressed(cloud, h.fields, n, bytes.substr(pos), name);
  else if (h.data == "binary" || h.data == "ascii")
    fill(cloud, h.fields, n, bytes.substr(pos), h.data == "binary", NonFinite::Drop, name, "POINTS");
  else
    throw Error(name + ": PCD DATA " + printable(h.data, 40) + " is not supported (ascii, binary or binary_compressed)");
  cloud.origin = h.origin;
  return cloud;
}

Cloud read_pcd(const std::string& path) {
  Cloud cloud = parse_pcd(slurp(path), path);
  const std::string sidecar = origin_sidecar(path);
  if (const auto recorded = read_origin_sidecar(sidecar)) {
    // Two records of the origin that disagree: the cloud was re-saved next to another map's origin
    // file, or the other way round. Either may be the right one; guessing would misplace the map.
    if (cloud.origin && !same_origin(*cloud.origin, *recorded))
      throw Error(sidecar + " records the origin " + describe(*recorded) + " but the \"# origin\" comment of " + path + " says " +
                  describe(*cloud.origin) + ": one of the two belongs to another map; delete the wrong one " +
                  "(or write the cloud again with write_pcd, which writes both)");
    cloud.origin = recorded;  // the full precision of the two
  }
  return cloud;
}

namespace {

// ---- PLY ----

struct PlyHeader {
  std::vector<Field> fields;  // the vertex element's properties
  std::size_t vertices = 0;
  bool binary = false;
};

Field ply_property(const std::vector<std::string_view>& w, std::string_view line, const std::string& name) {
  if (w.size() < 3 || w[1] == "list") throw Error(name + ": vertex properties must be scalars, found " + in_quotes(line));
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
        throw Error(name + ": expected \"element NAME COUNT\" (COUNT a whole number >= 0), found " + in_quotes(line));
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
  fill(cloud, h.fields, h.vertices, bytes.substr(pos), h.binary, NonFinite::Refuse, name, "element vertex");
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
