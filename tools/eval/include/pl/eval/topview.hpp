// A top view of a map cloud and trajectories (pl-eval topview), x east (right), y north (up), equal
// aspect, as an SVG or a PNG by the output's extension:
// - SVG: the cloud as a raster of occupied grid cells shaded grey, the trajectories as coloured
//   polylines with a title, axes, a legend and their starts marked.
// - PNG: the same cells and trajectories without text (no font is drawn: the title and the legend go
//   into the file's Title and Description text chunks). Each cell is a square of whole pixels, the
//   most (up to 8) that keep the image within 1600 px on its longer side; where even one pixel a cell
//   would not fit, the cell grows instead. A PNG may be cropped to bounds and may show a second cloud's
//   cells in red over the map (e.g. the points a filter removed).
#pragma once

#include <cstddef>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "pl/common/pose.hpp"
#include "pl/common/voxel.hpp"

namespace pl::eval {

enum class TopviewShade { Count, Height };

// A box in the xy plane, metres; x_min < x_max and y_min < y_max.
struct TopviewBounds {
  double x_min = 0.0, y_min = 0.0, x_max = 0.0, y_max = 0.0;
};

struct TopviewOptions {
  double cell = 1.0;               // metres, the requested cell side
  std::size_t max_cells = 60000;   // SVG: the cell side grows until at most this many cells are occupied
  TopviewShade shade = TopviewShade::Count;
  std::string title;               // default: "Top view"
  std::optional<TopviewBounds> bounds;  // PNG only: draw this box alone (default: everything, with a margin)
};

// The most pixels a PNG top view has on its longer side, and the most pixels a cell gets.
inline constexpr int kTopviewMaxPixels = 1600;
inline constexpr int kTopviewMaxPixelsPerCell = 8;

struct TopviewTrack {
  std::string label;
  Trajectory trajectory;  // positions are drawn; rotations are ignored
};

struct TopviewResult {
  std::size_t points = 0;   // cloud points drawn
  double cell = 0.0;        // metres, the cell side used (>= the requested one)
  std::size_t cells = 0;    // occupied cells drawn
  double shade_lo = 0.0, shade_hi = 0.0;  // points per cell or metres mapped to lightest..darkest
  std::size_t bytes = 0;    // size of the file written
  bool png = false;         // written as a PNG (else an SVG)
  int width = 0, height = 0;  // PNG: pixels
  int pixels_per_cell = 0;    // PNG: the side of a cell in pixels
  TopviewBounds extent;       // PNG: the box the image shows, metres
  std::size_t highlight_points = 0, highlight_cells = 0;  // PNG: the second cloud's points and cells drawn
  std::string legend;         // PNG: the legend, as written into its Description chunk
};

// Parses "FILE" or "FILE:LABEL" (the label defaults to the file name without its folder and
// extension; a path that exists as a file is never split). Throws pl::Error for an empty label.
std::pair<std::string, std::string> parse_track_argument(const std::string& argument);

// Parses "XMIN,YMIN,XMAX,YMAX" (metres). Throws pl::Error unless these are four finite numbers with
// XMIN < XMAX and YMIN < YMAX.
TopviewBounds parse_bounds(const std::string& text);

// Occupied cells of side `cell` in the xy plane.
std::size_t count_occupied_cells(const Points3d& points, double cell);

// The points of `before` whose coordinates are not exactly those of any point of `after`: what a
// filter that keeps the survivors' coordinates (pl-map build --moving remove) took out.
Points3d points_missing_from(const Points3d& before, const Points3d& after);

// Writes the top view to `out`: a PNG when it ends in .png, an SVG when it ends in .svg; `highlight`'s
// cells are drawn in red over the cloud's. Throws pl::Error when there is nothing to draw, the cell is
// not positive, the name ends otherwise, bounds or highlight points are given for an SVG, or the file
// cannot be written.
TopviewResult write_topview(const Points3d& cloud, const std::vector<TopviewTrack>& tracks,
                            const TopviewOptions& options, const std::string& out, const Points3d& highlight = {});

}  // namespace pl::eval
