// The SVG top view: occupied cells as a grey raster of runs, trajectories as polylines, a legend.
#include <algorithm>
#include <cmath>
#include <filesystem>

#include "pl/common/error.hpp"
#include "pl/common/svg.hpp"
#include "topview_cells.hpp"

namespace pl::eval {

TopviewResult write_topview_svg(const Points3d& cloud, const std::vector<TopviewTrack>& tracks,
                                const TopviewOptions& options, const std::string& out) {
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

  std::vector<double> cx, cy, values;
  cx.reserve(cells.size());
  cy.reserve(cells.size());
  values.reserve(cells.size());
  for (const auto& [k, c] : cells) {
    cx.push_back(static_cast<double>(k[0]) * cell);
    cy.push_back(static_cast<double>(k[1]) * cell);
    values.push_back(cell_value(c, options.shade));
  }
  const CellShading shading = shade_cells(values, options.shade, cell);
  r.shade_lo = shading.lo;
  r.shade_hi = shading.hi;

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
  if (!cx.empty()) plot.add_cells(shading.key, cell, cx, cy, shading.shade);

  std::vector<double> start_x, start_y;
  for (std::size_t k = 0; k < tracks.size(); ++k) {
    std::vector<double> x, y;
    for (const auto& p : tracks[k].trajectory.poses) {
      x.push_back(p.translation().x());
      y.push_back(p.translation().y());
    }
    if (x.empty()) continue;
    plot.add_line(tracks[k].label, x, y, kTrackColors[k % std::size(kTrackColors)].hex, 2.0);
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
