// pl-eval topview's shared parts: arguments, cells and their shades, and the choice of SVG
// (topview_svg.cpp) or PNG (topview_png.cpp) by the output's name.
#include "pl/eval/topview.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <unordered_set>
#include <vector>

#include "pl/common/error.hpp"
#include "pl/common/stats.hpp"
#include "topview_cells.hpp"

namespace pl::eval {

const TrackColor kTrackColors[8] = {{"#d62728", "red"},    {"#1f77b4", "blue"},  {"#2ca02c", "green"},
                                    {"#ff7f0e", "orange"}, {"#9467bd", "purple"}, {"#8c564b", "brown"},
                                    {"#e377c2", "pink"},   {"#17becf", "cyan"}};

namespace {

std::string metres(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, std::fabs(v) < 10 ? "%.2f" : "%.1f", v);
  return buf;
}

std::string extension_of(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext;
}

// A point's coordinates as a key for exact comparison (+0 and -0 alike).
struct PointKey {
  double x, y, z;
  bool operator==(const PointKey& o) const { return x == o.x && y == o.y && z == o.z; }
};
struct PointKeyHash {
  std::size_t operator()(const PointKey& k) const {
    std::size_t h = 0;
    for (double v : {k.x, k.y, k.z}) {
      if (v == 0.0) v = 0.0;
      std::uint64_t bits;
      std::memcpy(&bits, &v, sizeof bits);
      h = (h ^ std::hash<std::uint64_t>()(bits)) * 0x100000001b3ull;
    }
    return h;
  }
};

}  // namespace

CellMap bin_cells(const Points3d& points, double cell) {
  CellMap cells;
  const double inv = 1.0 / cell;
  for (const auto& p : points) {
    if (!p.allFinite()) continue;
    VoxelIndex k = voxel_index(p, inv);
    k[2] = 0;
    auto [it, fresh] = cells.try_emplace(k);
    CellStats& c = it->second;
    c.z_max = fresh ? p.z() : std::max(c.z_max, p.z());
    ++c.count;
  }
  return cells;
}

CellShading shade_cells(const std::vector<double>& values, TopviewShade shade, double cell) {
  CellShading s;
  if (values.empty()) return s;
  s.shade.reserve(values.size());
  if (shade == TopviewShade::Count) {
    // Log scale from one point to the 95th percentile of points per cell.
    s.lo = 1.0;
    s.hi = std::max(1.0, percentile(values, 95));
    const double span = std::log(s.hi);
    for (double v : values) s.shade.push_back(span > 0.0 ? std::log(v) / span : 0.5);
    s.key = "map, " + metres(cell) + " m cells: darker = more points (1 to " + std::to_string(static_cast<long long>(s.hi)) +
            "+, log)";
  } else {
    // Linear in the highest point of each cell, between its 2nd and 98th percentiles.
    s.lo = percentile(values, 2);
    s.hi = percentile(values, 98);
    const double span = s.hi - s.lo;
    for (double v : values) s.shade.push_back(span > 0.0 ? (v - s.lo) / span : 0.5);
    s.key = "map, " + metres(cell) + " m cells: darker = higher (z " + metres(s.lo) + " to " + metres(s.hi) + " m)";
  }
  return s;
}

std::pair<std::string, std::string> parse_track_argument(const std::string& argument) {
  namespace fs = std::filesystem;
  std::string path = argument, label;
  // FILE:LABEL splits at the first ':' (a label may hold colons); a file whose name holds one is
  // taken whole when it exists.
  const auto colon = argument.find(':');
  std::error_code ec;
  if (!fs::is_regular_file(argument, ec) && colon != std::string::npos) {
    path = argument.substr(0, colon);
    label = argument.substr(colon + 1);
    if (path.empty()) throw Error("--traj \"" + argument + "\": no file before the ':' (--traj FILE[:LABEL])");
    if (label.empty()) throw Error("--traj \"" + argument + "\": empty label after the ':' (--traj FILE[:LABEL])");
  }
  if (label.empty()) label = fs::path(path).stem().string();
  return {path, label};
}

TopviewBounds parse_bounds(const std::string& text) {
  const std::string usage = "--bounds \"" + text + "\": ";
  std::vector<std::string> fields(1);
  for (char c : text) {
    if (c == ',') fields.emplace_back();
    else fields.back() += c;
  }
  if (fields.size() != 4) throw Error(usage + "expected four numbers XMIN,YMIN,XMAX,YMAX (metres), separated by commas");
  const char* const names[4] = {"XMIN", "YMIN", "XMAX", "YMAX"};
  double v[4];
  for (int k = 0; k < 4; ++k) {
    const std::string& field = fields[static_cast<std::size_t>(k)];
    char* end = nullptr;
    v[k] = std::strtod(field.c_str(), &end);
    if (field.empty() || end == field.c_str() || *end != '\0' || !std::isfinite(v[k]))
      throw Error(usage + names[k] + " \"" + field + "\" is not a finite number (XMIN,YMIN,XMAX,YMAX in metres)");
  }
  if (!(v[0] < v[2])) throw Error(usage + "XMIN must be below XMAX");
  if (!(v[1] < v[3])) throw Error(usage + "YMIN must be below YMAX");
  return TopviewBounds{v[0], v[1], v[2], v[3]};
}

std::size_t count_occupied_cells(const Points3d& points, double cell) {
  if (!(cell > 0.0)) throw Error("--cell takes a size in metres above 0");
  return bin_cells(points, cell).size();
}

Points3d points_missing_from(const Points3d& before, const Points3d& after) {
  std::unordered_set<PointKey, PointKeyHash> kept;
  kept.reserve(after.size());
  for (const auto& p : after) kept.insert(PointKey{p.x(), p.y(), p.z()});
  Points3d missing;
  for (const auto& p : before)
    if (!kept.count(PointKey{p.x(), p.y(), p.z()})) missing.push_back(p);
  return missing;
}

TopviewResult write_topview(const Points3d& cloud, const std::vector<TopviewTrack>& tracks, const TopviewOptions& options,
                            const std::string& out, const Points3d& highlight) {
  if (!(options.cell > 0.0) || !std::isfinite(options.cell)) throw Error("--cell takes a size in metres above 0");
  if (options.max_cells == 0) throw Error("the cell limit must be at least 1");
  if (cloud.empty() && tracks.empty() && highlight.empty())
    throw Error("nothing to draw: the cloud is empty and no --traj was given");
  const std::string ext = extension_of(out);
  if (ext == ".png") return write_topview_png(cloud, tracks, options, out, highlight);
  if (ext != ".svg") throw Error(out + ": a top view is written as an SVG or a PNG: name it FILE.svg or FILE.png");
  if (options.bounds || !highlight.empty())
    throw Error(out + ": bounds and highlighted points are drawn in a PNG only: name it FILE.png");
  return write_topview_svg(cloud, tracks, options, out);
}

}  // namespace pl::eval
