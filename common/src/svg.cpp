#include "pl/common/svg.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>

#include "pl/common/error.hpp"

namespace pl {

namespace {

struct Range {
  double lo = std::numeric_limits<double>::infinity();
  double hi = -std::numeric_limits<double>::infinity();
  void add(double v) {
    if (!std::isfinite(v)) return;
    lo = std::min(lo, v);
    hi = std::max(hi, v);
  }
  bool empty() const { return !(lo <= hi); }
  double span() const { return hi - lo; }
};

double nice_step(double span, int target) {
  if (!(span > 0.0) || !std::isfinite(span)) return 1.0;
  const double raw = span / std::max(1, target);
  const double mag = std::pow(10.0, std::floor(std::log10(raw)));
  const double f = raw / mag;
  const double nice = f < 1.5 ? 1.0 : f < 3.0 ? 2.0 : f < 7.0 ? 5.0 : 10.0;
  return nice * mag;
}

// Gives an empty or zero-width range some width so that the axis can be drawn.
void widen(Range& r) {
  if (r.empty()) {
    r.lo = 0.0;
    r.hi = 1.0;
  } else if (!(r.span() > 0.0)) {
    const double pad = r.lo == 0.0 ? 1.0 : std::fabs(r.lo) * 0.05;
    r.lo -= pad;
    r.hi += pad;
  }
}

std::string fmt(const char* format, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, format, v);
  return buf;
}

std::string px(double v) { return fmt("%.2f", v); }

// Shade level of a value in [0, 1] (clamped; NaN is the lightest).
int cell_level(double shade) {
  if (!(shade > 0.0)) return 0;
  if (shade >= 1.0) return SvgPlot::kCellShades - 1;
  return std::min(SvgPlot::kCellShades - 1, static_cast<int>(shade * SvgPlot::kCellShades));
}

// Light grey (#e4e4e4) at level 0 to dark grey (#2a2a2a) at the last level.
std::string level_color(int level) {
  const int l = std::clamp(level, 0, SvgPlot::kCellShades - 1);
  const unsigned v = static_cast<unsigned>(0xe4 - (0xe4 - 0x2a) * l / (SvgPlot::kCellShades - 1)) & 0xffu;
  char buf[16];
  std::snprintf(buf, sizeof buf, "#%02x%02x%02x", v, v, v);
  return buf;
}

std::string tick_label(double v, double step) {
  if (std::fabs(v) < step * 1e-6) v = 0.0;  // no "-0" or 1e-17
  if (std::fabs(v) >= 1e7 || (step < 1e-6 && v != 0.0)) return fmt("%g", v);
  int decimals = std::max(0, static_cast<int>(-std::floor(std::log10(step) + 1e-9)));
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", std::min(decimals, 9), v);
  return buf;
}

}  // namespace

std::vector<double> nice_ticks(double lo, double hi, int target) {
  std::vector<double> ticks;
  if (!(hi >= lo) || !std::isfinite(lo) || !std::isfinite(hi)) return ticks;
  const double step = nice_step(hi - lo, target);
  const double eps = step * 1e-9;
  for (double k = std::ceil((lo - eps) / step); k * step <= hi + eps && ticks.size() < 1000; k += 1.0)
    ticks.push_back(k * step);
  return ticks;
}

std::string xml_escape(const std::string& text) {
  std::string out;
  for (char c : text) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      case '\'': out += "&apos;"; break;
      default: out += c;
    }
  }
  return out;
}

std::string SvgPlot::cell_color(double shade) { return level_color(cell_level(shade)); }

SvgPlot::SvgPlot(std::string title, std::string x_label, std::string y_label)
    : title_(std::move(title)), x_label_(std::move(x_label)), y_label_(std::move(y_label)) {}

void SvgPlot::add_line(const std::string& label, const std::vector<double>& x, const std::vector<double>& y,
                       const std::string& color, double stroke_width, bool dashed) {
  series_.push_back({Kind::Line, label, x, y, color, stroke_width, dashed, {}});
}

void SvgPlot::add_points(const std::string& label, const std::vector<double>& x, const std::vector<double>& y,
                         const std::string& color, double radius) {
  series_.push_back({Kind::Points, label, x, y, color, radius, false, {}});
}

void SvgPlot::add_hline(const std::string& label, double y, const std::string& color, bool dashed) {
  series_.push_back({Kind::HLine, label, {}, {y}, color, 1.5, dashed, {}});
}

void SvgPlot::add_vline(const std::string& label, double x, const std::string& color, bool dashed) {
  series_.push_back({Kind::VLine, label, {x}, {}, color, 1.5, dashed, {}});
}

void SvgPlot::add_bars(const std::string& label, const std::vector<double>& edges, const std::vector<double>& heights,
                       const std::string& color) {
  if (edges.size() != heights.size() + 1) throw Error("bar plot needs one more edge than bars");
  series_.push_back({Kind::Bars, label, edges, heights, color, 0.0, false, {}});
}

// The "x,y x,y ..." pixel lists of a series' runs of finite points (a NaN ends a run).
template <typename SX, typename SY>
static std::vector<std::string> point_runs(const SvgPlot::Series& s, SX&& sx, SY&& sy) {
  std::vector<std::string> runs(1);
  for (std::size_t i = 0; i < std::min(s.x.size(), s.y.size()); ++i) {
    if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i])) {
      if (!runs.back().empty()) runs.emplace_back();
      continue;
    }
    runs.back() += (runs.back().empty() ? "" : " ") + px(sx(s.x[i])) + "," + px(sy(s.y[i]));
  }
  if (runs.back().empty()) runs.pop_back();
  return runs;
}

// The cells of a series as one <path> per shade level; each run of horizontally adjacent cells of
// the same level is one rectangle, written with absolute H/V moves so that neighbouring runs share
// their rounded edges exactly.
template <typename SX, typename SY>
static std::string cells_svg(const SvgPlot::Series& s, SX&& sx, SY&& sy) {
  struct Cell {
    int level;
    long long row, col;
    bool operator<(const Cell& o) const {
      return level != o.level ? level < o.level : row != o.row ? row < o.row : col < o.col;
    }
  };
  double x_ref = std::numeric_limits<double>::infinity(), y_ref = x_ref;
  for (std::size_t i = 0; i < s.x.size(); ++i)
    if (std::isfinite(s.x[i]) && std::isfinite(s.y[i])) {
      x_ref = std::min(x_ref, s.x[i]);
      y_ref = std::min(y_ref, s.y[i]);
    }
  std::vector<Cell> cells;
  cells.reserve(s.x.size());
  for (std::size_t i = 0; i < s.x.size(); ++i)
    if (std::isfinite(s.x[i]) && std::isfinite(s.y[i]))
      cells.push_back({cell_level(s.value[i]), std::llround((s.y[i] - y_ref) / s.size),
                       std::llround((s.x[i] - x_ref) / s.size)});
  std::sort(cells.begin(), cells.end());
  auto f1 = [](double v) { return fmt("%.1f", v); };
  std::string o = "<g stroke=\"none\" shape-rendering=\"crispEdges\">\n";
  for (std::size_t i = 0; i < cells.size();) {
    const int level = cells[i].level;
    std::string d;
    while (i < cells.size() && cells[i].level == level) {
      std::size_t j = i;
      while (j + 1 < cells.size() && cells[j + 1].level == level && cells[j + 1].row == cells[i].row &&
             cells[j + 1].col == cells[j].col + 1)
        ++j;
      const double x0 = sx(x_ref + static_cast<double>(cells[i].col) * s.size);
      const double x1 = sx(x_ref + static_cast<double>(cells[j].col + 1) * s.size);
      const double y0 = sy(y_ref + static_cast<double>(cells[i].row + 1) * s.size);  // top edge in pixels
      const double y1 = sy(y_ref + static_cast<double>(cells[i].row) * s.size);
      d += "M" + f1(x0) + " " + f1(y0) + "H" + f1(x1) + "V" + f1(y1) + "H" + f1(x0) + "z";
      i = j + 1;
    }
    o += "<path fill=\"" + level_color(level) + "\" d=\"" + d + "\"/>\n";
  }
  return o + "</g>\n";
}

void SvgPlot::add_polygons(const std::string& label, const std::vector<double>& x, const std::vector<double>& y,
                           const std::string& color, double opacity) {
  series_.push_back({Kind::Polygons, label, x, y, color, opacity, false, {}});
}

void SvgPlot::add_cells(const std::string& label, double size, const std::vector<double>& x,
                        const std::vector<double>& y, const std::vector<double>& shade) {
  if (!(size > 0.0) || !std::isfinite(size)) throw Error("grid cells need a positive size");
  if (x.size() != y.size() || x.size() != shade.size()) throw Error("grid cells need as many x, y and shade values");
  series_.push_back({Kind::Cells, label, x, y, cell_color(0.5), size, false, shade});
}

std::string SvgPlot::to_string() const {
  const double left = 84, right = 24, top = 48, bottom = 62;
  const double pw = std::max(10.0, width_ - left - right);
  const double ph = std::max(10.0, height_ - top - bottom);

  Range xr, yr;
  for (const auto& s : series_) {
    if (s.kind != Kind::HLine)
      for (double v : s.x) xr.add(v);
    for (double v : s.y) yr.add(v);
    if (s.kind == Kind::Bars) yr.add(0.0);
    if (s.kind == Kind::Cells) {
      for (double v : s.x) xr.add(v + s.size);
      for (double v : s.y) yr.add(v + s.size);
    }
  }
  if (y_from_zero_) yr.add(0.0);
  widen(xr);
  widen(yr);

  double x0, x1, y0, y1;
  if (equal_aspect_) {
    // Same units per pixel on both axes, data centred, 4% margin.
    const double scale = std::max(xr.span() / pw, yr.span() / ph) * 1.08;
    const double cx = 0.5 * (xr.lo + xr.hi), cy = 0.5 * (yr.lo + yr.hi);
    x0 = cx - 0.5 * pw * scale;
    x1 = cx + 0.5 * pw * scale;
    y0 = cy - 0.5 * ph * scale;
    y1 = cy + 0.5 * ph * scale;
  } else {
    // Axes end on ticks.
    const double xs = nice_step(xr.span(), 7), ys = nice_step(yr.span(), 6);
    x0 = std::floor(xr.lo / xs + 1e-9) * xs;
    x1 = std::ceil(xr.hi / xs - 1e-9) * xs;
    y0 = std::floor(yr.lo / ys + 1e-9) * ys;
    y1 = std::ceil(yr.hi / ys - 1e-9) * ys;
    if (!(x1 > x0)) x1 = x0 + xs;
    if (!(y1 > y0)) y1 = y0 + ys;
  }
  auto sx = [&](double x) { return left + (x - x0) / (x1 - x0) * pw; };
  auto sy = [&](double y) { return top + ph - (y - y0) / (y1 - y0) * ph; };

  std::string o;
  o += "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" + std::to_string(width_) + "\" height=\"" +
       std::to_string(height_) + "\" viewBox=\"0 0 " + std::to_string(width_) + " " + std::to_string(height_) +
       "\" font-family=\"sans-serif\">\n";
  o += "<rect x=\"0\" y=\"0\" width=\"" + std::to_string(width_) + "\" height=\"" + std::to_string(height_) +
       "\" fill=\"white\"/>\n";
  o += "<defs><clipPath id=\"plot-area\"><rect x=\"" + px(left) + "\" y=\"" + px(top) + "\" width=\"" + px(pw) +
       "\" height=\"" + px(ph) + "\"/></clipPath></defs>\n";
  o += "<text x=\"" + px(width_ / 2.0) + "\" y=\"28\" text-anchor=\"middle\" font-size=\"17\">" +
       xml_escape(title_) + "</text>\n";

  // Grid and tick labels.
  const std::vector<double> xt = nice_ticks(x0, x1, 7), yt = nice_ticks(y0, y1, 6);
  const double xstep = xt.size() > 1 ? xt[1] - xt[0] : 1.0, ystep = yt.size() > 1 ? yt[1] - yt[0] : 1.0;
  o += "<g stroke=\"#e0e0e0\" stroke-width=\"1\">\n";
  for (double t : xt)
    o += "<line x1=\"" + px(sx(t)) + "\" y1=\"" + px(top) + "\" x2=\"" + px(sx(t)) + "\" y2=\"" + px(top + ph) + "\"/>\n";
  for (double t : yt)
    o += "<line x1=\"" + px(left) + "\" y1=\"" + px(sy(t)) + "\" x2=\"" + px(left + pw) + "\" y2=\"" + px(sy(t)) + "\"/>\n";
  o += "</g>\n<g font-size=\"12\" fill=\"#333\">\n";
  for (double t : xt)
    o += "<text x=\"" + px(sx(t)) + "\" y=\"" + px(top + ph + 18) + "\" text-anchor=\"middle\">" +
         tick_label(t, xstep) + "</text>\n";
  for (double t : yt)
    o += "<text x=\"" + px(left - 8) + "\" y=\"" + px(sy(t) + 4) + "\" text-anchor=\"end\">" + tick_label(t, ystep) +
         "</text>\n";
  o += "</g>\n";
  o += "<text x=\"" + px(left + pw / 2) + "\" y=\"" + px(height_ - 16.0) + "\" text-anchor=\"middle\" font-size=\"14\">" +
       xml_escape(x_label_) + "</text>\n";
  o += "<text x=\"20\" y=\"" + px(top + ph / 2) + "\" text-anchor=\"middle\" font-size=\"14\" transform=\"rotate(-90 20 " +
       px(top + ph / 2) + ")\">" + xml_escape(y_label_) + "</text>\n";

  // Series, clipped to the plot area.
  o += "<g clip-path=\"url(#plot-area)\">\n";
  for (const auto& s : series_) {
    const std::string dash = s.dashed ? " stroke-dasharray=\"6 4\"" : "";
    switch (s.kind) {
      case Kind::Line: {
        // One polyline per run of finite points.
        for (const std::string& pts : point_runs(s, sx, sy))
          o += "<polyline fill=\"none\" stroke=\"" + s.color + "\" stroke-width=\"" + px(s.size) +
               "\" stroke-linejoin=\"round\"" + dash + " points=\"" + pts + "\"/>\n";
        break;
      }
      case Kind::Polygons: {
        o += "<g fill=\"" + s.color + "\" fill-opacity=\"" + px(s.size) + "\" stroke=\"none\">\n";
        for (const std::string& pts : point_runs(s, sx, sy)) o += "<polygon points=\"" + pts + "\"/>\n";
        o += "</g>\n";
        break;
      }
      case Kind::Cells:
        o += cells_svg(s, sx, sy);
        break;
      case Kind::Points:
        break;  // drawn after the frame, unclipped, so that markers on the axes show whole
      case Kind::HLine:
        if (!s.y.empty() && std::isfinite(s.y[0]))
          o += "<line x1=\"" + px(left) + "\" y1=\"" + px(sy(s.y[0])) + "\" x2=\"" + px(left + pw) + "\" y2=\"" +
               px(sy(s.y[0])) + "\" stroke=\"" + s.color + "\" stroke-width=\"" + px(s.size) + "\"" + dash + "/>\n";
        break;
      case Kind::VLine:
        if (!s.x.empty() && std::isfinite(s.x[0]))
          o += "<line x1=\"" + px(sx(s.x[0])) + "\" y1=\"" + px(top) + "\" x2=\"" + px(sx(s.x[0])) + "\" y2=\"" +
               px(top + ph) + "\" stroke=\"" + s.color + "\" stroke-width=\"" + px(s.size) + "\"" + dash + "/>\n";
        break;
      case Kind::Bars:
        o += "<g fill=\"" + s.color + "\" stroke=\"white\" stroke-width=\"0.5\">\n";
        for (std::size_t i = 0; i < s.y.size(); ++i) {
          if (!std::isfinite(s.y[i])) continue;
          const double a = sx(s.x[i]), b = sx(s.x[i + 1]);
          const double ya = sy(std::max(s.y[i], 0.0)), yb = sy(std::min(s.y[i], 0.0));
          o += "<rect x=\"" + px(std::min(a, b)) + "\" y=\"" + px(ya) + "\" width=\"" + px(std::fabs(b - a)) +
               "\" height=\"" + px(yb - ya) + "\"/>\n";
        }
        o += "</g>\n";
        break;
    }
  }
  o += "</g>\n";
  o += "<rect x=\"" + px(left) + "\" y=\"" + px(top) + "\" width=\"" + px(pw) + "\" height=\"" + px(ph) +
       "\" fill=\"none\" stroke=\"#333\" stroke-width=\"1\"/>\n";
  for (const auto& s : series_) {
    if (s.kind != Kind::Points) continue;
    o += "<g fill=\"" + s.color + "\">\n";
    for (std::size_t i = 0; i < std::min(s.x.size(), s.y.size()); ++i)
      if (std::isfinite(s.x[i]) && std::isfinite(s.y[i]))
        o += "<circle cx=\"" + px(sx(s.x[i])) + "\" cy=\"" + px(sy(s.y[i])) + "\" r=\"" + px(s.size) + "\"/>\n";
    o += "</g>\n";
  }

  // How much data a legend box at (bx, by) of size bw x bh would hide (pixel coordinates).
  auto legend_cost = [&](double bx, double by, double bw, double bh) {
    auto inside = [&](double X, double Y) { return X >= bx && X <= bx + bw && Y >= by && Y <= by + bh; };
    double cost = 0.0;
    for (const auto& s : series_) {
      const std::size_t n = std::min(s.x.size(), s.y.size());
      switch (s.kind) {
        case Kind::Line:
          for (std::size_t i = 0; i + 1 < n; ++i) {
            if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i]) || !std::isfinite(s.x[i + 1]) ||
                !std::isfinite(s.y[i + 1]))
              continue;
            for (int k = 0; k < 8; ++k) {  // samples along the segment
              const double f = k / 8.0;
              cost += inside(sx(s.x[i] + f * (s.x[i + 1] - s.x[i])), sy(s.y[i] + f * (s.y[i + 1] - s.y[i]))) ? 1 : 0;
            }
          }
          break;
        case Kind::Points:
        case Kind::Polygons:
          for (std::size_t i = 0; i < n; ++i) cost += std::isfinite(s.x[i]) && inside(sx(s.x[i]), sy(s.y[i])) ? 8 : 0;
          break;
        case Kind::Cells:
          for (std::size_t i = 0; i < n; ++i)
            cost += inside(sx(s.x[i] + 0.5 * s.size), sy(s.y[i] + 0.5 * s.size)) ? 1 : 0;
          break;
        case Kind::HLine:
          if (!s.y.empty() && sy(s.y[0]) >= by && sy(s.y[0]) <= by + bh) cost += 20;
          break;
        case Kind::VLine:
          if (!s.x.empty() && sx(s.x[0]) >= bx && sx(s.x[0]) <= bx + bw) cost += 20;
          break;
        case Kind::Bars:
          for (std::size_t i = 0; i < s.y.size(); ++i) {
            const double a = std::min(sx(s.x[i]), sx(s.x[i + 1])), b = std::max(sx(s.x[i]), sx(s.x[i + 1]));
            const double t = sy(std::max(s.y[i], 0.0)), u = sy(std::min(s.y[i], 0.0));
            const double ox = std::min(b, bx + bw) - std::max(a, bx), oy = std::min(u, by + bh) - std::max(t, by);
            if (ox > 0 && oy > 0) cost += ox * oy / 50.0;  // covered bar area
          }
          break;
      }
    }
    return cost;
  };

  // Legend, in the corner of the plot area that hides the least data (top right on ties).
  std::size_t entries = 0, longest = 0;
  for (const auto& s : series_)
    if (!s.label.empty()) {
      ++entries;
      longest = std::max(longest, s.label.size());
    }
  if (entries > 0) {
    const double w = 44 + 7.0 * static_cast<double>(longest), h = 8 + 20.0 * static_cast<double>(entries);
    const double corners[4][2] = {{left + pw - w - 10, top + 10},
                                  {left + 10, top + 10},
                                  {left + pw - w - 10, top + ph - h - 10},
                                  {left + 10, top + ph - h - 10}};
    double best_cost = std::numeric_limits<double>::infinity();
    double lx = corners[0][0], ly = corners[0][1];
    for (const auto& c : corners) {
      const double cost = legend_cost(c[0], c[1], w, h);
      if (cost < best_cost) {
        best_cost = cost;
        lx = c[0];
        ly = c[1];
      }
    }
    o += "<g font-size=\"12\">\n<rect x=\"" + px(lx) + "\" y=\"" + px(ly) + "\" width=\"" + px(w) + "\" height=\"" +
         px(h) + "\" fill=\"white\" fill-opacity=\"0.85\" stroke=\"#999\"/>\n";
    double y = ly + 18;
    for (const auto& s : series_) {
      if (s.label.empty()) continue;
      const std::string dash = s.dashed ? " stroke-dasharray=\"6 4\"" : "";
      if (s.kind == Kind::Bars || s.kind == Kind::Polygons || s.kind == Kind::Cells)
        o += "<rect x=\"" + px(lx + 8) + "\" y=\"" + px(y - 9) + "\" width=\"22\" height=\"10\" fill=\"" + s.color +
             "\"/>\n";
      else if (s.kind == Kind::Points)
        o += "<circle cx=\"" + px(lx + 19) + "\" cy=\"" + px(y - 4) + "\" r=\"4\" fill=\"" + s.color + "\"/>\n";
      else
        o += "<line x1=\"" + px(lx + 8) + "\" y1=\"" + px(y - 4) + "\" x2=\"" + px(lx + 30) + "\" y2=\"" + px(y - 4) +
             "\" stroke=\"" + s.color + "\" stroke-width=\"2\"" + dash + "/>\n";
      o += "<text x=\"" + px(lx + 36) + "\" y=\"" + px(y) + "\">" + xml_escape(s.label) + "</text>\n";
      y += 20;
    }
    o += "</g>\n";
  }
  o += "</svg>\n";
  return o;
}

void SvgPlot::save(const std::string& path) const {
  std::ofstream out(path, std::ios::binary);
  if (!out) throw Error(path + ": cannot write (check that the folder exists and is writable)");
  out << to_string();
  out.close();
  if (!out) throw Error(path + ": write failed (disk full?)");
}

}  // namespace pl
