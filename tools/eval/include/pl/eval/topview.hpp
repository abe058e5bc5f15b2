// A top view of a map cloud and trajectories as an SVG (pl-eval topview): the cloud as a raster of
// occupied grid cells shaded grey, the trajectories as coloured polylines with a legend and their
// starts marked. x east (right), y north (up), equal aspect.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "pl/common/pose.hpp"
#include "pl/common/voxel.hpp"

namespace pl::eval {

enum class TopviewShade { Count, Height };

struct TopviewOptions {
  double cell = 1.0;               // metres, the requested cell side
  std::size_t max_cells = 60000;   // the cell side grows until at most this many cells are occupied
  TopviewShade shade = TopviewShade::Count;
  std::string title;               // default: "Top view"
};

struct TopviewTrack {
  std::string label;
  Trajectory trajectory;  // positions are drawn; rotations are ignored
};

struct TopviewResult {
  std::size_t points = 0;   // cloud points drawn
  double cell = 0.0;        // metres, the cell side used (>= the requested one)
  std::size_t cells = 0;    // occupied cells drawn
  double shade_lo = 0.0, shade_hi = 0.0;  // points per cell or metres mapped to lightest..darkest
  std::size_t bytes = 0;    // size of the SVG written
};

// Parses "FILE" or "FILE:LABEL" (the label defaults to the file name without its folder and
// extension; a path that exists as a file is never split). Throws pl::Error for an empty label.
std::pair<std::string, std::string> parse_track_argument(const std::string& argument);

// Occupied cells of side `cell` in the xy plane.
std::size_t count_occupied_cells(const Points3d& points, double cell);

// Writes the SVG to `out`. Throws pl::Error when there is nothing to draw, the cell is not positive,
// or the file cannot be written.
TopviewResult write_topview(const Points3d& cloud, const std::vector<TopviewTrack>& tracks,
                            const TopviewOptions& options, const std::string& out);

}  // namespace pl::eval
