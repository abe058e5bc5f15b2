#include "pl/eval/report.hpp"

#include <cmath>
#include <cstdio>

#include "pl/common/text.hpp"

namespace pl::eval {

namespace {

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
    Eigen::Matrix4d m = r.alignment_transform.matrix();
    m.topLeftCorner<3, 3>() *= r.alignment_scale;  // the matrix applied to the estimate
    for (int row = 0; row < 3; ++row) rows.push_back({m(row, 0), m(row, 1), m(row, 2), m(row, 3)});
    j["alignment_transform"] = rows;
  }
  if (r.alignment == Alignment::Sim3) j["scale"] = r.alignment_scale;
  return j;
}

std::string ape_text(const ApeResult& r, const std::string& est_path, const std::string& gt_path) {
  std::string o;
  o += "Absolute position error (APE, translation, metres)\n";
  o += "  estimate      " + est_path + "\n";
  o += "  ground truth  " + gt_path + "\n";
  append_format(o, "  alignment     %s%s\n", alignment_name(r.alignment),
                r.alignment == Alignment::None  ? " (raw poses)"
                : r.alignment == Alignment::Se3 ? " (rigid: rotation + translation, no scale)"
                                                : " (similarity: rotation + translation + uniform scale)");
  if (r.alignment == Alignment::Sim3)
    append_format(o, "  scale         %.6f (applied to the estimate: it was %.4f times the ground truth's size)\n",
                  r.alignment_scale, r.alignment_scale > 0.0 ? 1.0 / r.alignment_scale : 0.0);
  append_format(o, "  matched       %zu of %zu ground-truth poses (coverage %.1f %%)\n", r.matched, r.gt_poses,
                r.coverage * 100.0);
  append_format(o, "  vertical axis %c (%s)\n", axis_name(r.vertical_axis),
                r.vertical_axis_auto ? "auto: the ground truth's smallest extent; override with --up" : "from --up");
  o += "\n";
  append_format(o, "  %-14s %10s %10s %10s %10s %10s\n", "", "mean", "median", "rmse", "std", "max");
  append_format(o, "  %-14s %10.4f %10.4f %10.4f %10.4f %10.4f\n", "error [m]", r.error.mean, r.error.median, r.error.rmse,
                r.error.std, r.error.max);
  o += "\n";
  append_format(o, "  %-14s %10s %10s\n", "component", "mean |e|", "rmse");
  append_format(o, "  %-14s %10.4f %10.4f\n", "longitudinal", r.longitudinal.mean_abs, r.longitudinal.rmse);
  append_format(o, "  %-14s %10.4f %10.4f\n", "lateral", r.lateral.mean_abs, r.lateral.rmse);
  append_format(o, "  %-14s %10.4f %10.4f\n", "vertical", r.vertical.mean_abs, r.vertical.rmse);
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
  append_format(o, "  pairs         %zu poses, %.1f m of ground-truth path, %zu segments\n", r.pairs, r.path_length,
                r.segments.size());
  append_format(o, "  speed from    %s\n", r.times_from_files ? "timestamps" : "frame numbers at 10 Hz");
  o += "\n";
  append_format(o, "  %-16s %9s %14s %18s\n", "", "segments", "translation %", "rotation deg/100m");
  append_format(o, "  %-16s %9zu %14.4f %18.4f\n", "overall", r.overall.segments, r.overall.translation_pct,
                r.overall.rotation_deg_per_100m);
  o += "\n  by length\n";
  for (const auto& g : r.by_length) {
    char label[32];
    std::snprintf(label, sizeof label, "%.0f m", g.lo);
    append_format(o, "  %-16s %9zu %14.4f %18.4f\n", label, g.segments, g.translation_pct, g.rotation_deg_per_100m);
  }
  o += "\n  by speed\n";
  for (const auto& g : r.by_speed) {
    char label[32];
    std::snprintf(label, sizeof label, "%.0f-%.0f km/h", g.lo, g.hi);
    append_format(o, "  %-16s %9zu %14.4f %18.4f\n", label, g.segments, g.translation_pct, g.rotation_deg_per_100m);
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
  j["percentiles"] = "linear";  // interpolated between the closest ranks (pl/common/stats.hpp)
  nlohmann::ordered_json edges = nlohmann::ordered_json::array();
  for (std::size_t i = 0; i <= h.counts.size(); ++i) edges.push_back(i == h.counts.size() ? h.hi : h.edge(i));
  j["histogram"] = {{"edges", edges}, {"counts", h.counts}};
  return j;
}

std::string timing_text(const TimingColumn& c, const TimingStats& s, const Histogram& h, const std::string& path) {
  std::string o;
  o += "Per-scan time, column " + c.name + " of " + path + " (ms; percentiles interpolated between ranks)\n";
  append_format(o, "  %8s %10s %10s %10s %10s %10s %10s\n", "count", "min", "mean", "p50", "p90", "p99", "max");
  append_format(o, "  %8zu %10.3f %10.3f %10.3f %10.3f %10.3f %10.3f\n", s.count, s.min, s.mean, s.p50, s.p90, s.p99, s.max);
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

namespace {

double share_at(const MapAccuracy& r, double distance) {
  for (const auto& s : r.shares)
    if (std::fabs(s.distance - distance) < 1e-12) return s.share;
  return 0.0;
}

}  // namespace

nlohmann::ordered_json map_json(const MapAccuracy& r, const std::string& map_path, const std::string& reference_path,
                                const std::optional<GeoPoint>& origin) {
  nlohmann::ordered_json j;
  j["map"] = map_path;
  j["reference"] = reference_path;
  j["map_points"] = r.map_points;
  j["reference_points"] = r.reference_points;
  if (origin)
    j["origin"] = {{"lat", origin->lat_deg}, {"lon", origin->lon_deg}, {"alt", origin->alt_m}};
  else
    j["origin"] = nullptr;
  j["within_m"] = r.within;
  j["share_within"] = share_at(r, r.within);
  nlohmann::ordered_json shares = nlohmann::ordered_json::array();
  for (const auto& s : r.shares) shares.push_back({{"distance_m", s.distance}, {"points", s.points}, {"share", s.share}});
  j["shares"] = shares;
  j["mean"] = r.distance.mean;
  j["median"] = r.distance.median;
  j["rmse"] = r.distance.rmse;
  j["p90"] = r.p90;
  j["p95"] = r.p95;
  j["p99"] = r.p99;
  j["max"] = r.distance.max;
  j["metric"] = r.surface ? "surface" : "point";
  j["surface_points"] = r.surface_points;
  j["reference_spacing_m"] = r.reference_spacing;
  j["coverage_radius_m"] = r.coverage_radius;
  j["reference_coverage"] = r.reference_coverage;
  return j;
}

std::string map_text(const MapAccuracy& r, const std::string& map_path, const std::string& reference_path,
                     const std::optional<GeoPoint>& origin) {
  std::string o;
  o += r.surface ? "Map accuracy: distance from each map point to the reference surface (metres)\n"
                 : "Map accuracy: distance from each map point to the nearest reference point (metres)\n";
  append_format(o, "  map           %s (%zu points)\n", map_path.c_str(), r.map_points);
  append_format(o, "  reference     %s (%zu points, spacing %.3f m)\n", reference_path.c_str(), r.reference_points,
                r.reference_spacing);
  if (origin)
    append_format(o, "  origin        lat %.9f, lon %.9f, alt %.3f m\n", origin->lat_deg, origin->lon_deg, origin->alt_m);
  else
    o += "  origin        not recorded (the clouds are taken to share one world frame)\n";
  o += "\n";
  append_format(o, "  within %.3f m  %6.2f %% of the map points\n", r.within, 100.0 * share_at(r, r.within));
  o += "\n";
  append_format(o, "  %-12s %10s %10s\n", "within [m]", "points", "share %");
  for (const auto& s : r.shares) append_format(o, "  %-12.3f %10zu %10.2f\n", s.distance, s.points, 100.0 * s.share);
  o += "\n";
  append_format(o, "  %-14s %9s %9s %9s %9s %9s %9s\n", "", "mean", "median", "p90", "p95", "p99", "max");
  append_format(o, "  %-14s %9.4f %9.4f %9.4f %9.4f %9.4f %9.4f\n", "distance [m]", r.distance.mean, r.distance.median, r.p90,
                r.p95, r.p99, r.distance.max);
  o += "\n";
  append_format(o, "  reference coverage  %.2f %% of the reference points have a map point within %.2f m\n",
                100.0 * r.reference_coverage, r.coverage_radius);
  if (r.surface)
    append_format(o,
                  "  metric              %zu of the map points (%.1f %%) measured to a plane fitted to the reference, the rest "
                  "to the nearest reference point\n",
                  r.surface_points, 100.0 * static_cast<double>(r.surface_points) / r.map_points);
  if (!r.surface && 0.5 * std::sqrt(2.0) * r.reference_spacing > r.within)
    append_format(o,
                  "  note: the reference's points are %.3f m apart, so even a perfect map point can be up to about "
                  "%.3f m from the nearest one; a denser reference (pl-sim --map-spacing) resolves --within %.3f m\n",
                  r.reference_spacing, 0.5 * r.reference_spacing * std::sqrt(2.0), r.within);
  return o;
}

}  // namespace pl::eval
