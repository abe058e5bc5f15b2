#include "pl/common/svg.hpp"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <filesystem>
#include <regex>
#include <sstream>

#include "eval_test_util.hpp"
#include "pl/common/error.hpp"
#include "pl/eval/figures.hpp"

namespace pl::eval {
namespace {

using test::count_of;
using test::read_text;
using test::starts_with;
using test::TempDir;

// Well-formed enough: starts with <svg, ends with </svg>, every element opened is closed.
void expect_svg_document(const std::string& text, const std::string& what) {
  EXPECT_TRUE(starts_with(text, "<svg")) << what;
  std::string trimmed = text;
  while (!trimmed.empty() && std::isspace(static_cast<unsigned char>(trimmed.back()))) trimmed.pop_back();
  EXPECT_GE(trimmed.size(), 6u);
  EXPECT_EQ(trimmed.substr(trimmed.size() - 6), "</svg>") << what;
  for (const char* tag : {"svg", "g", "text", "defs", "clipPath"}) {
    const std::string open = std::string("<") + tag, close = std::string("</") + tag + ">";
    // Count "<tag " and "<tag>" (not "<tagX"), against "</tag>".
    std::size_t opened = count_of(text, open + " ") + count_of(text, open + ">");
    EXPECT_EQ(opened, count_of(text, close)) << what << ": <" << tag << ">";
  }
}

std::vector<std::pair<double, double>> polyline_points(const std::string& svg, std::size_t which) {
  std::size_t pos = 0;
  for (std::size_t k = 0; k <= which; ++k) {
    pos = svg.find("<polyline", pos);
    if (pos == std::string::npos) return {};
    if (k < which) ++pos;
  }
  const std::size_t a = svg.find("points=\"", pos) + 8, b = svg.find('"', a);
  std::stringstream ss(svg.substr(a, b - a));
  std::vector<std::pair<double, double>> out;
  std::string pair;
  while (ss >> pair) {
    const auto comma = pair.find(',');
    out.emplace_back(std::stod(pair.substr(0, comma)), std::stod(pair.substr(comma + 1)));
  }
  return out;
}

TEST(EvalSvg, NiceTicks) {
  EXPECT_EQ(nice_ticks(0, 10, 6), (std::vector<double>{0, 2, 4, 6, 8, 10}));
  const auto t = nice_ticks(-0.33, 0.71, 6);
  ASSERT_EQ(t.size(), 5u);
  EXPECT_NEAR(t.front(), -0.2, 1e-12);
  EXPECT_NEAR(t.back(), 0.6, 1e-12);
  EXPECT_EQ(nice_ticks(0, 1000, 5), (std::vector<double>{0, 200, 400, 600, 800, 1000}));
  EXPECT_TRUE(nice_ticks(1, 0).empty());
}

TEST(EvalSvg, EscapesText) { EXPECT_EQ(xml_escape("a<b & \"c\">'"), "a&lt;b &amp; &quot;c&quot;&gt;&apos;"); }

TEST(EvalSvg, PlotHasAxesLegendAndPolylines) {
  SvgPlot plot("Title <1>", "x [m]", "y [m]");
  plot.add_line("first", {0, 1, 2, 3}, {0, 1, 4, 9}, "#f00");
  plot.add_line("second", {0, 3}, {9, 0}, "#00f", 1.0, true);
  plot.add_hline("level", 5, "#0f0");
  const std::string svg = plot.to_string();
  expect_svg_document(svg, "plot");
  EXPECT_EQ(count_of(svg, "<polyline"), 2u);
  EXPECT_NE(svg.find("Title &lt;1&gt;"), std::string::npos);
  EXPECT_NE(svg.find(">x [m]</text>"), std::string::npos);
  EXPECT_NE(svg.find(">y [m]</text>"), std::string::npos);
  EXPECT_NE(svg.find(">first</text>"), std::string::npos);
  EXPECT_NE(svg.find(">level</text>"), std::string::npos);
  EXPECT_NE(svg.find(">8</text>"), std::string::npos);  // a y tick label
  EXPECT_NE(svg.find("stroke-dasharray"), std::string::npos);
  EXPECT_EQ(polyline_points(svg, 0).size(), 4u);
}

TEST(EvalSvg, EqualAspectUsesTheSameScaleOnBothAxes) {
  SvgPlot plot("t", "x", "y");
  plot.set_equal_aspect(true);
  plot.add_line("along x", {0, 100}, {0, 0}, "#f00");
  plot.add_line("along y", {0, 0}, {0, 10}, "#00f");
  const std::string svg = plot.to_string();
  const auto a = polyline_points(svg, 0), b = polyline_points(svg, 1);
  ASSERT_EQ(a.size(), 2u);
  ASSERT_EQ(b.size(), 2u);
  const double px_per_unit_x = std::fabs(a[1].first - a[0].first) / 100.0;
  const double px_per_unit_y = std::fabs(b[1].second - b[0].second) / 10.0;
  EXPECT_NEAR(px_per_unit_x, px_per_unit_y, 0.01);
  EXPECT_LT(b[1].second, b[0].second);  // y grows upwards on the page
}

TEST(EvalSvg, NonFiniteValuesBreakTheLine) {
  SvgPlot plot("t", "x", "y");
  plot.add_line("l", {0, 1, 2, 3, 4}, {0, 1, std::nan(""), 3, 4}, "#f00");
  EXPECT_EQ(count_of(plot.to_string(), "<polyline"), 2u);
}

TEST(EvalSvg, BarsAndSave) {
  TempDir dir;
  SvgPlot plot("h", "v", "n");
  plot.add_bars("bins", {0, 1, 2, 3}, {4, 0, 2}, "#123456");
  plot.add_vline("p50", 1.5, "#000");
  const std::string path = dir.file("h.svg");
  plot.save(path);
  const std::string svg = read_text(path);
  expect_svg_document(svg, path);
  EXPECT_NE(svg.find("fill=\"#123456\""), std::string::npos);
  EXPECT_THROW(plot.save(dir.file("no/such/folder/h.svg")), pl::Error);
  EXPECT_THROW(plot.add_bars("bad", {0, 1}, {1, 2}, "#000"), pl::Error);
}

// The rectangles "Mx0 y0Hx1Vy1Hx0z" of the cell path filled with `color`.
std::vector<std::array<double, 4>> cell_runs(const std::string& svg, const std::string& color) {
  std::vector<std::array<double, 4>> out;
  const std::size_t at = svg.find("<path fill=\"" + color + "\" d=\"");
  if (at == std::string::npos) return out;
  const std::size_t a = svg.find("d=\"", at) + 3, b = svg.find('"', a);
  const std::regex run("M([-0-9.]+) ([-0-9.]+)H([-0-9.]+)V([-0-9.]+)H([-0-9.]+)z");
  const std::string d = svg.substr(a, b - a);
  for (std::sregex_iterator it(d.begin(), d.end(), run), end; it != end; ++it) {
    out.push_back({std::stod((*it)[1]), std::stod((*it)[2]), std::stod((*it)[3]), std::stod((*it)[4])});
    EXPECT_EQ((*it)[1], (*it)[5]);  // the rectangle closes where it started
  }
  return out;
}

TEST(EvalSvg, CellsMergeIntoRunsPerShade) {
  SvgPlot plot("cells", "x", "y");
  plot.set_equal_aspect(true);
  // Row 0: three dark cells side by side and one more dark cell apart; row 1: one light cell.
  plot.add_cells("map", 2.0, {0, 2, 4, 10, 0}, {0, 0, 0, 0, 2}, {0.95, 0.99, 1.5, 0.97, 0.0});
  const std::string svg = plot.to_string();
  expect_svg_document(svg, "cells");
  const std::string dark = SvgPlot::cell_color(1.0), light = SvgPlot::cell_color(0.0);
  EXPECT_EQ(dark, "#2a2a2a");
  EXPECT_EQ(light, "#e4e4e4");
  EXPECT_EQ(SvgPlot::cell_color(std::nan("")), light);
  EXPECT_NE(SvgPlot::cell_color(0.5), dark);
  EXPECT_EQ(count_of(svg, "<path fill="), 2u);  // one path per shade
  const auto d = cell_runs(svg, dark), l = cell_runs(svg, light);
  ASSERT_EQ(d.size(), 2u);  // the three neighbours are one run
  ASSERT_EQ(l.size(), 1u);
  const double cell_px = l[0][2] - l[0][0];
  EXPECT_GT(cell_px, 10.0);
  EXPECT_NEAR(d[0][2] - d[0][0], 3.0 * cell_px, 0.2);  // the run spans three cells
  EXPECT_NEAR(d[0][3] - d[0][1], cell_px, 0.2);        // square cells (equal aspect)
  EXPECT_NEAR(d[1][0] - d[0][0], 5.0 * cell_px, 0.2);  // the lone cell starts at x = 10
  EXPECT_NEAR(l[0][3], d[0][1], 0.05);                 // row 1 sits on top of row 0 without a gap
  EXPECT_GT(d[0][1], l[0][1]);                         // y grows upwards on the page
  // The far edge of the last cell (x = 12) is inside the plot area (right margin 24 px).
  EXPECT_LE(d[1][2], 800.0 - 24.0);
  EXPECT_NE(svg.find(">map</text>"), std::string::npos);  // the legend entry

  EXPECT_THROW(plot.add_cells("bad", 0.0, {0}, {0}, {0}), pl::Error);
  EXPECT_THROW(plot.add_cells("bad", 1.0, {0, 1}, {0}, {0, 1}), pl::Error);
}

TEST(EvalSvg, ApeFigures) {
  TempDir dir;
  const Trajectory gt = test::curvy_path(120);
  Trajectory est = gt;
  for (auto& p : est.poses) p.translation() += Eigen::Vector3d(0.5, -0.2, 0.1);
  const ApeResult r = compute_ape(est, gt, pair_poses(est, gt, "e", "g"));
  const std::string out = dir.file("plots/nested");  // created on demand
  const auto files = write_ape_figures(r, out);
  ASSERT_EQ(files.size(), 3u);
  EXPECT_EQ(std::filesystem::path(files[0]).filename(), "trajectory.svg");
  EXPECT_EQ(std::filesystem::path(files[1]).filename(), "error_over_distance.svg");
  EXPECT_EQ(std::filesystem::path(files[2]).filename(), "error_histogram.svg");
  for (const auto& f : files) expect_svg_document(read_text(f), f);
  const std::string traj = read_text(files[0]);
  EXPECT_EQ(count_of(traj, "<polyline"), 2u);  // ground truth and estimate
  EXPECT_EQ(polyline_points(traj, 0).size(), 120u);
  EXPECT_NE(traj.find(">ground truth</text>"), std::string::npos);
  EXPECT_NE(traj.find(">estimate</text>"), std::string::npos);
  EXPECT_EQ(polyline_points(read_text(files[1]), 0).size(), 120u);
  EXPECT_GE(count_of(read_text(files[2]), "<rect"), 11u);  // ceil(sqrt(120)) = 11 bars, plus frames
}

TEST(EvalSvg, PlotFolderThatIsAFileIsAnError) {
  TempDir dir;
  test::write_text(dir.file("f"), "x");
  EXPECT_THROW(make_output_dir(dir.file("f")), pl::Error);
}

TEST(EvalSvg, KittiAndTimingFigures) {
  TempDir dir;
  const Trajectory gt = test::curvy_path(700);
  Trajectory est = gt;
  for (auto& p : est.poses) p.translation() *= 1.01;
  const KittiResult k = compute_kitti_metrics(est, gt, pair_poses(est, gt, "e", "g"));
  const auto kf = write_kitti_figures(k, dir.path());
  ASSERT_EQ(kf.size(), 1u);
  EXPECT_EQ(std::filesystem::path(kf[0]).filename(), "kitti_errors.svg");
  const std::string ks = read_text(kf[0]);
  expect_svg_document(ks, kf[0]);
  EXPECT_EQ(polyline_points(ks, 0).size(), k.by_length.size());

  TimingColumn c;
  c.name = "registration_ms";
  for (int i = 0; i < 50; ++i) c.values.push_back(10.0 + (i % 7));
  const auto tf = write_timing_figures(c, timing_stats(c.values), dir.path());
  ASSERT_EQ(tf.size(), 1u);
  EXPECT_EQ(std::filesystem::path(tf[0]).filename(), "timing_histogram.svg");
  const std::string ts = read_text(tf[0]);
  expect_svg_document(ts, tf[0]);
  EXPECT_NE(ts.find(">p90 "), std::string::npos);
}

}  // namespace
}  // namespace pl::eval
