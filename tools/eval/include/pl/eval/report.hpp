// Text tables and JSON objects for the pl-eval results.
#pragma once

#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "pl/eval/ape.hpp"
#include "pl/eval/kitti_metrics.hpp"
#include "pl/eval/map_accuracy.hpp"
#include "pl/eval/timing.hpp"

namespace pl::eval {

// Keys: alignment, matched, gt_poses, coverage, mean, median, rmse, std, max,
// lateral/longitudinal/vertical {mean_abs, rmse}, vertical_axis, vertical_axis_source, for se3 and
// sim3 alignment_transform (the 3x4 rows applied to the estimate, scale * R | t), and for sim3 scale.
// Keys keep this order.
nlohmann::ordered_json ape_json(const ApeResult& r);
std::string ape_text(const ApeResult& r, const std::string& est_path, const std::string& gt_path);

// Keys: pairs, segments, path_length_m, time_source, translation_pct, rotation_deg_per_100m,
// by_length [{length_m, ...}], by_speed [{speed_min_kmh, speed_max_kmh, ...}].
nlohmann::ordered_json kitti_json(const KittiResult& r);
std::string kitti_text(const KittiResult& r, const std::string& est_path, const std::string& gt_path);

// Keys: column, count, min, mean, p50, p90, p99, max, percentiles, histogram {edges, counts}.
nlohmann::ordered_json timing_json(const TimingColumn& c, const TimingStats& s, const Histogram& h);
std::string timing_text(const TimingColumn& c, const TimingStats& s, const Histogram& h, const std::string& path);

// Keys: map, reference, map_points, reference_points, origin ({lat, lon, alt} or null), within_m,
// share_within, shares [{distance_m, points, share}], mean, median, rmse, p90, p95, p99, max, metric,
// surface_points, reference_spacing_m, coverage_radius_m, reference_coverage.
nlohmann::ordered_json map_json(const MapAccuracy& r, const std::string& map_path, const std::string& reference_path,
                                const std::optional<GeoPoint>& origin);
std::string map_text(const MapAccuracy& r, const std::string& map_path, const std::string& reference_path,
                     const std::optional<GeoPoint>& origin);

}  // namespace pl::eval
