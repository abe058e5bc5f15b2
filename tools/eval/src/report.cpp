#include "pl/eval/report.hpp"

#include <cstdarg>
#include <cstdio>

namespace pl::eval {

namespace {

std::string line(const char* format, ...) __attribute__((format(printf, 1, 2)));
std::string line(const char* format, ...) {
  char buf[512];
  va_list args;
  va_start(args, format);
  std::vsnprintf(buf, sizeof buf, format, args);
  va_end(args);
  return std::string(buf) + "\n";
}

nlohmann::ordered_json component_json(const ComponentError& c) { return {{"mean_abs", c.mean_abs}, {"rmse", c.rmse}}; }

nlohmann::ordered_json group_json(const ErrorGroup& g) {
  return {{"segments", g.segments},
          {"translation_pct", g.translation_pct},
          {"rotation_deg_per_100m", g.rotation_deg_per_100m}};
}

}  // namespace

nlohmann::ordered_json ape_json(const ApeResult& r) {
  nlohmann::ordered_json j;
  j["alignment"] = alignment_name(r.alignment);
  j["matched"] = r.matched;
  j["gt_poses"] = r.gt_poses;
  j["coverage"] = r.coverage;
  j["mean"] = r.error.mean;
  j["median"] = r.error.median;
  j["rmse"] = r.error.rmse;
  j["std"] = r.error.std;
  j["max"] = r.error.max;
  j["lateral"] = component_json(r.lateral);
  j["longitudinal"] = component_json(r.longitudinal);
  j["vertical"] = component_json(r.vertical);
  j["vertical_axis"] = std::string(1, axis_name(r.vertical_axis));
  j["vertical_axis_source"] = r.vertical_axis_auto ? "auto" : "option";
  if (r.alignment != Alignment::None) {
    nlohmann::ordered_json rows = nlohmann::ordered_json::array();
    const Eigen::Matrix4d m = r.alignment_transform.matrix();
    for (int row = 0; row < 3; ++row) rows.push_back({m(row, 0), m(row, 1), m(row, 2), m(row, 3)});
    j["alignment_transform"] = rows;
  }
  return j;
}

std::string ape_text(const ApeResult& r, const std::string& est_path, const std::string& gt_path) {
  std::string o;
  o += "Absolute position error (APE, translation, metres)\n";
  o += "  estimate      " + est_path + "\n";
  o += "  ground truth  " + gt_path + "\n";
  o += line("  alignment     %s%s", alignment_name(r.alignment),
            r.alignment == Alignment::None ? " (raw poses)" : " (rigid: rotation + translation, no scale)");
  o += line("  matched       %zu of %zu ground-truth poses (coverage %.1f %%)", r.matched, r.gt_poses,
            r.coverage * 100.0);
  o += line("  vertical axis %c (%s)", axis_name(r.vertical_axis),
            r.vertical_axis_auto ? "auto: the ground truth's smallest extent; override with --up" : "from --up");
  o += "\n";
  o += line("  %-14s %10s %10s %10s %10s %10s", "", "mean", "median", "rmse", "std", "max");
  o += line("  %-14s %10.4f %10.4f %10.4f %10.4f %10.4f", "error [m]", r.error.mean, r.error.median, r.error.rmse,
            r.error.std, r.error.max);
  o += "\n";
  o += line("  %-14s %10s %10s", "component", "mean |e|", "rmse");
  o += line("  %-14s %10.4f %10.4f", "longitudinal", r.longitudinal.mean_abs, r.longitudinal.rmse);
  o += line("  %-14s %10.4f %10.4f", "lateral", r.lateral.mean_abs, r.lateral.rmse);
  o += line("  %-14s %10.4f %10.4f", "vertical", r.vertical.mean_abs, r.vertical.rmse);
  return o;
}

nlohmann::ordered_json kitti_json(const KittiResult& r) {
  nlohmann::ordered_json j;
  j["pairs"] = r.pairs;
  j["segments"] = r.segments.size();
  j["path_length_m"] = r.path_length;
  j["time_source"] = r.times_from_files ? "timestamps" : "frames at 10 Hz";
  j["translation_pct"] = r.overall.translation_pct;
  j["rotation_deg_per_100m"] = r.overall.rotation_deg_per_100m;
  nlohmann::ordered_json by_length = nlohmann::ordered_json::array();
  for (const auto& g : r.by_length) {
    nlohmann::ordered_json e = group_json(g);
    e["length_m"] = g.lo;
    by_length.push_back(e);
  }
  j["by_length"] = by_length;
  nlohmann::ordered_json by_speed = nlohmann::ordered_json::array();
  for (const auto& g : r.by_speed) {
    nlohmann::ordered_json e = group_json(g);
    e["speed_min_kmh"] = g.lo;
    e["speed_max_kmh"] = g.hi;
    by_speed.push_back(e);
  }
  j["by_speed"] = by_speed;
  return j;
}

std::string kitti_text(const KittiResult& r, const std::string& est_path, const std::string& gt_path) {
  std::string o;
  o += "KITTI odometry relative errors (segments of 100..800 m from every 10th frame)\n";
  o += "  estimate      " + est_path + "\n";
  o += "  ground truth  " + gt_path + "\n";
  o += line("  pairs         %zu poses, %.1f m of ground-truth path, %zu segments", r.pairs, r.path_length,
            r.segments.size());
  o += line("  speed from    %s", r.times_from_files ? "timestamps" : "frame numbers at 10 Hz");
  o += "\n";
  o += line("  %-16s %9s %14s %18s", "", "segments", "translation %", "rotation deg/100m");
  o += line("  %-16s %9zu %14.4f %18.4f", "overall", r.overall.segments, r.overall.translation_pct,
            r.overall.rotation_deg_per_100m);
  o += "\n  by length\n";
  for (const auto& g : r.by_length) {
    char label[32];
    std::snprintf(label, sizeof label, "%.0f m", g.lo);
    o += line("  %-16s %9zu %14.4f %18.4f", label, g.segments, g.translation_pct, g.rotation_deg_per_100m);
  }
  o += "\n  by speed\n";
  for (const auto& g : r.by_speed) {
    char label[32];
    std::snprintf(label, sizeof label, "%.0f-%.0f km/h", g.lo, g.hi);
    o += line("  %-16s %9zu %14.4f %18.4f", label, g.segments, g.translation_pct, g.rotation_deg_per_100m);
  }
  return o;
}

nlohmann::ordered_json timing_json(const TimingColumn& c, const TimingStats& s, const Histogram& h) {
  nlohmann::ordered_json j;
  j["column"] = c.name;
  j["count"] = s.count;
  j["min"] = s.min;
  j["mean"] = s.mean;
  j["p50"] = s.p50;
  j["p90"] = s.p90;
  j["p99"] = s.p99;
  j["max"] = s.max;
  j["percentiles"] = "nearest-rank";
  nlohmann::ordered_json edges = nlohmann::ordered_json::array();
  for (std::size_t i = 0; i <= h.counts.size(); ++i) edges.push_back(i == h.counts.size() ? h.hi : h.edge(i));
  j["histogram"] = {{"edges", edges}, {"counts", h.counts}};
  return j;
}

std::string timing_text(const TimingColumn& c, const TimingStats& s, const Histogram& h, const std::string& path) {
  std::string o;
  o += "Per-scan time, column " + c.name + " of " + path + " (ms; percentiles are nearest-rank)\n";
  o += line("  %8s %10s %10s %10s %10s %10s %10s", "count", "min", "mean", "p50", "p90", "p99", "max");
  o += line("  %8zu %10.3f %10.3f %10.3f %10.3f %10.3f %10.3f", s.count, s.min, s.mean, s.p50, s.p90, s.p99, s.max);
  o += "\n";
  const std::string hist = text_histogram(h, 40, 2);
  std::size_t start = 0;
  while (start < hist.size()) {
    std::size_t end = hist.find('\n', start);
    o += "  " + hist.substr(start, end - start) + "\n";
    start = end == std::string::npos ? hist.size() : end + 1;
  }
  return o;
}

}  // namespace pl::eval
