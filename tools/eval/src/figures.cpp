#include "pl/eval/figures.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <system_error>

#include "pl/common/error.hpp"
#include "pl/common/svg.hpp"

namespace pl::eval {

namespace {

const char* const kGroundTruth = "#333333";
const char* const kEstimate = "#d62728";
const char* const kBlue = "#1f77b4";
const char* const kOrange = "#ff7f0e";
const char* const kGreen = "#2ca02c";
const char* const kPurple = "#9467bd";

std::string join_path(const std::string& dir, const std::string& name) {
  return (std::filesystem::path(dir) / name).string();
}

std::string number(const char* format, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, format, v);
  return buf;
}

std::size_t figure_bins(std::size_t n) {
  return std::clamp<std::size_t>(static_cast<std::size_t>(std::ceil(std::sqrt(static_cast<double>(n)))), 1, 40);
}

std::vector<double> bin_edges(const Histogram& h) {
  std::vector<double> edges;
  for (std::size_t i = 0; i <= h.counts.size(); ++i) edges.push_back(i == h.counts.size() ? h.hi : h.edge(i));
  return edges;
}

std::vector<double> as_doubles(const std::vector<std::size_t>& v) { return {v.begin(), v.end()}; }

}  // namespace

void make_output_dir(const std::string& dir) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec || !std::filesystem::is_directory(dir))
    throw Error(dir + ": cannot create the plot folder (" + (ec ? ec.message() : std::string("a file is in the way")) +
                "); pass --plot a writable folder");
}

std::vector<std::string> write_ape_figures(const ApeResult& r, const std::string& dir) {
  make_output_dir(dir);
  std::vector<std::string> written;
  const std::string align = alignment_name(r.alignment);

  // Top view: the two horizontal axes, ordered so that the view is from above for z-up frames
  // (x right, y up) and for KITTI's y-down camera frame (x right, z up).
  const int v = r.vertical_axis;
  const int a = v == 0 ? 1 : 0;
  const int b = v == 2 ? 1 : 2;
  auto coords = [](const Positions& p, int axis) {
    std::vector<double> out;
    out.reserve(p.size());
    for (const auto& q : p) out.push_back(q[axis]);
    return out;
  };
  {
    SvgPlot plot("Trajectory, top view (alignment: " + align + ")", std::string(1, axis_name(a)) + " [m]",
                 std::string(1, axis_name(b)) + " [m]");
    plot.set_equal_aspect(true);
    plot.add_line("ground truth", coords(r.gt_positions, a), coords(r.gt_positions, b), kGroundTruth, 2.0);
    plot.add_line(r.alignment == Alignment::None ? "estimate" : "estimate (" + align + "-aligned)",
                  coords(r.est_positions, a), coords(r.est_positions, b), kEstimate, 1.5);
    if (!r.gt_positions.empty())
      plot.add_points("start", {r.gt_positions.front()[a]}, {r.gt_positions.front()[b]}, kGreen, 5.0);
    written.push_back(join_path(dir, "trajectory.svg"));
    plot.save(written.back());
  }
  {
    SvgPlot plot("Absolute position error over distance (alignment: " + align + ")",
                 "distance travelled along the ground truth [m]", "position error [m]");
    plot.set_y_from_zero(true);
    plot.add_line("error", r.gt_distance, r.errors, kBlue, 1.2);
    plot.add_hline("mean " + number("%.3f", r.error.mean) + " m", r.error.mean, kOrange);
    plot.add_hline("rmse " + number("%.3f", r.error.rmse) + " m", r.error.rmse, kPurple);
    written.push_back(join_path(dir, "error_over_distance.svg"));
    plot.save(written.back());
  }
  {
    const Histogram h = make_histogram(r.errors, figure_bins(r.errors.size()));
    SvgPlot plot("Absolute position error histogram (" + std::to_string(r.errors.size()) + " poses, alignment: " +
                     align + ")",
                 "position error [m]", "poses");
    plot.add_bars("poses per bin", bin_edges(h), as_doubles(h.counts), kBlue);
    plot.add_vline("median " + number("%.3f", r.error.median) + " m", r.error.median, kOrange);
    written.push_back(join_path(dir, "error_histogram.svg"));
    plot.save(written.back());
  }
  return written;
}

std::vector<std::string> write_kitti_figures(const KittiResult& r, const std::string& dir) {
  make_output_dir(dir);
  std::vector<double> len, pct;
  for (const auto& g : r.by_length) {
    len.push_back(g.lo);
    pct.push_back(g.translation_pct);
  }
  SvgPlot plot("KITTI relative translation error by segment length", "segment length [m]", "translation error [%]");
  plot.set_y_from_zero(true);
  plot.add_line("", len, pct, kBlue, 2.0);
  plot.add_points("by length", len, pct, kBlue, 4.0);
  plot.add_hline("average " + number("%.3f", r.overall.translation_pct) + " %", r.overall.translation_pct, kOrange);
  std::vector<std::string> written{join_path(dir, "kitti_errors.svg")};
  plot.save(written.back());
  return written;
}

std::vector<std::string> write_timing_figures(const TimingColumn& c, const TimingStats& s, const std::string& dir) {
  make_output_dir(dir);
  const Histogram h = make_histogram(c.values, figure_bins(c.values.size()));
  SvgPlot plot("Per-scan time: " + c.name + " (" + std::to_string(s.count) + " scans)", "time per scan [ms]", "scans");
  plot.add_bars("scans per bin", bin_edges(h), as_doubles(h.counts), kBlue);
  plot.add_vline("p50 " + number("%.2f", s.p50) + " ms", s.p50, kGreen);
  plot.add_vline("p90 " + number("%.2f", s.p90) + " ms", s.p90, kOrange);
  plot.add_vline("p99 " + number("%.2f", s.p99) + " ms", s.p99, kEstimate);
  std::vector<std::string> written{join_path(dir, "timing_histogram.svg")};
  plot.save(written.back());
  return written;
}

}  // namespace pl::eval
