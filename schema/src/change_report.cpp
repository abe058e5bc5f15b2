// The change report's JSON: written by the vehicle, parsed by the map service (which trusts nothing
// in it: every field is checked, and the size bounded before it is parsed).
#include "pl/schema/change_report.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>
#include <tuple>

#include "pl/common/error.hpp"
#include "pl/schema/api_rules.hpp"

namespace pl::schema {

namespace {

using json = nlohmann::json;
constexpr int kFormatVersion = 1;
constexpr std::size_t kCellFields = 7;

const json& field(const json& j, const char* name, const char* where) {
  auto it = j.find(name);
  if (it == j.end()) throw Error(std::string("change report: ") + where + " has no \"" + name + "\"");
  return *it;
}

std::string text_field(const json& j, const char* name) {
  const json& v = field(j, name, "the report");
  if (!v.is_string()) throw Error(std::string("change report: \"") + name + "\" must be a string");
  return v.get<std::string>();
}

double number_field(const json& j, const char* name, const char* where) {
  const json& v = field(j, name, where);
  if (!v.is_number()) throw Error(std::string("change report: ") + where + "'s \"" + name + "\" must be a number");
  const double d = v.get<double>();
  if (!std::isfinite(d)) throw Error(std::string("change report: ") + where + "'s \"" + name + "\" must be finite");
  return d;
}

std::int64_t integer_field(const json& j, const char* name, const char* where, std::int64_t lo, std::int64_t hi) {
  const json& v = field(j, name, where);
  if (!v.is_number_integer()) throw Error(std::string("change report: ") + where + "'s \"" + name + "\" must be an integer");
  const std::int64_t i = v.is_number_unsigned() && v.get<std::uint64_t>() > static_cast<std::uint64_t>(INT64_MAX)
                             ? INT64_MAX
                             : v.get<std::int64_t>();
  if (i < lo || i > hi)
    throw Error(std::string("change report: ") + where + "'s \"" + name + "\" is " + std::to_string(i) + ", outside " +
                std::to_string(lo) + ".." + std::to_string(hi));
  return i;
}

}  // namespace

bool valid_id(std::string_view s) {
  if (s.empty() || s.size() > 128) return false;
  return std::all_of(s.begin(), s.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' || c == '.' || c == ':' || c == '-';
  });
}

std::array<std::int32_t, 3> voxel_of_cm(const std::array<std::int32_t, 3>& p, double voxel_m) {
  std::array<std::int32_t, 3> v{};
  for (int k = 0; k < 3; ++k) v[k] = static_cast<std::int32_t>(std::floor(p[k] / (100.0 * voxel_m)));
  return v;
}

std::string change_report_json(const ChangeReport& r) {
  json tiles = json::array();
  for (const TileChangeEvidence& t : r.tiles) {
    json cells = json::array();
    for (const ChangeCell& c : t.cells) {
      cells.push_back(c.x);
      cells.push_back(c.y);
      cells.push_back(c.z);
      cells.push_back(c.added);
      cells.push_back(c.free);
      cells.push_back(c.seen);
      cells.push_back(c.passed);
    }
    json tile = {{"tx", t.key.tx}, {"ty", t.key.ty}, {"scans", t.scans}, {"cells", std::move(cells)}};
    if (!t.points.empty()) {
      json points = json::array();
      for (const auto& p : t.points)
        for (std::int32_t v : p) points.push_back(v);
      tile["points"] = std::move(points);
    }
    tiles.push_back(std::move(tile));
  }
  json j = {{"format", "pl-change-report"}, {"format_version", kFormatVersion}, {"map", r.map}, {"version", r.version},
            {"vehicle", r.vehicle}, {"drive", r.drive}, {"start", r.start}, {"end", r.end}, {"voxel_m", r.voxel_m},
            {"tile_m", r.tile_m}, {"tiles", std::move(tiles)}};
  return j.dump();
}

ChangeReport parse_change_report(std::string_view text, const ChangeReportLimits& limits) {
  if (text.size() > limits.max_bytes)
    throw Error("change report: " + std::to_string(text.size()) + " bytes, more than the " + std::to_string(limits.max_bytes) +
                " a report may be (send the drive's evidence in several reports)");
  // A report is three levels deep; deeper nesting is refused before it is built.
  json j;
  try {
    j = json::parse(text.begin(), text.end(), [](int depth, json::parse_event_t, json&) {
      if (depth > 4) throw Error("change report: nested deeper than a report is");
      return true;
    });
  } catch (const json::exception& e) {
    throw Error(std::string("change report: not JSON (") + e.what() + ")");
  }
  if (!j.is_object()) throw Error("change report: not a JSON object");
  if (text_field(j, "format") != "pl-change-report") throw Error("change report: \"format\" must be \"pl-change-report\"");
  const std::int64_t fv = integer_field(j, "format_version", "the report", 0, INT64_MAX);
  if (fv != kFormatVersion)
    throw Error("change report: format_version " + std::to_string(fv) + " is not known here (this service reads version " +
                std::to_string(kFormatVersion) + ")");
  ChangeReport r;
  r.map = text_field(j, "map");
  if (!api::valid_map_name(r.map)) throw Error("change report: \"map\" is not a map name (1-64 of A-Z a-z 0-9 _ . -)");
  r.version = integer_field(j, "version", "the report", 1, INT64_MAX);
  r.vehicle = text_field(j, "vehicle");
  r.drive = text_field(j, "drive");
  if (!valid_id(r.vehicle)) throw Error("change report: \"vehicle\" must be 1-128 of A-Z a-z 0-9 _ . : -");
  if (!valid_id(r.drive)) throw Error("change report: \"drive\" must be 1-128 of A-Z a-z 0-9 _ . : -");
  r.start = number_field(j, "start", "the report");
  r.end = number_field(j, "end", "the report");
  if (r.end < r.start) throw Error("change report: \"end\" is before \"start\"");
  r.voxel_m = number_field(j, "voxel_m", "the report");
  if (!(r.voxel_m >= 0.05 && r.voxel_m <= 10.0)) throw Error("change report: \"voxel_m\" must be within 0.05..10");
  r.tile_m = number_field(j, "tile_m", "the report");
  if (!api::valid_tile_size(r.tile_m)) throw Error("change report: \"tile_m\" is not a tile size this service knows (1..1000 m)");
  const json& tiles = field(j, "tiles", "the report");
  if (!tiles.is_array()) throw Error("change report: \"tiles\" must be an array");
  if (tiles.size() > limits.max_tiles)
    throw Error("change report: " + std::to_string(tiles.size()) + " tiles, more than the " + std::to_string(limits.max_tiles) +
                " a report may hold");
  const TileGrid grid(r.tile_m);
  std::size_t cells_total = 0, points_total = 0;
  for (const json& t : tiles) {
    if (!t.is_object()) throw Error("change report: a tile must be an object");
    TileChangeEvidence e;
    e.key.tx = static_cast<std::int32_t>(integer_field(t, "tx", "a tile", INT32_MIN, INT32_MAX));
    e.key.ty = static_cast<std::int32_t>(integer_field(t, "ty", "a tile", INT32_MIN, INT32_MAX));
    if (!r.tiles.empty() && !(r.tiles.back().key < e.key))
      throw Error("change report: tiles must be in key order (tx, then ty), each once");
    e.scans = static_cast<std::uint32_t>(integer_field(t, "scans", "a tile", 0, UINT32_MAX));
    const json& cells = field(t, "cells", "a tile");
    if (!cells.is_array() || cells.size() % kCellFields != 0)
      throw Error("change report: a tile's \"cells\" must be an array of 7 integers per voxel (x, y, z, added, free, seen, passed)");
    cells_total += cells.size() / kCellFields;
    if (cells_total > limits.max_cells)
      throw Error("change report: more than the " + std::to_string(limits.max_cells) + " voxels a report may hold");
    const TileBounds b = grid.bounds_of(e.key);
    e.cells.reserve(cells.size() / kCellFields);
    for (std::size_t i = 0; i < cells.size(); i += kCellFields) {
      std::int64_t v[kCellFields];
      for (std::size_t k = 0; k < kCellFields; ++k) {
        const json& x = cells[i + k];
        if (!x.is_number_integer()) throw Error("change report: a voxel's fields must be integers");
        if (k < 3) {
          if (x.is_number_unsigned() ? x.get<std::uint64_t>() > INT32_MAX : (x.get<std::int64_t>() < INT32_MIN || x.get<std::int64_t>() > INT32_MAX))
            throw Error("change report: a voxel index is outside 32 bits");
          v[k] = x.get<std::int64_t>();
        } else {
          if (!x.is_number_unsigned() && x.get<std::int64_t>() < 0) throw Error("change report: a voxel's count is negative");
          if (x.get<std::uint64_t>() > UINT32_MAX) throw Error("change report: a voxel's count is outside 32 bits");
          v[k] = static_cast<std::int64_t>(x.get<std::uint64_t>());
        }
      }
      ChangeCell c{static_cast<std::int32_t>(v[0]), static_cast<std::int32_t>(v[1]), static_cast<std::int32_t>(v[2]),
                   static_cast<std::uint32_t>(v[3]), static_cast<std::uint32_t>(v[4]), static_cast<std::uint32_t>(v[5]),
                   static_cast<std::uint32_t>(v[6])};
      // The voxel's centre must lie in its tile (a voxel straddling a tile edge belongs to the tile
      // of its centre).
      const double cx = (c.x + 0.5) * r.voxel_m, cy = (c.y + 0.5) * r.voxel_m;
      if (!b.contains(cx, cy))
        throw Error("change report: voxel (" + std::to_string(c.x) + ", " + std::to_string(c.y) + ") lies outside its tile (" +
                    std::to_string(e.key.tx) + ", " + std::to_string(e.key.ty) + ")");
      if (!e.cells.empty()) {
        const ChangeCell& p = e.cells.back();
        if (!(std::tie(p.x, p.y, p.z) < std::tie(c.x, c.y, c.z)))
          throw Error("change report: a tile's voxels must be in (x, y, z) order, each once");
      }
      e.cells.push_back(c);
    }
    auto pit = t.find("points");
    if (pit != t.end()) {
      const json& pts = *pit;
      if (!pts.is_array() || pts.size() % 3 != 0)
        throw Error("change report: a tile's \"points\" must be an array of 3 integers per point (x, y, z in centimetres)");
      points_total += pts.size() / 3;
      if (points_total > limits.max_points)
        throw Error("change report: more than the " + std::to_string(limits.max_points) + " sample points a report may hold");
      e.points.reserve(pts.size() / 3);
      for (std::size_t i = 0; i < pts.size(); i += 3) {
        std::array<std::int32_t, 3> p{};
        for (std::size_t k = 0; k < 3; ++k) {
          const json& x = pts[i + k];
          if (!x.is_number_integer() ||
              (x.is_number_unsigned() ? x.get<std::uint64_t>() > INT32_MAX : (x.get<std::int64_t>() < INT32_MIN || x.get<std::int64_t>() > INT32_MAX)))
            throw Error("change report: a sample point's coordinates must be integers of 32 bits (centimetres)");
          p[k] = static_cast<std::int32_t>(x.get<std::int64_t>());
        }
        if (!e.points.empty() && !(e.points.back() < p))
          throw Error("change report: a tile's sample points must be in (x, y, z) order, each once");
        // In a voxel the tile reports added (what is not reported added there is no new structure).
        const auto v = voxel_of_cm(p, r.voxel_m);
        const auto c = std::lower_bound(e.cells.begin(), e.cells.end(), v, [](const ChangeCell& a, const std::array<std::int32_t, 3>& b) {
          return std::tie(a.x, a.y, a.z) < std::tie(b[0], b[1], b[2]);
        });
        if (c == e.cells.end() || c->x != v[0] || c->y != v[1] || c->z != v[2] || c->added == 0)
          throw Error("change report: sample point (" + std::to_string(p[0]) + ", " + std::to_string(p[1]) + ", " + std::to_string(p[2]) +
                      ") cm is not in a voxel of its tile with added > 0");
        e.points.push_back(p);
      }
    }
    r.tiles.push_back(std::move(e));
  }
  return r;
}

std::vector<ChangeReport> read_change_reports(const std::vector<std::string>& paths) {
  std::vector<ChangeReport> reports;
  for (const std::string& path : paths) {
    std::ifstream f(path, std::ios::binary);
    if (!f) throw Error(path + ": cannot read the change report");
    std::ostringstream text;
    text << f.rdbuf();
    try {
      reports.push_back(parse_change_report(text.str()));
    } catch (const Error& e) {
      throw Error(path + ": " + e.what());
    }
  }
  return reports;
}

}  // namespace pl::schema
