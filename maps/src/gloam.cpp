#include "pl/maps/gloam.hpp"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <vector>

#include <Eigen/Geometry>

#include <nlohmann/json.hpp>

#include "pl/common/cloud_io.hpp"
#include "pl/common/error.hpp"
#include "pl/common/read_ahead.hpp"
#include "pl/common/scan.hpp"
#include "pl/common/text.hpp"
#include "pl/maps/drive_record.hpp"
#include "pl/maps/import.hpp"
#include "pl/registration/normals.hpp"
#include "pl/registration/place_index.hpp"

namespace pl::maps {

namespace {

// Real recordings (no meta.json: KITTI) sweep while the car moves, and so do drives whose points carry
// their own times (point_times/: pl-sim's swept scans, a driver's per-point times).
bool deskews(const GloamConfig& cfg, const Dataset& ds) {
  return cfg.deskew == Deskew::On || (cfg.deskew == Deskew::Auto && (!ds.has_meta_file || ds.has_point_times()));
}

// The merge corrects the sweep when told, or by itself for scans that carry their points' times
// (the sensor says it sweeps). Not for KITTI raw by default: on drive 0005 the azimuth-timed
// correction of map and scans did not make the localizer's error smaller (docs/benchmarks.md).
bool merge_deskews(const GloamConfig& cfg, const Dataset& ds) {
  return cfg.deskew == Deskew::On || (cfg.deskew == Deskew::Auto && ds.has_point_times());
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
                     {"query_drive", graph.drive_of(l.query) + 1},
                     {"match_drive", graph.drive_of(l.match) + 1},
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

// One drive's LiDAR odometry over every scan (it needs them all to follow the drive), started at
// `start`, with the clouds of the graph's keyframes when loops are asked for (the keyframe rule is
// causal, so they are kept as the odometry runs; the other scans are not held). Those clouds are
// corrected for the sweep as the merge corrects the drive's scans: uncorrected, two drives through a
// place in opposite directions see it skewed opposite ways, and their loops were 0.2-0.3 m off.
struct DriveOdometry {
  PoseList poses;
  std::vector<Information6> information;
  std::vector<std::vector<Eigen::Vector3f>> keyframe_clouds;
  double median_ms = 0;
  std::size_t degenerate = 0;
  bool deskew = false;
};

// The loop-closure cloud of keyframe `i` (`frame`), corrected for the sweep by the motion from scan
// a to scan b at constant velocity when the merge corrects this drive's scans.
std::vector<Eigen::Vector3f> keyframe_cloud(Frame& frame, const Dataset& ds, const PoseList& poses, std::size_t a, std::size_t b,
                                            const GloamConfig& cfg) {
  const double sweep_s = ds.meta.sensor.rate_hz > 0 ? 1.0 / ds.meta.sensor.rate_hz : cfg.merge.sweep_s;
  const double dt = b > a ? ds.times[b] - ds.times[a] : 0.0;
  if (merge_deskews(cfg, ds) && dt > 0)
    compensate_sweep(frame.scan, frame.times, scale_motion(poses[a].inverse() * poses[b], sweep_s / dt), sweep_s);
  ScanPrepConfig loop_prep = cfg.merge.scan;
  loop_prep.voxel_m = cfg.loop_voxel_m;
  return to_points(prepare_scan(frame.scan, {}, loop_prep));
}

DriveOdometry run_odometry(const Dataset& ds, const GloamConfig& cfg, const Pose& start, const std::string& stage, const Tell& tell) {
  DriveOdometry out;
  LoamConfig lc = cfg.loam;
  lc.deskew = out.deskew = deskews(cfg, ds);
  if (ds.meta.sensor.rate_hz > 0) lc.scan_period_s = 1.0 / ds.meta.sensor.rate_hz;
  LoamOdometry odometry(lc);
  odometry.start(start);
  std::vector<double> ms;
  Pose last_keyframe = Pose::Identity();
  // The next scan is read and its features extracted on the second core while this one registers.
  struct Loaded {
    Frame frame;
    LoamFeatures features;
    double extract_ms = 0;
  };
  ReadAhead<Loaded> scans(ds.size(), [&ds, &lc](std::size_t i) {
    Loaded l{ds.load_frame(i), {}};
    const auto t0 = std::chrono::steady_clock::now();
    l.features = extract_loam_features(l.frame.scan, l.frame.rings, lc);
    l.extract_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    return l;
  });
  Frame first;
  for (std::size_t i = 0; i < ds.size(); ++i) {
    Loaded loaded = scans.next();
    Frame& frame = loaded.frame;
    LoamFrame f = odometry.add(std::move(loaded.features), ds.times[i]);
    out.poses.push_back(f.pose);
    out.information.push_back(f.information);
    ms.push_back(f.ms + loaded.extract_ms);  // the scan's whole odometry time, wherever it ran
    out.degenerate += f.degenerate;
    // A keyframe's cloud, corrected by the motion since the scan before; the first scan's by the
    // motion to the second, once that is known.
    if (cfg.loops && i == 1) out.keyframe_clouds.push_back(keyframe_cloud(first, ds, out.poses, 0, 1, cfg));
    if (cfg.loops && i == 0) {
      first = std::move(frame);
      if (ds.size() == 1) out.keyframe_clouds.push_back(keyframe_cloud(first, ds, out.poses, 0, 0, cfg));
    } else if (cfg.loops && is_new_keyframe(last_keyframe, f.pose, cfg.graph)) {
      out.keyframe_clouds.push_back(keyframe_cloud(frame, ds, out.poses, i - 1, i, cfg));
    }
    if (i == 0 || is_new_keyframe(last_keyframe, f.pose, cfg.graph)) last_keyframe = f.pose;
    tell.progress(stage, i + 1, ds.size());
  }
  std::sort(ms.begin(), ms.end());
  out.median_ms = ms.empty() ? 0.0 : ms[ms.size() / 2];
  return out;
}

// The loop-closure clouds of a base map's drive at the graph's keyframes: read again and corrected as
// run_odometry keeps them for a drive it runs.
std::vector<std::vector<Eigen::Vector3f>> fixed_keyframe_clouds(const Dataset& ds, const PoseList& poses,
                                                                const std::vector<std::size_t>& keyframes, const GloamConfig& cfg) {
  std::vector<std::vector<Eigen::Vector3f>> clouds;
  for (std::size_t i : keyframes) {
    Frame frame = ds.load_frame(i);
    const std::size_t a = i > 0 ? i - 1 : 0, b = i > 0 ? i : std::min<std::size_t>(1, ds.size() - 1);
    clouds.push_back(keyframe_cloud(frame, ds, poses, a, b, cfg));
  }
  return clouds;
}

// A drive's world frame in the map's (the first drive's): both datasets' projections of the same
// geodetic points, fitted rigidly. None when only one of them has a geodetic reference; identity
// when neither has one (taken to share the frame).
std::optional<Pose> frame_in_map(const Dataset& ds, const Dataset& map) {
  using Kind = WorldProjection::Kind;
  if (ds.projection.kind == Kind::None && map.projection.kind == Kind::None) return Pose::Identity();
  if (ds.projection.kind == Kind::None || map.projection.kind == Kind::None) return std::nullopt;
  const EnuFrame around(ds.projection.origin);
  Eigen::Matrix<double, 3, Eigen::Dynamic> from(3, 18), to(3, 18);
  int c = 0;
  for (double x : {-200.0, 0.0, 200.0})
    for (double y : {-200.0, 0.0, 200.0})
      for (double z : {0.0, 20.0}) {
        const GeoPoint g = around.to_geodetic(Eigen::Vector3d(x, y, z));
        from.col(c) = ds.to_world(g);
        to.col(c) = map.to_world(g);
        ++c;
      }
  Pose t = Pose::Identity();
  t.matrix() = Eigen::umeyama(from, to, false);
  return t;
}

double mean_error(const PoseList& poses, const PoseList& truth) {
  double sum = 0;
  for (std::size_t i = 0; i < truth.size(); ++i) sum += (poses[i].translation() - truth[i].translation()).norm();
  return truth.empty() ? 0.0 : sum / static_cast<double>(truth.size());
}

// The drives' LiDAR odometry, then one pose graph over them with the GPS fixes and the loop closures
// when asked; fills the report. Returns each drive's poses in the map frame, and in `odometry` each
// drive's odometry before the graph (moved as a whole to start where the graph put its first scan).
std::vector<Trajectory> lidar_poses(const std::vector<const Dataset*>& drives, const GloamConfig& cfg,
                                    const std::vector<std::vector<GpsEdge>>& gps, const std::vector<PoseList>& truth,
                                    const GloamBase& base, std::optional<GeoPoint>& origin, nlohmann::json& report,
                                    const Tell& tell, std::vector<Trajectory>& odometry_out) {
  const std::size_t n = drives.size(), nb = base.poses.size();
  // Without GPS the first drive starts at its first ground-truth pose when there is one, so that the
  // map lies in the dataset's world frame; otherwise in its first scan's frame, which has no geodetic
  // origin. With GPS the ground truth is not used at all. Other drives start in their own frame: the
  // fixes or the loops place them. A base map's drives hold its frame and are not run again.
  const bool start_at_truth = nb == 0 && !truth[0].empty() && !cfg.gps;
  if (nb == 0 && !start_at_truth) origin.reset();
  std::vector<DriveOdometry> runs(n);
  const auto t_start = std::chrono::steady_clock::now();
  std::size_t scans = 0;
  for (std::size_t d = 0; d < n; ++d) {
    const Dataset& ds = *drives[d];
    if (d < nb) {
      runs[d].poses = base.poses[d].poses;
      report["drives"][d]["fixed"] = true;
      continue;
    }
    const std::string stage = n > 1 ? format_text("lidar odometry, drive %zu of %zu", d + 1, n) : "lidar odometry";
    runs[d] = run_odometry(ds, cfg, d == 0 && start_at_truth ? truth[0][0] : Pose::Identity(), stage, tell);
    scans += ds.size();
    tell.log(format_text("%s: %zu scans (deskew %s), median %.1f ms a scan, %zu degenerate%s", stage.c_str(), ds.size(),
                         runs[d].deskew ? "on" : "off", runs[d].median_ms, runs[d].degenerate,
                         d == 0 && start_at_truth ? ", started at the first ground-truth pose" : ", in the first scan's frame"));
    nlohmann::json& dj = report["drives"][d];
    dj["odometry"] = {{"median_ms", runs[d].median_ms}, {"degenerate", runs[d].degenerate}, {"deskew", runs[d].deskew}};
    if (!truth[d].empty()) {
      // The odometry's error as if it had started at the first ground-truth pose.
      Trajectory from_truth;
      from_truth.poses = runs[d].poses;
      const Pose to_truth = truth[d][0] * runs[d].poses[0].inverse();
      for (Pose& p : from_truth.poses) p = to_truth * p;
      dj["mean_error_before_m"] = mean_error(from_truth.poses, truth[d]);
    }
  }
  report["odometry"] = {{"median_ms", runs[nb].median_ms}, {"degenerate", runs[nb].degenerate}, {"deskew", runs[nb].deskew}};
  std::vector<Trajectory> placed(n);
  odometry_out.assign(n, {});
  for (std::size_t d = 0; d < n; ++d) {
    placed[d].poses = runs[d].poses;
    if (d >= nb) odometry_out[d].poses = runs[d].poses;
  }
  if (cfg.gps || cfg.loops) {
    std::vector<GraphDrive> chains(n);
    for (std::size_t d = 0; d < n; ++d) {
      chains[d].odometry = runs[d].poses;
      chains[d].information = runs[d].information;
      chains[d].gps = gps[d];
      chains[d].lever_arm = drives[d]->meta.vehicle.gps_lever_arm;
      chains[d].fixed = d < nb;
    }
    PoseGraph graph(chains, cfg.graph);
    graph.optimize();
    if (cfg.gps) {
      if (nb == 0) origin = drives[0]->meta.origin;  // the fixes set the world frame: the map keeps the first dataset's origin
      for (std::size_t d = nb; d < n; ++d)
        if (!truth[d].empty()) report["drives"][d]["mean_error_gps_m"] = mean_error(graph.poses(d), truth[d]);
    }
    if (cfg.loops) {
      std::vector<std::vector<Eigen::Vector3f>> clouds;
      for (std::size_t d = 0; d < n; ++d) {
        if (d < nb) {
          const auto begin = graph.keyframes().begin();
          const std::vector<std::size_t> keys(begin + static_cast<std::ptrdiff_t>(graph.first_keyframe(d)),
                                              begin + static_cast<std::ptrdiff_t>(d + 1 < n ? graph.first_keyframe(d + 1)
                                                                                            : graph.keyframes().size()));
          runs[d].keyframe_clouds = fixed_keyframe_clouds(*drives[d], runs[d].poses, keys, cfg);
        }
        for (auto& c : runs[d].keyframe_clouds) clouds.push_back(std::move(c));
      }
      const std::size_t keyframes = graph.keyframes().size();
      const LoopReport lr = close_loops(graph, clouds, cfg.loop,
                                        [&](std::size_t done, std::size_t) { tell.progress("loop closure", done, keyframes); });
      tell.log(
          format_text("loop closure: %zu queries, proposed %zu by position and %zu by place; %zu accepted, %zu rejected; "
                      "loop residual median %.3f m -> %.3f m; %.1f s verifying",
                      lr.queries, lr.proposed_by_position, lr.proposed_by_descriptor, lr.accepted, lr.rejected,
                      lr.residual_before_m, lr.residual_after_m, lr.verify_ms / 1000.0));
      report["loops"] = loop_report_json(lr, graph);
      // Loops from each drive to each drive (itself included), accepted ones.
      for (std::size_t d = 0; d < n; ++d) report["drives"][d]["loops_to"] = std::vector<std::size_t>(n, 0);
      for (const LoopRecord& l : lr.loops) {
        if (!l.accepted) continue;
        const std::size_t a = graph.drive_of(l.query), b = graph.drive_of(l.match);
        report["drives"][a]["loops_to"][b] = report["drives"][a]["loops_to"][b].get<std::size_t>() + 1;
        if (a != b) report["drives"][b]["loops_to"][a] = report["drives"][b]["loops_to"][a].get<std::size_t>() + 1;
      }
    }
    for (std::size_t d = 0; d < n; ++d)
      if (!graph.joined(d))
        throw Error(drives[d]->dir + ": nothing joins this drive to the map: it has no GPS fixes" +
                    std::string(cfg.gps ? "" : " in use (--gps)") + " and no loop closure " +
                    (cfg.loops ? "was found to the other drives" : "was looked for (--loops)") +
                    "; build it with a drive that passes the same places, or with its GPS");
    const PoseGraphReport r = graph.report();
    for (std::size_t d = nb; d < n; ++d) {
      placed[d].poses = graph.poses(d);
      // The odometry started in its own frame: moved as a whole to start where the graph put the first scan.
      const Pose to_graph = placed[d].poses.front() * odometry_out[d].poses.front().inverse();
      for (Pose& p : odometry_out[d].poses) p = to_graph * p;
    }
    for (std::size_t d = 0; d < n; ++d) {
      const PoseGraphDriveReport& dr = r.drives[d];
      nlohmann::json& dj = report["drives"][d];
      dj["keyframes"] = dr.keyframes;
      dj["gps_edges"] = dr.gps_edges;
      dj["gps_outliers"] = dr.gps_outliers;
      dj["gps_rms_before_m"] = dr.gps_rms_before_m;
      dj["gps_rms_after_m"] = dr.gps_rms_after_m;
    }
    tell.log(
        format_text("pose graph: %zu keyframes, %zu GPS edges (%zu outliers), %zu loop edges, GPS residual RMS %.3f m -> %.3f m, "
                    "%d solves, %d iterations, %.0f ms (%s)",
                    r.keyframes, r.gps_edges, r.gps_outliers, r.loop_edges, r.gps_rms_before_m, r.gps_rms_after_m, r.solves,
                    r.iterations, r.solve_ms, r.termination.c_str()));
    report["pose_graph"] = graph_report_json(r);
  }
  const double total_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  report["trajectory_ms_per_scan"] = 1000.0 * total_s / static_cast<double>(scans);
  tell.log(format_text("trajectory: %.1f ms a scan in all (odometry%s%s)", 1000.0 * total_s / static_cast<double>(scans),
                       cfg.gps ? " + GPS" : "", cfg.loops ? " + loops" : ""));
  return placed;
}

// Which drives each tile's points came from: per tile (pl-map tile's default grid), its points and
// the points each drive returned from.
nlohmann::json tile_sources(const MapCloud& map, std::size_t drives) {
  const TileGrid grid(ImportConfig{}.tile_size_m);
  std::map<TileKey, std::pair<std::size_t, std::vector<std::size_t>>> tiles;
  for (std::size_t i = 0; i < map.points.size(); ++i) {
    auto& t = tiles[grid.key_of(map.points[i].x(), map.points[i].y())];
    if (t.second.empty()) t.second.assign(drives, 0);
    ++t.first;
    for (std::size_t d = 0; d < drives && !map.drives.empty(); ++d)
      if (map.drives[i] >> d & 1u) ++t.second[d];
  }
  nlohmann::json out = nlohmann::json::array();
  for (const auto& [key, t] : tiles) out.push_back({{"tx", key.tx}, {"ty", key.ty}, {"points", t.first}, {"points_by_drive", t.second}});
  return out;
}

// The merged map's points of things that moved, removed by the rays of every merged scan.
nlohmann::json remove_moving(MapCloud& map, const std::vector<PlacedDrive>& drives, const GloamConfig& cfg, const Tell& tell) {
  const auto t0 = std::chrono::steady_clock::now();
  const std::vector<Eigen::Vector3f> normals = registration::estimate_normals(map.points, registration::map_normal_radius(cfg.merge.voxel_m));
  FreeSpaceFilter filter(map.points, normals, map.seen, cfg.merge.voxel_m, cfg.free_space);
  std::size_t scans = 0, done = 0, last_drive = SIZE_MAX;
  for (const PlacedDrive& d : drives) scans += (d.dataset->size() + cfg.merge.every - 1) / cfg.merge.every;
  for_each_merged_scan(drives, cfg.merge, [&](std::size_t drive, std::size_t, const Pose& sensor, const Scan& kept) {
    if (drive != last_drive) filter.begin_drive(drives[drive].dataset->meta.sensor.vertical_angles_deg), last_drive = drive;
    filter.add_scan(sensor, to_points(kept));
    tell.progress("removing moving things", ++done, scans);
  });
  const std::vector<bool> moving = filter.moving();
  std::vector<bool> keep(moving.size());
  for (std::size_t i = 0; i < moving.size(); ++i) keep[i] = !moving[i];
  map.keep_only(keep);
  const FreeSpaceReport r = filter.report();
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  tell.log(format_text("moving things: %zu of %zu points removed (%zu crossed by the rays of other scans, %zu in the vehicle's "
                       "corridor), %zu rays from %zu scans, %.1f s",
                       r.removed_by_rays + r.removed_by_corridor, r.points, r.removed_by_rays, r.removed_by_corridor, r.rays,
                       r.walked, s));
  return {{"points", r.points},       {"removed_by_rays", r.removed_by_rays}, {"removed_by_corridor", r.removed_by_corridor},
          {"rays", r.rays},           {"scans_walked", r.walked},             {"crossed", r.passed},
          {"seconds", s}};
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

GloamResult build_gloam_map(const std::vector<const Dataset*>& drives, const GloamConfig& cfg, const GloamObserver& observer,
                            const GloamBase& base) {
  check_gloam_config(cfg);
  const Tell tell{observer};
  const std::size_t n = drives.size(), nb = base.poses.size();
  if (n <= nb) throw Error("a map needs at least one drive (--dataset)" + std::string(nb > 0 ? " besides the base map's" : ""));
  if (n > 64) throw Error(format_text("a map is built from at most 64 drives, not %zu", n));
  for (std::size_t d = 0; d < nb; ++d) {
    if (base.poses[d].size() != drives[d]->size() || base.poses[d].times != drives[d]->times)
      throw Error(format_text("%s: the base map's drive %zu had %zu scans at other times than the %zu it has now: the dataset "
                              "changed since the base map was built; build the whole map anew without --base-map",
                              drives[d]->dir.c_str(), d + 1, base.poses[d].size(), drives[d]->size()));
    if (d < base.deskew.size() && base.deskew[d] != merge_deskews(cfg, *drives[d]))
      throw Error(format_text("%s: the base map merged this drive with motion compensation %s: give the --deskew it was built "
                              "with (auto, on or off) so that its tiles keep their points",
                              drives[d]->dir.c_str(), base.deskew[d] ? "on" : "off"));
  }
  if (nb > 0 && !base.origin && (cfg.gps || cfg.poses == PoseSource::GroundTruth))
    throw Error("the base map has no geodetic origin (it was built from LiDAR odometry alone, in its first scan's frame): "
                "a new drive's " + std::string(cfg.gps ? "GPS fixes" : "ground truth") + " cannot be placed on it; add the drive "
                "with --poses lidar --loops");
  if (n > 1 && cfg.poses == PoseSource::Lidar && !cfg.gps && !cfg.loops)
    throw Error("several drives with --poses lidar need --gps or --loops: nothing else places the " +
                std::string(nb > 0 ? "new drive (" + drives[nb]->dir + ") on the base map's" : "second drive (" + drives[1]->dir + ") on the first"));
  // Each drive's world frame in the map's; its ground truth and fixes brought into it.
  std::vector<std::optional<Pose>> frames(n);
  std::vector<PoseList> truth(n);
  std::vector<std::vector<GpsEdge>> gps(n);
  for (std::size_t d = 0; d < n; ++d) {
    const Dataset& ds = *drives[d];
    if (ds.size() == 0) throw Error(ds.dir + ": no scans");
    frames[d] = frame_in_map(ds, *drives[0]);
    if (cfg.poses == PoseSource::GroundTruth && d >= nb) {
      if (!ds.has_ground_truth()) throw Error(ds.dir + ": --poses gt needs ground-truth poses (poses.txt or OXTS)");
      if (!frames[d])
        throw Error(ds.dir + ": its ground truth cannot be placed in the map's frame (" + drives[0]->dir +
                    "'s): one of the two has no geodetic origin; add \"origin\" {lat, lon, alt} to its meta.json");
    }
    if (ds.has_ground_truth() && frames[d])
      for (const Pose& p : ds.ground_truth.poses) truth[d].push_back(*frames[d] * p);
    if (cfg.gps && d >= nb) {
      if (ds.gps.empty() && !(cfg.loops && n > 1))
        throw Error(ds.dir + ": --gps needs GPS fixes (gps.csv or OXTS), and the drive has none" +
                    std::string(n > 1 ? " (with --loops, a drive without GPS is joined by its loops)" : ""));
      if (!ds.gps.empty()) {
        if (!frames[d]) throw Error(ds.dir + ": its GPS fixes cannot be placed in the map's frame: " + drives[0]->dir + " has no geodetic origin");
        gps[d] = gps_edges_from_dataset(ds);  // throws when the fixes cannot be placed in the world frame
        for (GpsEdge& e : gps[d]) e.antenna_world = *frames[d] * e.antenna_world;
        if (gps[d].empty()) throw Error(ds.dir + ": no usable GPS fix (status other than none, within 0.05 s of a scan)");
      }
    }
  }
  GloamResult result;
  nlohmann::json report;
  report["dataset"] = drives[0]->dir;
  std::size_t scans = 0;
  for (const Dataset* ds : drives) scans += ds->size();
  report["scans"] = scans;
  report["poses"] = cfg.poses == PoseSource::GroundTruth ? "gt" : "lidar";
  report["drives"] = nlohmann::json::array();
  for (const Dataset* ds : drives) report["drives"].push_back({{"dataset", ds->dir}, {"scans", ds->size()}});
  result.origin = nb > 0 ? base.origin : drives[0]->meta.origin;
  result.base_drives = nb;
  std::vector<Trajectory> poses(n), odometry(n);
  if (cfg.poses == PoseSource::GroundTruth)
    for (std::size_t d = 0; d < n; ++d) poses[d].poses = d < nb ? base.poses[d].poses : truth[d];
  else
    poses = lidar_poses(drives, cfg, gps, truth, base, result.origin, report, tell, odometry);
  for (std::size_t d = 0; d < nb; ++d) report["drives"][d]["fixed"] = true;
  // Errors against ground truth, per drive and over every scan.
  double before = 0, after = 0;
  std::size_t with_truth = 0;
  for (std::size_t d = 0; d < n; ++d) {
    poses[d].times = drives[d]->times;
    if (!odometry[d].poses.empty()) odometry[d].times = drives[d]->times;
    if (truth[d].empty() || cfg.poses == PoseSource::GroundTruth || d < nb) continue;
    const double e = mean_error(poses[d].poses, truth[d]);
    report["drives"][d]["mean_error_after_m"] = e;
    after += e * static_cast<double>(truth[d].size());
    before += report["drives"][d].value("mean_error_before_m", 0.0) * static_cast<double>(truth[d].size());
    with_truth += truth[d].size();
  }
  if (with_truth > 0) {
    report["mean_error_before_m"] = before / static_cast<double>(with_truth);
    report["mean_error_after_m"] = after / static_cast<double>(with_truth);
    if (n == 1 && report["drives"][0].contains("mean_error_gps_m")) report["mean_error_gps_m"] = report["drives"][0]["mean_error_gps_m"];
  }
  result.source = source_name(cfg);

  std::vector<PlacedDrive> placed(n);
  result.merged_scans = 0;
  for (std::size_t d = 0; d < n; ++d) {
    const Dataset& ds = *drives[d];
    placed[d] = {&ds, &poses[d], merge_deskews(cfg, ds),
                 ds.meta.sensor.rate_hz > 0 ? 1.0 / ds.meta.sensor.rate_hz : cfg.merge.sweep_s};
    result.merged_scans += (ds.size() + cfg.merge.every - 1) / cfg.merge.every;
  }
  result.voxel_m = cfg.merge.voxel_m;
  result.merge = cfg.merge;
  const std::size_t merged = result.merged_scans;
  result.map = build_map_from_drives(placed, cfg.merge, [&](std::size_t done, std::size_t) { tell.progress("merging scans", done, merged); });
  if (cfg.remove_moving) report["moving"] = remove_moving(result.map, placed, cfg, tell);
  if (n > 1) report["tiles"] = tile_sources(result.map, n);
  result.report_json = report.dump(2) + "\n";
  for (std::size_t d = 0; d < n; ++d)
    result.drives.push_back({drives[d]->dir, std::move(poses[d]), std::move(odometry[d]), placed[d].deskew, placed[d].sweep_s});
  return result;
}

GloamResult build_gloam_map(const Dataset& ds, const GloamConfig& cfg, const GloamObserver& observer) {
  return build_gloam_map(std::vector<const Dataset*>{&ds}, cfg, observer);
}

void check_gloam_outputs(const GloamOutputs& o, std::size_t drives) {
  auto per_drive = [&](const std::vector<std::string>& paths, const char* option) {
    if (!paths.empty() && paths.size() != drives)
      throw Error(format_text("%s: %zu given for %zu drives (one per --dataset, in the same order)", option, paths.size(), drives));
  };
  per_drive(o.trajectories, "--traj-out");
  per_drive(o.odometry, "--odometry-out");
}

namespace {

DriveRecord drive_record_of(const GloamResult& r) {
  DriveRecord record;
  record.origin = r.origin;
  record.merge = r.merge;
  for (const GloamDrive& d : r.drives) {
    std::error_code ec;
    const std::filesystem::path path = std::filesystem::absolute(d.dataset, ec);
    record.drives.push_back({ec ? d.dataset : path.lexically_normal().string(), d.poses, d.merge_deskew, d.sweep_s});
  }
  return record;
}

}  // namespace

std::string write_gloam_outputs(const GloamResult& r, const GloamOutputs& o) {
  std::string out;
  const std::size_t nb = r.base_drives, n = r.drives.size() - nb;  // the drives written: those after the base map's
  check_gloam_outputs(o, n);
  // KITTI, or TUM with the scan times when the name ends in .tum.
  auto write_poses = [](const std::string& path, const Trajectory& t) {
    const bool tum = path.size() > 4 && path.compare(path.size() - 4, 4, ".tum") == 0;
    write_trajectory(path, t, tum ? PoseFormat::Tum : PoseFormat::Kitti);
  };
  for (std::size_t d = 0; d < o.odometry.size(); ++d) {
    const GloamDrive& drive = r.drives[nb + d];
    if (drive.odometry.poses.empty()) throw Error("--odometry-out needs --poses lidar (with --poses gt no odometry runs)");
    write_poses(o.odometry[d], drive.odometry);
    out += format_text("wrote %s: %zu LiDAR poses (lidar odometry, before any pose graph), one per scan\n", o.odometry[d].c_str(),
                       drive.odometry.poses.size());
  }
  if (!o.report.empty()) {
    std::ofstream f(o.report);
    f << r.report_json;
    if (!f) throw Error(o.report + ": cannot write the report");
    out += "wrote " + o.report + "\n";
  }
  for (std::size_t d = 0; d < o.trajectories.size(); ++d) {
    write_poses(o.trajectories[d], r.drives[nb + d].poses);
    out += format_text("wrote %s: %zu LiDAR poses (%s), one per scan\n", o.trajectories[d].c_str(), r.drives[nb + d].poses.size(),
                       r.source.c_str());
  }
  const std::string& map_pcd = o.map_pcd;
  write_pcd(map_pcd, r.map.points, r.map.intensity, r.origin);
  const std::size_t all = r.drives.size();
  out += format_text("wrote %s: %zu points from %zu scans%s at %.2f m voxels\n", map_pcd.c_str(), r.map.points.size(),
                     r.merged_scans, all > 1 ? format_text(" of %zu drives", all).c_str() : "", r.voxel_m);
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
  const std::string record = drive_record_path(map_pcd);
  write_drive_record(record, drive_record_of(r));
  out += format_text("wrote %s: the map's %zu drives and their poses (pl-map build --base-map %s adds drives to this map)\n",
                     record.c_str(), all, map_pcd.c_str());
  return out;
}

}  // namespace pl::maps
