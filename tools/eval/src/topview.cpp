#include "pl/eval/topview.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <unordered_map>

#include "pl/common/error.hpp"
#include "pl/common/stats.hpp"
#include "pl/common/svg.hpp"

namespace pl::eval {

namespace {

const char* const kTrackColors[] = {"#d62728", "#1f77b4", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2", "#17becf"};

struct CellStats {
  std::size_t count = 0;
  double z_max = -INFINITY;
};

using CellMap = std::unordered_map<VoxelIndex, CellStats, VoxelIndexHash>;

CellMap bin_cells(const Points3d& points, double cell) {
  CellMap cells;
  const double inv = 1.0 / cell;
  for (const auto& p : points) {
    if (!p.allFinite()) continue;
    VoxelIndex k = voxel_index(p, inv);
    k[2] = 0;
    CellStats& c = cells[k];
    ++c.count;
    c.z_max = std::max(c.z_max, p.z());
  }
  return cells;
}

std::string metres(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, v < 10 ? "%.2f" : "%.1f", v);
  return buf;
}

}  // namespace

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

std::size_t count_occupied_cells(const Points3d& points, double cell) {
  if (!(cell > 0.0)) throw Error("--cell takes a size in metres above 0");
  return bin_cells(points, cell).size();
}

TopviewResult write_topview(const Points3d& cloud, const std::vector<TopviewTrack>& tracks,
                            const TopviewOptions& options, const std::string& out) {
  if (!(options.cell > 0.0) || !std::isfinite(options.cell)) throw Error("--cell takes a size in metres above 0");
  if (options.max_cells == 0) throw Error("the cell limit must be at least 1");
  if (cloud.empty() && tracks.empty()) throw Error("nothing to draw: the cloud is empty and no --traj was given");

  TopviewResult r;
  r.points = cloud.size();
  // The cell side: as asked, enlarged (to whole centimetres) until few enough cells are occupied.
  double cell = options.cell;
  CellMap cells = bin_cells(cloud, cell);
  while (cells.size() > options.max_cells) {
    const double grow = std::max(1.05, std::sqrt(static_cast<double>(cells.size()) / static_cast<double>(options.max_cells)));
    cell = std::ceil(cell * grow * 100.0) / 100.0;
    cells = bin_cells(cloud, cell);
  }
  r.cell = cell;
  r.cells = cells.size();

  std::vector<double> cx, cy, shade, values;
  cx.reserve(cells.size());
  cy.reserve(cells.size());
  values.reserve(cells.size());
  for (const auto& [k, c] : cells) {
    cx.push_back(static_cast<double>(k[0]) * cell);
    cy.push_back(static_cast<double>(k[1]) * cell);
    values.push_back(options.shade == TopviewShade::Count ? static_cast<double>(c.count) : c.z_max);
  }
  std::string key;
  if (!values.empty()) {
    if (options.shade == TopviewShade::Count) {
      // Log scale from one point to the 95th percentile of points per cell.
      r.shade_lo = 1.0;
      r.shade_hi = std::max(1.0, percentile(values, 95));
      const double span = std::log(r.shade_hi);
      for (double v : values) shade.push_back(span > 0.0 ? std::log(v) / span : 0.5);
      key = "map, " + metres(cell) + " m cells: darker = more points (1 to " +
            std::to_string(static_cast<long long>(r.shade_hi)) + "+, log)";
    } else {
      // Linear in the highest point of each cell, between its 2nd and 98th percentiles.
      r.shade_lo = percentile(values, 2);
      r.shade_hi = percentile(values, 98);
      const double span = r.shade_hi - r.shade_lo;
      for (double v : values) shade.push_back(span > 0.0 ? (v - r.shade_lo) / span : 0.5);
      key = "map, " + metres(cell) + " m cells: darker = higher (z " + metres(r.shade_lo) + " to " +
            metres(r.shade_hi) + " m)";
    }
  }

  // Extent of everything drawn, for the picture's proportions.
  Eigen::Vector2d lo(INFINITY, INFINITY), hi(-INFINITY, -INFINITY);
  for (std::size_t i = 0; i < cx.size(); ++i) {
    lo = lo.cwiseMin(Eigen::Vector2d(cx[i], cy[i]));
    hi = hi.cwiseMax(Eigen::Vector2d(cx[i] + cell, cy[i] + cell));
  }
  for (const auto& t : tracks)
    for (const auto& p : t.trajectory.poses)
      if (p.translation().allFinite()) {
        lo = lo.cwiseMin(p.translation().head<2>());
        hi = hi.cwiseMax(p.translation().head<2>());
      }
  if (!(hi.x() >= lo.x())) throw Error("nothing to draw: no finite positions in the cloud or the trajectories");
  const double ex = std::max(hi.x() - lo.x(), 1e-3), ey = std::max(hi.y() - lo.y(), 1e-3);

  SvgPlot plot(options.title.empty() ? "Top view" : options.title, "x east [m]", "y north [m]");
  plot.set_equal_aspect(true);
  // SvgPlot's margins are 108 px across and 110 px down; the longer side of the plot gets 900 px.
  const double plot_w = ex >= ey ? 900.0 : std::max(300.0, 900.0 * ex / ey);
  const double plot_h = ex >= ey ? std::max(300.0, 900.0 * ey / ex) : 900.0;
  plot.set_size(static_cast<int>(plot_w + 108.0), static_cast<int>(plot_h + 110.0));
  if (!cx.empty()) plot.add_cells(key, cell, cx, cy, shade);

  std::vector<double> start_x, start_y;
  for (std::size_t k = 0; k < tracks.size(); ++k) {
    std::vector<double> x, y;
    for (const auto& p : tracks[k].trajectory.poses) {
      x.push_back(p.translation().x());
      y.push_back(p.translation().y());
    }
    if (x.empty()) continue;
    plot.add_line(tracks[k].label, x, y, kTrackColors[k % (sizeof kTrackColors / sizeof kTrackColors[0])], 2.0);
    start_x.push_back(x.front());
    start_y.push_back(y.front());
  }
  if (!start_x.empty()) plot.add_points("start", start_x, start_y, "#000000", 4.5);
  plot.save(out);
  std::error_code ec;
  r.bytes = static_cast<std::size_t>(std::filesystem::file_size(out, ec));
  return r;
}

}  // namespace pl::eval
