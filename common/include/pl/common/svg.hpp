// A small SVG plot writer: one x-y panel with axes, tick labels, axis titles, a title and a legend;
// series are polylines, point markers, horizontal/vertical reference lines, histogram bars, filled
// polygons and shaded grid cells (a raster, e.g. a map's occupied cells in a top view).
#pragma once

#include <string>
#include <vector>

namespace pl {

// "Nice" tick positions (steps of 1, 2 or 5 times a power of ten) covering [lo, hi], about
// `target` of them.
std::vector<double> nice_ticks(double lo, double hi, int target = 6);

// Escapes &, <, >, " and ' for SVG text and attributes.
std::string xml_escape(const std::string& text);

class SvgPlot {
 public:
  SvgPlot(std::string title, std::string x_label, std::string y_label);

  // Same metres per pixel on both axes (top views).
  void set_equal_aspect(bool on) { equal_aspect_ = on; }
  // Forces y to include 0 (counts, errors).
  void set_y_from_zero(bool on) { y_from_zero_ = on; }
  void set_size(int width, int height) { width_ = width; height_ = height; }

  void add_line(const std::string& label, const std::vector<double>& x, const std::vector<double>& y,
                const std::string& color, double stroke_width = 1.5, bool dashed = false);
  void add_points(const std::string& label, const std::vector<double>& x, const std::vector<double>& y,
                  const std::string& color, double radius = 3.0);
  void add_hline(const std::string& label, double y, const std::string& color, bool dashed = true);
  void add_vline(const std::string& label, double x, const std::string& color, bool dashed = true);
  // Bars from edges[i] to edges[i+1] with heights[i]; edges.size() == heights.size() + 1.
  void add_bars(const std::string& label, const std::vector<double>& edges, const std::vector<double>& heights,
                const std::string& color);

  // Filled polygons (e.g. footprints in a top view): vertex lists separated by a NaN in x and y.
  void add_polygons(const std::string& label, const std::vector<double>& x, const std::vector<double>& y,
                    const std::string& color, double opacity = 0.85);

  // Square cells of side `size` with lower-left corners (x[i], y[i]) on one grid (corners differ by
  // whole multiples of size), shaded grey by shade[i] in [0, 1] (0 light, 1 dark; clamped) in
  // kCellShades steps. Drawn compactly: one path per shade, a rectangle per run of horizontally
  // adjacent cells of that shade; size must be > 0.
  void add_cells(const std::string& label, double size, const std::vector<double>& x, const std::vector<double>& y,
                 const std::vector<double>& shade);
  static constexpr int kCellShades = 16;
  // The grey a cell of this shade is drawn in ("#rrggbb"), e.g. for a colour key.
  static std::string cell_color(double shade);

  std::string to_string() const;
  // Throws pl::Error when the file cannot be written.
  void save(const std::string& path) const;

 public:
  enum class Kind { Line, Points, HLine, VLine, Bars, Polygons, Cells };
  struct Series {
    Kind kind;
    std::string label;
    std::vector<double> x, y;  // bars: x = edges, y = heights; cells: lower-left corners
    std::string color;
    double size;               // stroke width, marker radius, opacity, or the cells' side
    bool dashed;
    std::vector<double> value;  // cells: the shade of each
  };

 private:

  std::string title_, x_label_, y_label_;
  bool equal_aspect_ = false;
  bool y_from_zero_ = false;
  int width_ = 800;
  int height_ = 560;
  std::vector<Series> series_;
};

}  // namespace pl
