// pl-localize: localizes a drive (dataset directory) against a tiled map, streamed from pl-server or
// read from a local map store, and writes the poses. See docs/pl-localize.md.
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <memory>
#include <thread>

#include "pl/client/localizer.hpp"
#include "pl/client/store_tiles.hpp"
#include "pl/client/tile_client.hpp"
#include "pl/common/cli.hpp"
#include "pl/common/dataset.hpp"
#include "pl/common/error.hpp"
#include "pl/common/progress.hpp"
#include "pl/common/stats.hpp"


namespace {

using pl::Error;
using pl::client::Health;

const char* kUsage =
    "usage: pl-localize --dataset DIR (--server URL | --db FILE) --map NAME [--version N]\n"
    "         [--lidar-beams 16] [--fov 360|180] [--odometry auto|encoder|odometry|lidar]\n"
    "         [--init x,y,z,yaw | gt | gps] [--init-search on|off] [--scans all|even|odd] [--first K] [--count N]\n"
    "         [--voxel 0.4] [--max-range 80] [--roi-radius 90] [--delta 1.0] [--cell 1.0]\n"
    "         --out poses.tum [--kitti-out poses.txt] [--timing timing.csv]\n"
    "         [--cache FILE] [--cache-mb 256] [--token T] [--realtime]\n";

double seconds_now() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

// The tiles: from pl-server through the tile client (background fetching, caches), or a local store.
struct TileSource {
  std::unique_ptr<pl::client::TileClient> client;
  std::unique_ptr<pl::client::StoreTiles> store;
  double tile_size = 0;
  long long version = 0;

  std::vector<pl::client::RoiMap::TileRef> near(const Eigen::Vector2d& c, double r) {
    return store ? store->near(c, r) : client->tiles_near(c, r);
  }
  void focus(const Eigen::Vector2d& now, const Eigen::Vector2d& ahead) {
    if (client) client->set_focus(now, ahead);
  }
  // Start-up: wait (bounded) for the tiles around the first pose.
  void wait_for(const Eigen::Vector2d& c, double r) {
    if (client && !client->wait_for(c, r, 30.0))
      std::fprintf(stderr, "pl-localize: warning: not every tile around the start arrived within 30 s (%s)\n",
                   client->status().last_error.c_str());
  }
};

int body(int argc, char** argv) {
  pl::Args args(argc, argv, 1, {"--realtime", "--help"});
  if (args.has("--help")) {
    std::fputs(kUsage, stdout);
    return 0;
  }
  const pl::Dataset ds = pl::open_dataset(args.require("--dataset", "the drive to localize (a dataset directory)"));
  const std::string map_name = args.require("--map", "the map's name (pl-map list)");
  const auto server = args.get("--server");
  const auto db = args.get("--db");
  if (!server == !db) throw Error("give exactly one of --server URL (pl-server) or --db FILE (a local map store)\n" + std::string(kUsage));
  const long long version = args.get_int("--version", 0);
  const std::string out_path = args.require("--out", "the TUM file for the fused poses");
  const auto kitti_out = args.get("--kitti-out");
  const auto timing_out = args.get("--timing");
  const bool realtime = args.has("--realtime");

  pl::client::LocalizerConfig cfg;
  const int beams = static_cast<int>(args.get_int("--lidar-beams", ds.meta.sensor.beams));
  if (beams < 1 || beams > ds.meta.sensor.beams || ds.meta.sensor.beams % beams != 0)
    throw Error("--lidar-beams must divide the sensor's " + std::to_string(ds.meta.sensor.beams) + " beams, got " +
                std::to_string(beams));
  cfg.scan.beams = beams;
  cfg.scan.sensor_beams = ds.meta.sensor.beams;
  cfg.scan.fov_deg = args.get_double("--fov", 360.0);
  if (!(cfg.scan.fov_deg > 0 && cfg.scan.fov_deg <= 360)) throw Error("--fov takes degrees in (0, 360]");
  cfg.scan.voxel_m = args.get_double("--voxel", cfg.scan.voxel_m);
  cfg.scan.max_range_m = args.get_double("--max-range", cfg.scan.max_range_m);
  cfg.roi_radius_m = args.get_double("--roi-radius", cfg.roi_radius_m);
  cfg.icp.max_pair_m = args.get_double("--delta", cfg.icp.max_pair_m);
  cfg.map.cell_m = args.get_double("--cell", cfg.map.cell_m);
  cfg.icp.max_iterations = static_cast<int>(args.get_int("--max-iterations", cfg.icp.max_iterations));
  cfg.icp.kernel_m = args.get_double("--kernel", cfg.icp.kernel_m);
  cfg.fusion.momentum_window = static_cast<int>(args.get_int("--momentum-window", cfg.fusion.momentum_window));

  // Scans to localize.
  const std::string which = args.get_or("--scans", "all");
  if (which != "all" && which != "even" && which != "odd") throw Error("--scans takes all, even or odd");
  std::vector<std::size_t> scans;
  for (std::size_t i = 0; i < ds.size(); ++i) {
    const long f = ds.frame_ids.empty() ? static_cast<long>(i) : ds.frame_ids[i];
    if (which == "all" || (which == "even") == (f % 2 == 0)) scans.push_back(i);
  }
  const auto first = static_cast<std::size_t>(args.get_int("--first", 0));
  const auto count = static_cast<std::size_t>(args.get_int("--count", static_cast<long long>(scans.size())));
  if (first >= scans.size()) throw Error("--first " + std::to_string(first) + " is past the " + std::to_string(scans.size()) + " scans");
  scans = std::vector<std::size_t>(scans.begin() + static_cast<long>(first),
                                   scans.begin() + static_cast<long>(std::min(scans.size(), first + count)));
  if (scans.empty()) throw Error("--count " + std::to_string(count) + " leaves no scan to localize (give at least 1)");

  // Odometry.
  std::string odo_kind = args.get_or("--odometry", "auto");
  if (odo_kind == "auto") odo_kind = !ds.encoder.empty() ? "encoder" : !ds.odometry.empty() ? "odometry" : "lidar";
  std::unique_ptr<pl::client::OdometryBuffer> odometry;
  if (odo_kind == "encoder") {
    if (ds.encoder.empty()) throw Error("--odometry encoder: " + ds.dir + " has no encoder.csv");
    odometry = std::make_unique<pl::client::OdometryBuffer>(
        pl::client::odometry_from_encoders(ds.encoder, ds.meta.vehicle.wheel_base_m));
  } else if (odo_kind == "odometry") {
    if (ds.odometry.empty()) throw Error("--odometry odometry: " + ds.dir + " has no odometry.csv");
    odometry = std::make_unique<pl::client::OdometryBuffer>(pl::client::odometry_from_poses(ds.odometry));
  } else if (odo_kind != "lidar") {
    throw Error("--odometry takes auto, encoder, odometry or lidar, got " + odo_kind);
  }

  const std::string init = args.get_or("--init", ds.gps.empty() ? "gt" : "gps");
  const std::string init_search = args.get_or("--init-search", "on");
  if (init_search != "on" && init_search != "off") throw Error("--init-search takes on or off");
  const bool args_search = init_search == "on" && init != "gt" && init != "gps";

  // Tiles.
  TileSource tiles;
  if (db) {
    tiles.store = std::make_unique<pl::client::StoreTiles>(*db, map_name, version);
    tiles.tile_size = tiles.store->tile_size();
    tiles.version = tiles.store->version();
  } else {
    pl::client::TileClientConfig tc;
    tc.server = *server;
    tc.map = map_name;
    if (version > 0) tc.version = version;
    tc.cache_path = args.get_or("--cache", "");
    tc.memory_mb = args.get_double("--cache-mb", tc.memory_mb);
    tc.radius_m = cfg.roi_radius_m + 20.0;
    tc.token = args.get_or("--token", "");
    tiles.client = std::make_unique<pl::client::TileClient>(tc);
    if (!tiles.client->wait_ready(30.0))
      throw Error("no map '" + map_name + "' from " + *server + " and none in the cache (" + tiles.client->status().last_error +
                  "): is pl-server running, or give --cache FILE of an earlier drive");
    const auto st = tiles.client->status();
    tiles.tile_size = st.tile_size;
    tiles.version = st.version;
  }
  args.finish();

  pl::client::Localizer loc(cfg, tiles.tile_size,
                            [&tiles](const Eigen::Vector2d& c, double r) { return tiles.near(c, r); });

  // Start pose.
  const std::size_t i0 = scans.front();
  const double t0 = ds.times[i0];
  Eigen::Isometry3d start = Eigen::Isometry3d::Identity();
  bool search_heading = false;
  if (init == "gt") {
    if (!ds.has_ground_truth()) throw Error("--init gt: " + ds.dir + " has no ground-truth poses; give --init x,y,z,yaw");
    start = ds.ground_truth.poses[i0];
  } else if (init == "gps") {
    const pl::GpsFix* fix = nullptr;
    for (const auto& g : ds.gps)
      if (g.status != pl::kGpsNone && g.t >= t0 - 0.5) {
        fix = &g;
        break;
      }
    if (!fix) throw Error("--init gps: no GPS fix at the start of " + ds.dir + "; give --init x,y,z,yaw");
    const Eigen::Vector3d antenna = ds.to_world(fix->position);
    start.translation() = antenna - ds.meta.vehicle.gps_lever_arm;  // heading unknown: lever arm as if level, facing +x
    search_heading = true;
  } else {
    const auto v = pl::parse_number_list(init, 4, "--init");
    start = pl::make_pose(v[0], v[1], v[2], 0, 0, v[3] * M_PI / 180.0);
  }
  tiles.focus(start.translation().head<2>(), start.translation().head<2>());
  tiles.wait_for(start.translation().head<2>(), cfg.roi_radius_m);
  // --init x,y,z,yaw is searched around (+-6 m, +-45 deg) unless --init-search off; a GPS fix has no
  // heading: every direction is tried.
  const bool searched = search_heading || args_search;
  if (searched) {
    const pl::Scan raw = ds.load_scan(i0);
    pl::client::PoseSearch ps;
    if (search_heading) ps.yaw_range_deg = 180.0;
    if (!loc.start_near(start, t0, odometry.get(), raw, ds.rings(raw), ps))
      throw Error("--init " + init + ": the first scan registers to the map nowhere within " + std::to_string(ps.radius_m) +
                  " m of the start; give a closer --init x,y,z,yaw");
    start = loc.pose_at(t0);
  } else {
    loc.start(start, t0, odometry.get());
  }

  // The loop.
  pl::Trajectory fused_tum, per_scan;
  fused_tum.format = pl::PoseFormat::Tum;
  std::FILE* timing = nullptr;
  if (timing_out) {
    timing = std::fopen(timing_out->c_str(), "w");
    if (!timing) throw Error("cannot write " + *timing_out);
    std::fprintf(timing, "scan,t,registration_ms,prepare_ms,map_ms,total_ms,points,iterations,pairs,inlier_share,rms_m,conditioning,correction_m,position_sigma_m,status,fused,note\n");
  }
  std::size_t next_odo = odometry ? odometry->upper_bound(t0 - 1e-9) : 0;
  std::vector<double> reg_ms, total_ms;
  std::size_t n_ok = 0, n_degraded = 0, n_lost = 0, n_outdated = 0, n_fused = 0;
  pl::Progress progress("localizing", scans.size());
  const double wall0 = seconds_now();
  Eigen::Vector2d last_xy = start.translation().head<2>();
  double last_t = t0;
  for (std::size_t k = 0; k < scans.size(); ++k) {
    const std::size_t i = scans[k];
    const double t = ds.times[i];
    if (realtime) {
      const double wait = (t - t0) - (seconds_now() - wall0);
      if (wait > 0) std::this_thread::sleep_for(std::chrono::duration<double>(wait));
    }
    // Odometry-rate output up to the scan, with what is known before it is registered.
    std::vector<std::pair<double, Eigen::Isometry3d>> pending;  // samples the result arrives too late for
    if (odometry) {
      for (; next_odo < odometry->size() && odometry->time(next_odo) < t; ++next_odo) {
        fused_tum.times.push_back(odometry->time(next_odo));
        fused_tum.poses.push_back(loc.pose_at(odometry->time(next_odo)));
      }
      for (std::size_t j = next_odo; j < odometry->size() && odometry->time(j) < t + 0.25; ++j)
        pending.emplace_back(odometry->time(j), loc.pose_at(odometry->time(j)));
    }
    const double c0 = seconds_now();
    const pl::Scan raw = ds.load_scan(i);
    const auto rings = beams < ds.meta.sensor.beams ? ds.rings(raw) : std::vector<std::uint16_t>{};
    const Eigen::Isometry3d pred = loc.pose_at(t);
    const Eigen::Vector2d xy = pred.translation().head<2>();
    const Eigen::Vector2d velocity = t > last_t ? Eigen::Vector2d((xy - last_xy) / (t - last_t)) : Eigen::Vector2d::Zero();
    const Eigen::Vector2d ahead = xy + 3.0 * velocity;  // where the vehicle will be in 3 s
    tiles.focus(xy, ahead);
    const pl::client::ScanReport r = loc.process(t, raw, rings);
    const double latency = seconds_now() - c0;
    last_xy = r.fused.translation().head<2>();
    last_t = t;
    if (odometry) {
      // Poses between the scan and the moment its result is ready were output before the correction.
      for (const auto& [tj, pj] : pending) {
        if (tj >= t + latency) break;
        fused_tum.times.push_back(tj);
        fused_tum.poses.push_back(pj);
        ++next_odo;
      }
    } else {
      fused_tum.times.push_back(t);
      fused_tum.poses.push_back(r.fused);
    }
    per_scan.times.push_back(t);
    per_scan.poses.push_back(r.fused);
    reg_ms.push_back(r.register_ms);
    total_ms.push_back(latency * 1000.0);
    n_fused += r.fused_lidar;
    n_outdated += r.map_outdated;
    (r.health == Health::Ok ? n_ok : r.health == Health::Degraded ? n_degraded : n_lost)++;
    if (timing)
      std::fprintf(timing, "%zu,%.6f,%.3f,%.3f,%.3f,%.3f,%zu,%d,%d,%.4f,%.4f,%.4f,%.4f,%.5f,%s,%d,%s\n", i, t, r.register_ms, r.prepare_ms,
                   r.map_ms, latency * 1000.0, r.scan_points, r.icp.iterations, r.icp.pairs, r.icp.inlier_share, r.icp.rms_m,
                   r.icp.conditioning, (r.predicted.translation() - r.icp.pose.translation()).norm(), r.position_sigma.norm(),
                   pl::client::health_name(r.health), r.fused_lidar ? 1 : 0, r.note.c_str());
    progress.update(k + 1);
  }
  progress.finish();
  if (odometry)
    for (; next_odo < odometry->size() && odometry->time(next_odo) <= ds.times[scans.back()]; ++next_odo) {
      fused_tum.times.push_back(odometry->time(next_odo));
      fused_tum.poses.push_back(loc.pose_at(odometry->time(next_odo)));
    }
  if (timing) std::fclose(timing);
  pl::write_tum_poses(out_path, fused_tum);
  if (kitti_out) pl::write_kitti_poses(*kitti_out, per_scan);

  const double span = ds.times[scans.back()] - t0;
  std::printf("pl-localize: %zu scans of %s, map %s v%lld (%s), %d beams, fov %.0f, odometry %s\n", scans.size(),
              ds.dir.c_str(), map_name.c_str(), tiles.version, db ? "local store" : server->c_str(), beams,
              cfg.scan.fov_deg, odo_kind.c_str());
  std::printf("  status: %zu ok, %zu degraded, %zu lost; LiDAR fused on %zu (%.1f %%); map looked outdated on %zu\n", n_ok,
              n_degraded, n_lost, n_fused, 100.0 * static_cast<double>(n_fused) / static_cast<double>(scans.size()), n_outdated);
  std::printf("  registration ms: median %.2f, p99 %.2f; whole scan ms: median %.2f, p99 %.2f (one thread)\n",
              pl::median(reg_ms), pl::percentile(reg_ms, 99), pl::median(total_ms), pl::percentile(total_ms, 99));
  std::printf("  fused poses: %zu (%.1f Hz over %.1f s of drive) -> %s\n", fused_tum.size(),
              span > 0 ? static_cast<double>(fused_tum.size()) / span : 0.0, span, out_path.c_str());
  if (tiles.client) {
    const auto st = tiles.client->status();
    std::printf("  tiles: %zu fetched, %zu from the disk cache, %zu failures, %zu retries%s%s\n", st.fetched, st.from_disk,
                st.failures, st.retries, st.last_error.empty() ? "" : "; last error: ", st.last_error.c_str());
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) { return pl::run_cli("pl-localize", body, argc, argv); }
