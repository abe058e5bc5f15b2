#include "pl/maps/gloam.hpp"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <vector>

#include <nlohmann/json.hpp>

#include "pl/common/cloud_io.hpp"
#include "pl/common/error.hpp"
#include "pl/common/scan.hpp"
#include "pl/common/text.hpp"
#include "pl/maps/import.hpp"
#include "pl/registration/place_index.hpp"

namespace pl::maps {

namespace {

// Real recordings (no meta.json: KITTI) sweep while the car moves, and so do drives whose points carry
// their own times (point_times/: pl-sim's swept scans, a driver's per-point times).
bool deskews(const GloamConfig& cfg, const Dataset& ds) {
  return cfg.deskew == Deskew::On || (cfg.deskew == Deskew::Auto && (!ds.has_meta_file || ds.has_point_times()));
}

// The observer's calls, each optional.
struct Tell {
  const GloamObserver& o;
  void progress(const std::string& stage, std::size_t done, std::size_t total) const {
    if (o.progress) o.progress(stage, done, total);
  }
  void log(const std::string& line) const {
    if (o.log) o.log(line);
  }
};

const char* source_name(const GloamConfig& cfg) {
  if (cfg.poses == PoseSource::GroundTruth) return "ground truth";
  if (cfg.gps && cfg.loops) return "lidar odometry + GPS + loops pose graph";
  if (cfg.gps) return "lidar odometry + GPS pose graph";
  if (cfg.loops) return "lidar odometry + loops pose graph";
  return "lidar odometry";
}

nlohmann::json loop_report_json(const LoopReport& lr, const PoseGraph& graph) {
  nlohmann::json loops = nlohmann::json::array();
  for (const LoopRecord& l : lr.loops)
    loops.push_back({{"query_scan", graph.keyframes()[l.query]},
                     {"match_scan", graph.keyframes()[l.match]},
                     {"proposed_by", l.by_descriptor ? "place" : "position"},
                     {"accepted", l.accepted},
                     {"reason", l.reason},
                     {"descriptor_distance", l.descriptor_distance},
                     {"overlap", l.overlap},
                     {"rms_m", l.rms_m},
                     {"correction_m", l.correction_m},
                     {"drift_m", l.drift_m}});
  return {{"queries", lr.queries},
          {"proposed_by_position", lr.proposed_by_position},
          {"proposed_by_place", lr.proposed_by_descriptor},
          {"accepted", lr.accepted},
          {"rejected", lr.rejected},
          {"rejected_by_reason", lr.rejected_by_reason},
          {"residual_before_m", lr.residual_before_m},
          {"residual_after_m", lr.residual_after_m},
          {"verify_ms", lr.verify_ms},
          {"edges", loops}};
}

nlohmann::json graph_report_json(const PoseGraphReport& r) {
  return {{"keyframes", r.keyframes},       {"gps_edges", r.gps_edges},   {"gps_outliers", r.gps_outliers},
          {"gps_rms_before_m", r.gps_rms_before_m}, {"gps_rms_after_m", r.gps_rms_after_m}, {"loop_edges", r.loop_edges},
          {"solves", r.solves},             {"iterations", r.iterations}, {"solve_ms", r.solve_ms},
          {"termination", r.termination}};
}

// LiDAR odometry over every scan (it needs them all to follow the drive), then the pose graph with
// the GPS fixes and the loop closures when asked; fills the report. Returns one pose per scan, and
// the odometry's own in `odometry` (before the graph; moved as a whole to start where the graph put
// the first scan).
Trajectory lidar_poses(const Dataset& ds, const GloamConfig& cfg, const std::vector<GpsEdge>& gps_edges,
                       std::optional<GeoPoint>& origin, nlohmann::json& report, const Tell& tell, Trajectory& odometry_out) {
  // Mean translation error against ground truth, when the dataset has it.
  auto mean_error = [&](const Trajectory& t) {
    double sum = 0;
    for (std::size_t i = 0; i < ds.size(); ++i) sum += (t.poses[i].translation() - ds.ground_truth.poses[i].translation()).norm();
    return sum / static_cast<double>(ds.size());
  };
  Trajectory placed;
  LoamConfig lc = cfg.loam;
  lc.deskew = deskews(cfg, ds);
  if (ds.meta.sensor.rate_hz > 0) lc.scan_period_s = 1.0 / ds.meta.sensor.rate_hz;
  LoamOdometry odometry(lc);
  // Without GPS: started at the first ground-truth pose when there is one, so that the map lies in
  // the dataset's world frame; otherwise in the first scan's frame, which has no geodetic origin.
  // With GPS the ground truth is not used at all: the odometry starts in the first scan's frame
  // and the fixes place it.
  const bool start_at_truth = ds.has_ground_truth() && !cfg.gps;
  if (start_at_truth)
    odometry.start(ds.ground_truth.poses[0]);
  else
    origin.reset();
  std::vector<double> ms;
  std::vector<Information6> information;
  std::size_t degenerate = 0;
  // The graph's keyframes are chosen by a causal rule, so their clouds for loop closure are kept
  // as the odometry runs (thinned; the other scans are not held).
  std::vector<std::vector<Eigen::Vector3f>> keyframe_clouds;
  Pose last_keyframe = Pose::Identity();
  ScanPrepConfig loop_prep = cfg.merge.scan;
  loop_prep.voxel_m = cfg.loop_voxel_m;
  const auto t_start = std::chrono::steady_clock::now();
  for (std::size_t i = 0; i < ds.size(); ++i) {
    Frame frame = ds.load_frame(i);
    Scan& scan = frame.scan;
    LoamFrame f = odometry.add(scan, frame.rings, ds.times[i]);
    placed.poses.push_back(f.pose);
    information.push_back(f.information);
    ms.push_back(f.ms);
    degenerate += f.degenerate;
    if (cfg.loops && (i == 0 || is_new_keyframe(last_keyframe, f.pose, cfg.graph))) {
      last_keyframe = f.pose;
      keyframe_clouds.push_back(to_points(prepare_scan(scan, {}, loop_prep)));
    }
    tell.progress("lidar odometry", i + 1, ds.size());
  }
  placed.times = ds.times;
  std::sort(ms.begin(), ms.end());
  tell.log(format_text("lidar odometry: %zu scans (deskew %s), median %.1f ms a scan, %zu degenerate%s", ds.size(),
                       lc.deskew ? "on" : "off", ms[ms.size() / 2], degenerate,
                       start_at_truth ? ", started at the first ground-truth pose" : ", in the first scan's frame"));
  report["odometry"] = {{"median_ms", ms[ms.size() / 2]}, {"degenerate", degenerate}, {"deskew", lc.deskew}};
  if (ds.has_ground_truth()) {
    // The odometry's error as if it had started at the first ground-truth pose.
    Trajectory from_truth = placed;
    if (!start_at_truth)
      for (Pose& p : from_truth.poses) p = ds.ground_truth.poses[0] * p;
    report["mean_error_before_m"] = mean_error(from_truth);
  }
  odometry_out = placed;
  if (cfg.gps || cfg.loops) {
    PoseGraph graph(placed.poses, information, gps_edges, ds.meta.vehicle.gps_lever_arm, cfg.graph);
    graph.optimize();
    if (cfg.gps) {
      // The GPS fixes set the world frame: the map keeps the dataset's origin even without ground truth.
      origin = ds.meta.origin;
      if (ds.has_ground_truth()) {
        Trajectory t = placed;
        t.poses = graph.poses();
        report["mean_error_gps_m"] = mean_error(t);
      }
    }
    if (cfg.loops) {
      const std::size_t keyframes = graph.keyframes().size();
      const LoopReport lr = close_loops(graph, keyframe_clouds, cfg.loop,
                                        [&](std::size_t done, std::size_t) { tell.progress("loop closure", done, keyframes); });
      tell.log(
          format_text("loop closure: %zu queries, proposed %zu by position and %zu by place; %zu accepted, %zu rejected; "
                      "loop residual median %.3f m -> %.3f m; %.1f s verifying",
                      lr.queries, lr.proposed_by_position, lr.proposed_by_descriptor, lr.accepted, lr.rejected,
                      lr.residual_before_m, lr.residual_after_m, lr.verify_ms / 1000.0));
      report["loops"] = loop_report_json(lr, graph);
    }
    placed.poses = graph.poses();
    // The odometry started in its own frame (the first scan's, with GPS): moved as a whole to start
    // where the graph put the first scan, so that it lies over the map.
    const Pose to_graph = placed.poses.front() * odometry_out.poses.front().inverse();
    for (Pose& p : odometry_out.poses) p = to_graph * p;
    const PoseGraphReport r = graph.report();
    tell.log(
        format_text("pose graph: %zu keyframes, %zu GPS edges (%zu outliers), %zu loop edges, GPS residual RMS %.3f m -> %.3f m, "
                    "%d solves, %d iterations, %.0f ms (%s)",
                    r.keyframes, r.gps_edges, r.gps_outliers, r.loop_edges, r.gps_rms_before_m, r.gps_rms_after_m, r.solves,
                    r.iterations, r.solve_ms, r.termination.c_str()));
    report["pose_graph"] = graph_report_json(r);
  }
  const double total_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  report["trajectory_ms_per_scan"] = 1000.0 * total_s / static_cast<double>(ds.size());
  tell.log(format_text("trajectory: %.1f ms a scan in all (odometry%s%s)", 1000.0 * total_s / static_cast<double>(ds.size()),
                       cfg.gps ? " + GPS" : "", cfg.loops ? " + loops" : ""));
  if (ds.has_ground_truth()) report["mean_error_after_m"] = mean_error(placed);
  return placed;
}

}  // namespace

void check_gloam_config(const GloamConfig& cfg) {
  if (cfg.gps && cfg.poses != PoseSource::Lidar) throw Error("--gps needs --poses lidar (it corrects the LiDAR odometry)");
  if (cfg.loops && cfg.poses != PoseSource::Lidar) throw Error("--loops needs --poses lidar (it corrects the LiDAR odometry)");
  if (!(cfg.merge.voxel_m > 0)) throw Error("the map's voxel (--voxel) must be above 0 m");
  if (cfg.merge.every < 1) throw Error("the scan step (--every) must be at least 1");
  if (!(cfg.merge.scan.min_range_m >= 0) || !(cfg.merge.scan.max_range_m > cfg.merge.scan.min_range_m))
    throw Error("the range crop needs 0 <= --min-range < --max-range");
  if (!(cfg.loop_voxel_m > 0)) throw Error("the loop-closure voxel must be above 0 m");
}

GloamResult build_gloam_map(const Dataset& ds, const GloamConfig& cfg, const GloamObserver& observer) {
  check_gloam_config(cfg);
  const Tell tell{observer};
  if (ds.size() == 0) throw Error(ds.dir + ": no scans");
  if (cfg.poses == PoseSource::GroundTruth && !ds.has_ground_truth())
    throw Error(ds.dir + ": --poses gt needs ground-truth poses (poses.txt or OXTS)");
  std::vector<GpsEdge> gps_edges;
  if (cfg.gps) {
    if (ds.gps.empty()) throw Error(ds.dir + ": --gps needs GPS fixes (gps.csv or OXTS), and the drive has none");
    gps_edges = gps_edges_from_dataset(ds);  // throws when the fixes cannot be placed in the world frame
    if (gps_edges.empty()) throw Error(ds.dir + ": no usable GPS fix (status other than none, within 0.05 s of a scan)");
  }
  GloamResult result;
  nlohmann::json report;
  report["dataset"] = ds.dir;
  report["scans"] = ds.size();
  report["poses"] = cfg.poses == PoseSource::GroundTruth ? "gt" : "lidar";
  result.origin = ds.meta.origin;
  if (cfg.poses == PoseSource::GroundTruth)
    result.poses = ds.ground_truth;
  else
    result.poses = lidar_poses(ds, cfg, gps_edges, result.origin, report, tell, result.odometry);
  result.poses.times = ds.times;
  if (!result.odometry.poses.empty()) result.odometry.times = ds.times;
  result.report_json = report.dump(2) + "\n";
  result.source = source_name(cfg);

  result.merged_scans = (ds.size() + cfg.merge.every - 1) / cfg.merge.every;
  result.voxel_m = cfg.merge.voxel_m;
  const std::size_t merged = result.merged_scans;
  MapBuildConfig merge = cfg.merge;
  // The merge corrects the sweep when told, or by itself for scans that carry their points' times
  // (the sensor says it sweeps). Not for KITTI raw by default: on drive 0005 the azimuth-timed
  // correction of map and scans did not make the localizer's error smaller (docs/benchmarks.md).
  merge.deskew = cfg.deskew == Deskew::On || (cfg.deskew == Deskew::Auto && ds.has_point_times());
  if (ds.meta.sensor.rate_hz > 0) merge.sweep_s = 1.0 / ds.meta.sensor.rate_hz;
  result.map = build_map_from_poses(ds, result.poses, merge,
                                    [&](std::size_t done, std::size_t) { tell.progress("merging scans", done, merged); });
  return result;
}

std::string write_gloam_outputs(const GloamResult& r, const std::string& map_pcd, const std::string& trajectory,
                                const std::string& report, const std::string& odometry) {
  std::string out;
  // KITTI, or TUM with the scan times when the name ends in .tum.
  auto write_poses = [](const std::string& path, const Trajectory& t) {
    const bool tum = path.size() > 4 && path.compare(path.size() - 4, 4, ".tum") == 0;
    write_trajectory(path, t, tum ? PoseFormat::Tum : PoseFormat::Kitti);
  };
  if (!odometry.empty()) {
    if (r.odometry.poses.empty()) throw Error("--odometry-out needs --poses lidar (with --poses gt no odometry runs)");
    write_poses(odometry, r.odometry);
    out += format_text("wrote %s: %zu LiDAR poses (lidar odometry, before any pose graph), one per scan\n", odometry.c_str(),
                       r.odometry.poses.size());
  }
  if (!report.empty()) {
    std::ofstream f(report);
    f << r.report_json;
    if (!f) throw Error(report + ": cannot write the report");
    out += "wrote " + report + "\n";
  }
  if (!trajectory.empty()) {
    write_poses(trajectory, r.poses);
    out += format_text("wrote %s: %zu LiDAR poses (%s), one per scan\n", trajectory.c_str(), r.poses.size(), r.source.c_str());
  }
  write_pcd(map_pcd, r.map.points, r.map.intensity, r.origin);
  out += format_text("wrote %s: %zu points from %zu scans at %.2f m voxels\n", map_pcd.c_str(), r.map.points.size(),
                     r.merged_scans, r.voxel_m);
  if (!r.map.places.empty()) {
    const std::string path = places_path(map_pcd);
    const std::string bytes = r.map.places.encode();
    const std::string partial = path + ".partial";
    {
      std::ofstream f(partial, std::ios::binary | std::ios::trunc);
      f.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
      if (!f) throw Error(partial + ": cannot write the places");
    }
    if (std::rename(partial.c_str(), path.c_str()) != 0) throw Error(path + ": cannot write the places (rename failed)");
    out += format_text("wrote %s: %zu places for relocalization (pl-map tile stores them with the map)\n", path.c_str(),
                       r.map.places.places().size());
  }
  return out;
}

}  // namespace pl::maps
