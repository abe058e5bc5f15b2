// What the SVG and PNG top views share: the cloud binned into xy cells, their grey shades, the
// trajectories' colours.
#pragma once

#include <cstddef>
#include <string>
#include <unordered_map>
#include <vector>

#include "pl/eval/topview.hpp"

namespace pl::eval {

struct CellStats {
  std::size_t count = 0;
  double z_max = 0.0;
};

using CellMap = std::unordered_map<VoxelIndex, CellStats, VoxelIndexHash>;

// Finite points binned into cells of side `cell` (index z is 0).
CellMap bin_cells(const Points3d& points, double cell);

// Shades in [0, 1] for the cells' values (points per cell or highest point), and the legend's words.
struct CellShading {
  std::vector<double> shade;  // one per value, in order
  double lo = 0.0, hi = 0.0;  // the values mapped to lightest and darkest
  std::string key;            // e.g. "map, 0.20 m cells: darker = more points (1 to 12+, log)"
};
CellShading shade_cells(const std::vector<double>& values, TopviewShade shade, double cell);

// The value shaded for one cell.
inline double cell_value(const CellStats& c, TopviewShade shade) {
  return shade == TopviewShade::Count ? static_cast<double>(c.count) : c.z_max;
}

struct TrackColor {
  const char* hex;   // "#d62728"
  const char* name;  // "red"
};
extern const TrackColor kTrackColors[8];

TopviewResult write_topview_svg(const Points3d& cloud, const std::vector<TopviewTrack>& tracks, const TopviewOptions& options,
                                const std::string& out);
TopviewResult write_topview_png(const Points3d& cloud, const std::vector<TopviewTrack>& tracks, const TopviewOptions& options,
                                const std::string& out, const Points3d& highlight);

}  // namespace pl::eval
