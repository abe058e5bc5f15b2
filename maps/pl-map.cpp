// pl-map: build maps from drives, cut them into Draco tiles in a versioned SQLite store, publish.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <optional>
#include <set>

#include <nlohmann/json.hpp>

#include "pl/common/cli.hpp"
#include "pl/common/cloud_io.hpp"
#include "pl/common/error.hpp"
#include "pl/common/progress.hpp"
#include "pl/common/stats.hpp"
#include "pl/common/text.hpp"
#include "pl/maps/loam.hpp"
#include "pl/maps/loop_closure.hpp"
#include "pl/maps/map_builder.hpp"
#include "pl/registration/normals.hpp"
#include "pl/maps/pose_graph.hpp"
#include "pl/maps/push.hpp"
#include "pl/schema/store.hpp"

namespace {

const char* kUsage =
    "usage: pl-map COMMAND [options]\n"
    "\n"
    "  build    --dataset DIR --out map.pcd [--poses gt|lidar] [--gps] [--loops] [--traj-out poses.txt] [--report FILE.json]\n"
    "           [--deskew auto|on|off] [--voxel 0.2] [--every N] [--max-range 80]\n"
    "           merge a drive's scans at their ground-truth poses (gt) or at the poses of LiDAR odometry\n"
    "           (lidar; without --gps started at the first ground-truth pose when there is one, with --gps the\n"
    "           ground truth is not used; deskew auto: on\n"
    "           for recordings without meta.json) into a voxelized map (PCD in the dataset's world\n"
    "           frame, its geodetic origin recorded in the header); --traj-out writes the LiDAR pose of\n"
    "           every scan, line for line with the dataset (KITTI format; TUM with the scan times when FILE\n"
    "           ends in .tum); --gps (with --poses lidar): a pose graph\n"
    "           of keyframes over the odometry with the drive's GPS fixes (robust to multipath) sets the poses;\n"
    "           --loops (with --poses lidar): loop closures found by position and by a place descriptor, verified\n"
    "           by ICP, join the graph (re-solved on each); --report writes JSON: keyframes, GPS edges and outliers,\n"
    "           GPS residuals, loops proposed/accepted/rejected (and why), the mean translation error against\n"
    "           ground truth (when there is one) before and after the graph, times\n"
    "  tile     --cloud FILE(.pcd|.ply|.bin) --db maps.sqlite --map NAME [--origin LAT,LON,ALT]\n"
    "           [--voxel 0.2] [--tile-size 20] [--normal-radius 0.6] [--max-error 0.005] [--note TEXT]\n"
    "           voxelize, estimate normals, cut into tiles, Draco-encode them and write a new staged\n"
    "           version (the map is created on first use; unchanged tiles share their stored bytes)\n"
    "  publish  --db FILE --map NAME --version N      make a staged version current (one transaction)\n"
    "  rollback --db FILE --map NAME                  make the previously published version current again\n"
    "  list     --db FILE [--map NAME]                maps, or the versions of one map\n"
    "  info     --db FILE --map NAME [--version N]    a map's manifest (default: the current version)\n"
    "  diff     --db FILE --map NAME --from A --to B  tiles added, removed and changed between versions\n"
    "  push     --db FILE --map NAME --version N --server URL --token T\n"
    "           upload a local version to a server (only the tiles it lacks), then publish it there\n";

std::string mb(double bytes) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.2f MB", bytes / 1e6);
  return buf;
}

int cmd_build(const pl::Args& a) {
  std::string dir = a.require("--dataset", "DIR (the drive to build the map from)");
  std::string poses = a.get_or("--poses", "gt");
  std::string out = a.require("--out", "FILE.pcd (where to write the map)");
  auto traj_out = a.get("--traj-out");
  const bool use_gps = a.has("--gps");
  const bool use_loops = a.has("--loops");
  auto report_path = a.get("--report");
  std::string deskew = a.get_or("--deskew", "auto");
  pl::maps::MapBuildConfig cfg;
  cfg.voxel_m = a.get_double("--voxel", cfg.voxel_m);
  cfg.every = static_cast<std::size_t>(std::max<long long>(1, a.get_int("--every", 1)));
  cfg.scan.min_range_m = a.get_double("--min-range", 2.0);
  cfg.scan.max_range_m = a.get_double("--max-range", 80.0);
  a.finish();
  if (poses != "gt" && poses != "lidar")
    throw pl::Error("--poses takes gt (the dataset's ground truth) or lidar (LiDAR odometry alone), not " + poses);
  if (deskew != "auto" && deskew != "on" && deskew != "off") throw pl::Error("--deskew takes auto, on or off, not " + deskew);
  if (use_gps && poses != "lidar") throw pl::Error("--gps needs --poses lidar (it corrects the LiDAR odometry)");
  if (use_loops && poses != "lidar") throw pl::Error("--loops needs --poses lidar (it corrects the LiDAR odometry)");
  pl::Dataset ds = pl::open_dataset(dir);
  if (ds.size() == 0) throw pl::Error(ds.dir + ": no scans");
  std::vector<pl::maps::GpsEdge> gps_edges;
  if (use_gps) {
    if (ds.gps.empty()) throw pl::Error(ds.dir + ": --gps needs GPS fixes (gps.csv or OXTS), and the drive has none");
    gps_edges = pl::maps::gps_edges_from_dataset(ds);  // throws when the fixes cannot be placed in the world frame
    if (gps_edges.empty()) throw pl::Error(ds.dir + ": no usable GPS fix (status other than none, within 0.05 s of a scan)");
  }
  nlohmann::json report;
  report["dataset"] = ds.dir;
  report["scans"] = ds.size();
  report["poses"] = poses;
  // Mean translation error against ground truth, when the dataset has it.
  auto mean_error = [&](const pl::Trajectory& t) {
    double sum = 0;
    for (std::size_t i = 0; i < ds.size(); ++i) sum += (t.poses[i].translation() - ds.ground_truth.poses[i].translation()).norm();
    return sum / static_cast<double>(ds.size());
  };

  pl::Trajectory placed;  // one LiDAR pose per scan of the dataset
  std::optional<pl::GeoPoint> origin = ds.meta.origin;
  if (poses == "gt") {
    if (!ds.has_ground_truth()) throw pl::Error(ds.dir + ": --poses gt needs ground-truth poses (poses.txt or OXTS)");
    placed = ds.ground_truth;
  } else {
    // The odometry runs over every scan (it needs them all to follow the drive; --every thins the map only).
    pl::maps::LoamConfig lc;
    // Real recordings (no meta.json: KITTI) sweep while the car moves; pl-sim's scans are taken at one pose.
    lc.deskew = deskew == "on" || (deskew == "auto" && !ds.has_meta_file);
    if (ds.meta.sensor.rate_hz > 0) lc.scan_period_s = 1.0 / ds.meta.sensor.rate_hz;
    pl::maps::LoamOdometry odometry(lc);
    // Without GPS: started at the first ground-truth pose when there is one, so that the map lies in
    // the dataset's world frame; otherwise in the first scan's frame, which has no geodetic origin.
    // With GPS the ground truth is not used at all: the odometry starts in the first scan's frame
    // and the fixes place it.
    const bool start_at_truth = ds.has_ground_truth() && !use_gps;
    if (start_at_truth)
      odometry.start(ds.ground_truth.poses[0]);
    else
      origin.reset();
    std::vector<double> ms;
    std::vector<pl::maps::Information6> information;
    std::size_t degenerate = 0;
    // The graph's keyframes are chosen by a causal rule, so their clouds for loop closure are kept
    // as the odometry runs (thinned; the other scans are not held).
    pl::maps::PoseGraphConfig gc;
    std::vector<std::vector<Eigen::Vector3f>> keyframe_clouds;
    pl::Pose last_keyframe = pl::Pose::Identity();
    pl::ScanPrepConfig loop_prep = cfg.scan;
    loop_prep.voxel_m = 0.3;
    const auto t_start = std::chrono::steady_clock::now();
    pl::Progress bar("lidar odometry", ds.size());
    for (std::size_t i = 0; i < ds.size(); ++i) {
      pl::Scan scan = ds.load_scan(i);
      pl::maps::LoamFrame f = odometry.add(scan, ds.rings(scan), ds.times[i]);
      placed.poses.push_back(f.pose);
      information.push_back(f.information);
      ms.push_back(f.ms);
      degenerate += f.degenerate;
      if (use_loops && (i == 0 || pl::maps::is_new_keyframe(last_keyframe, f.pose, gc))) {
        last_keyframe = f.pose;
        std::vector<Eigen::Vector3f> cloud;
        for (const pl::PointXYZI& p : pl::prepare_scan(scan, {}, loop_prep)) cloud.emplace_back(p.x, p.y, p.z);
        keyframe_clouds.push_back(std::move(cloud));
      }
      bar.update(i + 1);
    }
    bar.finish();
    placed.times = ds.times;
    const double median_ms = pl::median(ms);
    std::printf("lidar odometry: %zu scans (deskew %s), median %.1f ms a scan, %zu degenerate%s\n", ds.size(), lc.deskew ? "on" : "off",
                median_ms, degenerate, start_at_truth ? ", started at the first ground-truth pose" : ", in the first scan's frame");
    report["odometry"] = {{"median_ms", median_ms}, {"degenerate", degenerate}, {"deskew", lc.deskew}};
    if (ds.has_ground_truth()) {
      // The odometry's error as if it had started at the first ground-truth pose.
      pl::Trajectory from_truth = placed;
      if (!start_at_truth)
        for (pl::Pose& p : from_truth.poses) p = ds.ground_truth.poses[0] * p;
      report["mean_error_before_m"] = mean_error(from_truth);
    }
    if (use_gps || use_loops) {
      pl::maps::PoseGraph graph(placed.poses, information, gps_edges, ds.meta.vehicle.gps_lever_arm, gc);
      graph.optimize();
      if (use_gps) {
        // The GPS fixes set the world frame: the map keeps the dataset's origin even without ground truth.
        origin = ds.meta.origin;
        if (ds.has_ground_truth()) {
          pl::Trajectory t = placed;
          t.poses = graph.poses();
          report["mean_error_gps_m"] = mean_error(t);
        }
      }
      if (use_loops) {
        pl::maps::LoopClosureConfig lcc;
        pl::Progress loop_bar("loop closure", graph.keyframes().size());
        const pl::maps::LoopReport lr =
            pl::maps::close_loops(graph, keyframe_clouds, lcc, [&](std::size_t done, std::size_t) { loop_bar.update(done); });
        loop_bar.finish();
        std::printf("loop closure: %zu queries, proposed %zu by position and %zu by place; %zu accepted, %zu rejected; "
                    "loop residual median %.3f m -> %.3f m; %.1f s verifying\n",
                    lr.queries, lr.proposed_by_position, lr.proposed_by_descriptor, lr.accepted, lr.rejected, lr.residual_before_m,
                    lr.residual_after_m, lr.verify_ms / 1000.0);
        nlohmann::json loops = nlohmann::json::array();
        for (const pl::maps::LoopRecord& l : lr.loops)
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
        report["loops"] = {{"queries", lr.queries},
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
      placed.poses = graph.poses();
      const pl::maps::PoseGraphReport r = graph.report();
      std::printf("pose graph: %zu keyframes, %zu GPS edges (%zu outliers), %zu loop edges, GPS residual RMS %.3f m -> %.3f m, "
                  "%d solves, %d iterations, %.0f ms (%s)\n",
                  r.keyframes, r.gps_edges, r.gps_outliers, r.loop_edges, r.gps_rms_before_m, r.gps_rms_after_m, r.solves, r.iterations,
                  r.solve_ms, r.termination.c_str());
      report["pose_graph"] = {{"keyframes", r.keyframes},
                              {"gps_edges", r.gps_edges},
                              {"gps_outliers", r.gps_outliers},
                              {"gps_rms_before_m", r.gps_rms_before_m},
                              {"gps_rms_after_m", r.gps_rms_after_m},
                              {"loop_edges", r.loop_edges},
                              {"solves", r.solves},
                              {"iterations", r.iterations},
                              {"solve_ms", r.solve_ms},
                              {"termination", r.termination}};
    }
    const double total_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
    report["trajectory_ms_per_scan"] = 1000.0 * total_s / static_cast<double>(ds.size());
    std::printf("trajectory: %.1f ms a scan in all (odometry%s%s)\n", 1000.0 * total_s / static_cast<double>(ds.size()),
                use_gps ? " + GPS" : "", use_loops ? " + loops" : "");
    if (ds.has_ground_truth()) report["mean_error_after_m"] = mean_error(placed);
  }
  if (report_path) {
    std::ofstream f(*report_path);
    f << report.dump(2) << "\n";
    if (!f) throw pl::Error(*report_path + ": cannot write the report");
    std::printf("wrote %s\n", report_path->c_str());
  }
  if (traj_out) {
    // KITTI (12 numbers a line), or TUM with the scan times when the file name ends in .tum.
    pl::Trajectory kitti = placed;
    kitti.times = ds.times;
    const bool tum = traj_out->size() > 4 && traj_out->compare(traj_out->size() - 4, 4, ".tum") == 0;
    kitti.format = tum ? pl::PoseFormat::Tum : pl::PoseFormat::Kitti;
    if (tum)
      pl::write_tum_poses(*traj_out, kitti);
    else
      pl::write_kitti_poses(*traj_out, kitti);
    const char* source = poses == "gt"            ? "ground truth"
                         : use_gps && use_loops ? "lidar odometry + GPS + loops pose graph"
                         : use_gps              ? "lidar odometry + GPS pose graph"
                         : use_loops            ? "lidar odometry + loops pose graph"
                                                : "lidar odometry";
    std::printf("wrote %s: %zu LiDAR poses (%s), one per scan\n", traj_out->c_str(), kitti.size(), source);
  }
  std::size_t scans = (ds.size() + cfg.every - 1) / cfg.every;
  pl::Progress bar("merging scans", scans);
  pl::maps::MapCloud map = pl::maps::build_map_from_poses(ds, placed, cfg, [&](std::size_t done, std::size_t) { bar.update(done); });
  bar.finish();
  pl::write_pcd(out, map.points, map.intensity, origin);
  std::printf("wrote %s: %zu points from %zu scans at %.2f m voxels\n", out.c_str(), map.points.size(),
              scans, cfg.voxel_m);
  return 0;
}

int cmd_tile(const pl::Args& a) {
  std::string cloud_path = a.require("--cloud", "FILE (.pcd, .ply or .bin, in the map's local ENU frame)");
  std::string db = a.require("--db", "FILE (the SQLite map store; created when missing)");
  std::string name = a.require("--map", "NAME");
  auto origin_flag = a.get("--origin");
  double voxel = a.get_double("--voxel", 0.2), tile_size = a.get_double("--tile-size", 20.0);
  double radius = a.get_double("--normal-radius", 3.0 * voxel);
  pl::TileCodecConfig codec;
  codec.max_error_m = a.get_double("--max-error", codec.max_error_m);
  std::string note = a.get_or("--note", "tiled from " + cloud_path);
  a.finish();
  if (!(voxel > 0) || !(tile_size >= 1.0)) throw pl::Error("--voxel must be positive and --tile-size at least 1 m");
  if (!(codec.max_error_m > 0 && codec.max_error_m <= 0.1)) throw pl::Error("--max-error takes metres in (0, 0.1]");

  pl::Cloud cloud = pl::read_cloud(cloud_path);
  if (origin_flag) {
    auto v = pl::parse_number_list(*origin_flag, 3, "--origin");
    cloud.origin = pl::GeoPoint{v[0], v[1], v[2]};
  }
  pl::store::Store store = pl::store::Store::open(db);
  auto existing = store.find_map(name);
  if (!cloud.origin && !existing)
    throw pl::Error(cloud_path + ": no origin recorded: give --origin LAT,LON,ALT (the geodetic origin of the cloud's ENU frame)");
  if (existing) {
    if (std::abs(existing->tile_size - tile_size) > 1e-9 || std::abs(existing->voxel_size - voxel) > 1e-9)
      throw pl::Error("map " + name + " has " + std::to_string(existing->tile_size) + " m tiles and " +
                      std::to_string(existing->voxel_size) + " m voxels: use --tile-size " + std::to_string(existing->tile_size) +
                      " --voxel " + std::to_string(existing->voxel_size) + ", or another --map");
    if (cloud.origin && (std::abs(cloud.origin->lat_deg - existing->origin.lat_deg) > 1e-9 ||
                         std::abs(cloud.origin->lon_deg - existing->origin.lon_deg) > 1e-9))
      throw pl::Error(cloud_path + ": its origin differs from map " + name + "'s: the cloud is in another frame (use another --map)");
  }
  if (cloud.points.empty()) throw pl::Error(cloud_path + ": no points");

  std::vector<float> intensity;
  pl::Points3d pts = pl::voxel_downsample(cloud.points, cloud.intensity, voxel, intensity);
  auto normals = pl::registration::estimate_normals(pts, radius);
  pl::TileGrid grid(tile_size);
  auto tiles = pl::maps::cut_into_tiles(pts, normals, intensity, grid);

  // Everything in one transaction: an interrupted import leaves no version behind.
  pl::store::Store::Transaction tx(store);
  if (!existing) store.create_map(name, *cloud.origin, tile_size, voxel);
  pl::store::VersionInfo v = store.create_version(name, std::nullopt, note);
  std::map<pl::TileKey, std::string> parent_hash;  // the new version starts as a copy of its parent
  for (const auto& t : store.list_tiles(name, v.number)) parent_hash[t.key] = t.hash;
  std::size_t changed = 0, unchanged = 0, removed = 0;
  double bytes = 0;
  pl::Progress bar("encoding tiles", tiles.size());
  std::size_t done = 0;
  for (const auto& [key, tile] : tiles) {
    std::string enc = pl::encode_tile(tile, codec);
    Eigen::Vector3d lo = tile.points.front(), hi = lo;
    for (const auto& p : tile.points) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
    auto rec = store.put_tile(name, v.number, key, enc, static_cast<std::int64_t>(tile.size()), lo.x(), lo.y(), lo.z(), hi.x(),
                              hi.y(), hi.z());
    auto it = parent_hash.find(key);
    if (it != parent_hash.end() && it->second == rec.hash)
      ++unchanged;
    else
      ++changed;
    bytes += static_cast<double>(enc.size());
    bar.update(++done);
  }
  bar.finish();
  for (const auto& [key, hash] : parent_hash)
    if (!tiles.count(key)) removed += store.delete_tile(name, v.number, key);
  store.log_upload(name, v.number, "tile", note, "pl-map");
  tx.commit();
  std::string parent = v.parent ? "parent v" + std::to_string(*v.parent) : "no parent";
  std::printf("map %s version %lld staged (%s): %zu tiles (%zu new or changed, %zu unchanged, %zu removed), %zu points, %s\n",
              name.c_str(), static_cast<long long>(v.number), parent.c_str(), tiles.size(), changed, unchanged, removed, pts.size(),
              mb(bytes).c_str());
  std::printf("publish it with: pl-map publish --db %s --map %s --version %lld\n", db.c_str(), name.c_str(),
              static_cast<long long>(v.number));
  return 0;
}

pl::store::MapInfo need_map(const pl::store::Store& s, const std::string& name) {
  auto m = s.find_map(name);
  if (!m) throw pl::Error(s.path() + ": no map named \"" + name + "\" (pl-map list --db " + s.path() + " shows the maps)");
  return *m;
}

void print_version(const pl::store::VersionInfo& v, bool current) {
  std::printf("  %s v%-4lld %-9s %6lld tiles %10lld points %10s  %s%s%s\n", current ? "*" : " ", static_cast<long long>(v.number),
              pl::store::state_name(v.state), static_cast<long long>(v.tiles), static_cast<long long>(v.points),
              mb(static_cast<double>(v.bytes)).c_str(), v.created.c_str(), v.note.empty() ? "" : "  ", v.note.c_str());
}

int cmd_publish(const pl::Args& a) {
  std::string db = a.require("--db", "FILE"), name = a.require("--map", "NAME");
  long long version = a.get_int("--version", -1);
  a.finish();
  if (version < 1) throw pl::Error("missing --version N (the staged version to publish)");
  auto store = pl::store::Store::open(db, false);
  need_map(store, name);
  store.publish(name, version);
  store.log_upload(name, version, "publish", "", "pl-map");
  std::printf("map %s: version %lld is current\n", name.c_str(), version);
  return 0;
}

int cmd_rollback(const pl::Args& a) {
  std::string db = a.require("--db", "FILE"), name = a.require("--map", "NAME");
  a.finish();
  auto store = pl::store::Store::open(db, false);
  need_map(store, name);
  auto v = store.rollback(name);
  store.log_upload(name, v, "rollback", "", "pl-map");
  std::printf("map %s: rolled back, version %lld is current\n", name.c_str(), static_cast<long long>(v));
  return 0;
}

int cmd_list(const pl::Args& a) {
  std::string db = a.require("--db", "FILE");
  auto name = a.get("--map");
  a.finish();
  auto store = pl::store::Store::open(db, false);
  if (name) {
    auto m = need_map(store, *name);
    std::printf("map %s (tile %.1f m, voxel %.2f m)\n", m.name.c_str(), m.tile_size, m.voxel_size);
    for (const auto& v : store.list_versions(*name)) print_version(v, m.current && *m.current == v.number);
    return 0;
  }
  auto maps = store.list_maps();
  if (maps.empty()) std::printf("no maps in %s\n", db.c_str());
  for (const auto& m : maps)
    std::printf("%-24s current %s, tile %.1f m, voxel %.2f m, origin %.7f %.7f %.2f\n", m.name.c_str(),
                m.current ? ("v" + std::to_string(*m.current)).c_str() : "none", m.tile_size, m.voxel_size, m.origin.lat_deg,
                m.origin.lon_deg, m.origin.alt_m);
  return 0;
}

int cmd_info(const pl::Args& a) {
  std::string db = a.require("--db", "FILE"), name = a.require("--map", "NAME");
  long long version = a.get_int("--version", 0);
  a.finish();
  auto store = pl::store::Store::open(db, false);
  auto m = need_map(store, name);
  if (version == 0) {
    if (!m.current) throw pl::Error("map " + name + " has no published version yet: give --version N");
    version = *m.current;
  }
  auto v = store.find_version(name, version);
  if (!v) throw pl::Error("map " + name + " has no version " + std::to_string(version));
  auto tiles = store.list_tiles(name, version);
  double lo_x = INFINITY, lo_y = INFINITY, hi_x = -INFINITY, hi_y = -INFINITY;
  for (const auto& t : tiles) lo_x = std::min(lo_x, t.min_x), lo_y = std::min(lo_y, t.min_y), hi_x = std::max(hi_x, t.max_x), hi_y = std::max(hi_y, t.max_y);
  double area_km2 = static_cast<double>(tiles.size()) * m.tile_size * m.tile_size / 1e6;
  std::printf("map          %s\n", m.name.c_str());
  std::printf("version      %lld (%s)%s, created %s\n", version, pl::store::state_name(v->state),
              m.current && *m.current == version ? ", current" : "", v->created.c_str());
  std::printf("origin       lat %.9f, lon %.9f, alt %.3f m\n", m.origin.lat_deg, m.origin.lon_deg, m.origin.alt_m);
  std::printf("grid         %.1f m tiles, %.2f m voxels\n", m.tile_size, m.voxel_size);
  std::printf("tiles        %zu covering %.4f km2, %lld points, %s (%.1f MB per km2 of tiles)\n", tiles.size(), area_km2,
              static_cast<long long>(v->points), mb(static_cast<double>(v->bytes)).c_str(),
              area_km2 > 0 ? static_cast<double>(v->bytes) / 1e6 / area_km2 : 0.0);
  if (!tiles.empty()) std::printf("bounds       x %.1f .. %.1f, y %.1f .. %.1f m\n", lo_x, hi_x, lo_y, hi_y);
  return 0;
}

int cmd_diff(const pl::Args& a) {
  std::string db = a.require("--db", "FILE"), name = a.require("--map", "NAME");
  long long from = a.get_int("--from", -1), to = a.get_int("--to", -1);
  a.finish();
  if (from < 1 || to < 1) throw pl::Error("diff needs --from A --to B (version numbers)");
  auto store = pl::store::Store::open(db, false);
  need_map(store, name);
  for (long long v : {from, to})
    if (!store.find_version(name, v)) throw pl::Error("map " + name + " has no version " + std::to_string(v));
  std::map<pl::TileKey, std::string> a_tiles, b_tiles;
  for (const auto& t : store.list_tiles(name, from)) a_tiles[t.key] = t.hash;
  for (const auto& t : store.list_tiles(name, to)) b_tiles[t.key] = t.hash;
  std::size_t added = 0, removed = 0, changed = 0, same = 0;
  for (const auto& [k, h] : b_tiles) {
    auto it = a_tiles.find(k);
    if (it == a_tiles.end()) {
      ++added;
      std::printf("+ %d %d\n", k.tx, k.ty);
    } else if (it->second != h) {
      ++changed;
      std::printf("~ %d %d\n", k.tx, k.ty);
    } else {
      ++same;
    }
  }
  for (const auto& [k, h] : a_tiles)
    if (!b_tiles.count(k)) {
      ++removed;
      std::printf("- %d %d\n", k.tx, k.ty);
    }
  std::printf("v%lld -> v%lld: %zu added, %zu removed, %zu changed, %zu unchanged\n", from, to, added, removed, changed, same);
  return 0;
}

int cmd_push(const pl::Args& a) {
  pl::maps::PushOptions o;
  o.db = a.require("--db", "FILE");
  o.map = a.require("--map", "NAME");
  o.version = a.get_int("--version", -1);
  o.server = a.require("--server", "URL (e.g. http://127.0.0.1:8080)");
  o.token = a.require("--token", "TOKEN (of the upload role; admin to create the map there)");
  a.finish();
  if (o.version < 1) throw pl::Error("missing --version N (the local version to push)");
  auto r = pl::maps::push_version(o);
  std::printf("pushed map %s v%lld to %s as v%lld: %zu tiles, %zu uploaded (%s), %zu already there, %zu deleted; published\n",
              o.map.c_str(), static_cast<long long>(o.version), o.server.c_str(), static_cast<long long>(r.remote_version), r.tiles,
              r.uploaded, mb(static_cast<double>(r.bytes)).c_str(), r.skipped, r.deleted);
  return 0;
}

int body(int argc, char** argv) {
  if (argc < 2 || std::string(argv[1]) == "--help" || std::string(argv[1]) == "-h") {
    std::fputs(kUsage, argc < 2 ? stderr : stdout);
    return argc < 2 ? 2 : 0;
  }
  std::string cmd = argv[1];
  pl::Args args(argc, argv, 2, {"--gps", "--loops"});
  if (!args.positional().empty()) throw pl::Error("unexpected argument \"" + args.positional()[0] + "\" (see pl-map --help)");
  if (cmd == "build") return cmd_build(args);
  if (cmd == "tile") return cmd_tile(args);
  if (cmd == "publish") return cmd_publish(args);
  if (cmd == "rollback") return cmd_rollback(args);
  if (cmd == "list") return cmd_list(args);
  if (cmd == "info") return cmd_info(args);
  if (cmd == "diff") return cmd_diff(args);
  if (cmd == "push") return cmd_push(args);
  throw pl::Error("unknown command \"" + cmd + "\" (build, tile, publish, rollback, list, info, diff or push; see --help)");
}

}  // namespace

int main(int argc, char** argv) { return pl::run_cli("pl-map", body, argc, argv); }
