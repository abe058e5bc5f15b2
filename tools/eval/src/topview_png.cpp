// The PNG top view: the cells and trajectories of the SVG as pixels, without text (the legend goes
// into the Description chunk); optionally cropped, and with a second cloud's cells in red.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>

#include "pl/common/error.hpp"
#include "pl/common/svg.hpp"
#include "png_image.hpp"
#include "topview_cells.hpp"

namespace pl::eval {

namespace {

// The palette: white background, the SVG's grey shades, then the highlight, the starts and the tracks.
constexpr std::uint8_t kWhite = 0, kFirstGrey = 1;
constexpr std::uint8_t kHighlight = kFirstGrey + SvgPlot::kCellShades, kBlack = kHighlight + 1, kFirstTrack = kBlack + 1;
constexpr int kMarginCells = 2;       // around everything drawn, when no bounds are given
constexpr int kLinePixels = 3;        // a trajectory's width
constexpr double kStartRadius = 4.5;  // pixels

Rgb hex_color(const char* hex) {
  unsigned r = 0, g = 0, b = 0;
  std::sscanf(hex, "#%02x%02x%02x", &r, &g, &b);
  return Rgb{static_cast<std::uint8_t>(r), static_cast<std::uint8_t>(g), static_cast<std::uint8_t>(b)};
}

// As the SVG's cells (common/src/svg.cpp): light grey #e4e4e4 at level 0 to #2a2a2a at the last.
std::uint8_t grey_index(double shade) {
  const int levels = SvgPlot::kCellShades;
  const int level = !(shade > 0.0) ? 0 : shade >= 1.0 ? levels - 1 : std::min(levels - 1, static_cast<int>(shade * levels));
  return static_cast<std::uint8_t>(kFirstGrey + level);
}

std::vector<Rgb> palette() {
  std::vector<Rgb> p{Rgb{255, 255, 255}};
  for (int l = 0; l < SvgPlot::kCellShades; ++l) {
    const auto v = static_cast<std::uint8_t>(0xe4 - (0xe4 - 0x2a) * l / (SvgPlot::kCellShades - 1));
    p.push_back(Rgb{v, v, v});
  }
  p.push_back(hex_color(kTrackColors[0].hex));  // the highlight: red
  p.push_back(Rgb{0, 0, 0});
  for (const TrackColor& c : kTrackColors) p.push_back(hex_color(c.hex));
  return p;
}

// The grid of cells the image shows, [x0, x1] x [y0, y1] in cell indices.
struct Grid {
  double cell = 0.0;
  std::int64_t x0 = 0, y0 = 0, x1 = -1, y1 = -1;
  std::int64_t nx() const { return x1 - x0 + 1; }
  std::int64_t ny() const { return y1 - y0 + 1; }
  bool holds(const VoxelIndex& k) const { return k[0] >= x0 && k[0] <= x1 && k[1] >= y0 && k[1] <= y1; }
};

// The box of everything drawn, metres.
TopviewBounds extent_of(const Points3d& cloud, const Points3d& highlight, const std::vector<TopviewTrack>& tracks) {
  double x_min = INFINITY, y_min = INFINITY, x_max = -INFINITY, y_max = -INFINITY;
  auto add = [&](double x, double y) {
    if (!std::isfinite(x) || !std::isfinite(y)) return;
    x_min = std::min(x_min, x);
    y_min = std::min(y_min, y);
    x_max = std::max(x_max, x);
    y_max = std::max(y_max, y);
  };
  for (const Points3d* points : {&cloud, &highlight})
    for (const auto& p : *points)
      if (std::isfinite(p.z())) add(p.x(), p.y());
  for (const auto& t : tracks)
    for (const auto& p : t.trajectory.poses) add(p.translation().x(), p.translation().y());
  if (!(x_max >= x_min)) throw Error("nothing to draw: no finite positions in the clouds or the trajectories");
  return TopviewBounds{x_min, y_min, x_max, y_max};
}

// Cells of side `cell` over the bounds (exactly those they touch) or over the extent with a margin.
Grid grid_over(const TopviewBounds& box, bool exact, double cell) {
  Grid g;
  g.cell = cell;
  const std::int64_t margin = exact ? 0 : kMarginCells;
  const auto first = [cell](double v) { return static_cast<std::int64_t>(std::floor(v / cell)); };
  // The last cell: the one holding a point at v, or for bounds the last one a box ending at v enters.
  const auto last = [cell, exact](double v) {
    return static_cast<std::int64_t>(exact ? std::ceil(v / cell) - 1 : std::floor(v / cell));
  };
  g.x0 = first(box.x_min) - margin;
  g.y0 = first(box.y_min) - margin;
  g.x1 = last(box.x_max) + margin;
  g.y1 = last(box.y_max) + margin;
  g.x1 = std::max(g.x1, g.x0);
  g.y1 = std::max(g.y1, g.y0);
  return g;
}

std::string format(const char* f, double a) {
  char buf[64];
  std::snprintf(buf, sizeof buf, f, a);
  return buf;
}

}  // namespace

TopviewResult write_topview_png(const Points3d& cloud, const std::vector<TopviewTrack>& tracks, const TopviewOptions& options,
                                const std::string& out, const Points3d& highlight) {
  const bool exact = options.bounds.has_value();
  const TopviewBounds box = exact ? *options.bounds : extent_of(cloud, highlight, tracks);
  // The cell side: as asked, enlarged (to whole centimetres) until one pixel a cell fits the image.
  double cell = options.cell;
  for (;;) {
    const double cells_across = std::max(std::floor(box.x_max / cell) - std::floor(box.x_min / cell),
                                         std::floor(box.y_max / cell) - std::floor(box.y_min / cell)) +
                                1 + 2 * kMarginCells;
    if (cells_across <= kTopviewMaxPixels) break;
    cell = std::max(cell + 0.01, std::ceil(cell * cells_across / kTopviewMaxPixels * 100.0) / 100.0);
    if (!(cell < 1e9)) throw Error("nothing to draw at a sane scale: the points and trajectories span more than 1e12 m");
  }
  const Grid grid = grid_over(box, exact, cell);
  const int ppc =
      static_cast<int>(std::clamp<std::int64_t>(kTopviewMaxPixels / std::max(grid.nx(), grid.ny()), 1, kTopviewMaxPixelsPerCell));

  TopviewResult r;
  r.png = true;
  r.cell = cell;
  r.pixels_per_cell = ppc;
  r.width = static_cast<int>(grid.nx()) * ppc;
  r.height = static_cast<int>(grid.ny()) * ppc;
  r.extent = TopviewBounds{static_cast<double>(grid.x0) * cell, static_cast<double>(grid.y0) * cell,
                           static_cast<double>(grid.x1 + 1) * cell, static_cast<double>(grid.y1 + 1) * cell};

  std::vector<VoxelIndex> keys;
  std::vector<double> values;
  for (const auto& [k, c] : bin_cells(cloud, cell))
    if (grid.holds(k)) {
      keys.push_back(k);
      values.push_back(cell_value(c, options.shade));
      r.points += c.count;
    }
  r.cells = keys.size();
  const CellShading shading = shade_cells(values, options.shade, cell);
  r.shade_lo = shading.lo;
  r.shade_hi = shading.hi;

  PaletteImage image(r.width, r.height, palette(), kWhite);
  auto fill_cell = [&](const VoxelIndex& k, std::uint8_t colour) {
    const int px = static_cast<int>(k[0] - grid.x0) * ppc, py = static_cast<int>(grid.y1 - k[1]) * ppc;
    image.fill_rect(px, py, px + ppc, py + ppc, colour);
  };
  for (std::size_t i = 0; i < keys.size(); ++i) fill_cell(keys[i], grey_index(shading.shade[i]));
  for (const auto& [k, c] : bin_cells(highlight, cell))
    if (grid.holds(k)) {
      fill_cell(k, kHighlight);
      ++r.highlight_cells;
      r.highlight_points += c.count;
    }

  // Tracks: red is the highlight's when there is one, so they take the other colours then.
  const auto to_px = [&](double x) { return (x / cell - static_cast<double>(grid.x0)) * ppc; };
  const auto to_py = [&](double y) { return (static_cast<double>(grid.y1 + 1) - y / cell) * ppc; };
  const std::size_t first_colour = highlight.empty() ? 0 : 1, colours = std::size(kTrackColors) - first_colour;
  std::string lines;
  for (std::size_t k = 0; k < tracks.size(); ++k) {
    const std::size_t colour = first_colour + k % colours;
    const auto& poses = tracks[k].trajectory.poses;
    for (std::size_t i = 1; i < poses.size(); ++i)
      image.line(to_px(poses[i - 1].translation().x()), to_py(poses[i - 1].translation().y()), to_px(poses[i].translation().x()),
                 to_py(poses[i].translation().y()), kLinePixels, static_cast<std::uint8_t>(kFirstTrack + colour));
    if (poses.size() == 1)
      image.disc(to_px(poses[0].translation().x()), to_py(poses[0].translation().y()), 1.5,
                 static_cast<std::uint8_t>(kFirstTrack + colour));
    lines += std::string(lines.empty() ? "" : ", ") + kTrackColors[colour].name + " " + tracks[k].label;
  }
  for (const auto& t : tracks)
    if (!t.trajectory.poses.empty())
      image.disc(to_px(t.trajectory.poses.front().translation().x()), to_py(t.trajectory.poses.front().translation().y()),
                 kStartRadius, kBlack);

  std::string legend = "x east to the right, y north up; " + std::to_string(ppc) + " px a cell of " + format("%.2f", cell) +
                       " m; x " + format("%.2f", r.extent.x_min) + " to " + format("%.2f", r.extent.x_max) + " m, y " +
                       format("%.2f", r.extent.y_min) + " to " + format("%.2f", r.extent.y_max) + " m.";
  if (!shading.key.empty()) legend += " Grey: " + shading.key + ".";
  if (!highlight.empty())
    legend +=
        " Red: " + std::to_string(r.highlight_points) + " highlighted points in " + std::to_string(r.highlight_cells) + " cells.";
  if (!lines.empty()) legend += " Lines: " + lines + "; black dots: their starts.";
  r.legend = legend;
  write_png(
      out, image,
      {{"Title", options.title.empty() ? "Top view" : options.title}, {"Description", legend}, {"Software", "pl-eval topview"}});
  std::error_code ec;
  r.bytes = static_cast<std::size_t>(std::filesystem::file_size(out, ec));
  return r;
}

}  // namespace pl::eval
