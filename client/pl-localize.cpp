// pl-localize: localizes a drive (dataset directory) against a tiled map, streamed from pl-server or
// read from a local map store, and writes the poses: a replay of the drive through
// pl::client::VehicleLocalizer, the API a vehicle program embeds. See docs/pl-localize.md.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>

#include "pl/client/replay.hpp"
#include "pl/client/vehicle_localizer.hpp"
#include "pl/common/cli.hpp"
#include "pl/common/dataset.hpp"
#include "pl/common/error.hpp"
#include "pl/common/output_path.hpp"
#include "pl/common/progress.hpp"
#include "pl/common/stats.hpp"

namespace {

using pl::Error;

const char* kUsage =
    "usage: pl-localize --dataset DIR (--server URL | --db FILE) --map NAME [--version N]\n"
    "         [--lidar-beams 16] [--fov 360|180] [--odometry auto|encoder|odometry|lidar]\n"
    "         [--init x,y,z,yaw | gt | gps] [--init-search on|off] [--scans all|even|odd] [--first K] [--count N]\n"
    "         [--voxel 1.0] [--max-range 80] [--roi-radius 90] [--delta 1.0] [--cell 0.5]\n"
    "         --out poses.tum [--kitti-out poses.txt] [--timing timing.csv]\n"
    "         [--cache FILE] [--cache-mb 256] [--token T] [--realtime]\n";

// The dataset indices of --scans all|even|odd, then --first K and --count N of them.
std::vector<std::size_t> choose_scans(const pl::Dataset& ds, const std::string& which, long long first, long long count) {
  if (which != "all" && which != "even" && which != "odd") throw Error("--scans takes all, even or odd");
  std::vector<std::size_t> scans;
  for (std::size_t i = 0; i < ds.size(); ++i) {
    const long f = ds.frame_ids.empty() ? static_cast<long>(i) : ds.frame_ids[i];
    if (which == "all" || (which == "even") == (f % 2 == 0)) scans.push_back(i);
  }
  if (first < 0 || static_cast<std::size_t>(first) >= scans.size())
    throw Error("--first " + std::to_string(first) + " is not one of the " + std::to_string(scans.size()) + " scans (0 to " +
                std::to_string(static_cast<long long>(scans.size()) - 1) + ")");
  if (count < 1) throw Error("--count " + std::to_string(count) + " leaves no scan to localize (give at least 1)");
  const auto b = static_cast<std::size_t>(first), e = std::min(scans.size(), b + static_cast<std::size_t>(count));
  return std::vector<std::size_t>(scans.begin() + static_cast<long>(b), scans.begin() + static_cast<long>(e));
}

int body(int argc, char** argv) {
  pl::Args args(argc, argv, 1, {"--realtime", "--help"});
  if (args.has("--help")) {
    std::fputs(kUsage, stdout);
    return 0;
  }
  const pl::Dataset ds = pl::open_dataset(args.require("--dataset", "the drive to localize (a dataset directory)"));
  pl::client::VehicleLocalizerConfig cfg;
  cfg.tiles.map = args.require("--map", "the map's name (pl-map list)");
  const auto server = args.get("--server");
  const auto db = args.get("--db");
  if (!server == !db) throw Error("give exactly one of --server URL (pl-server) or --db FILE (a local map store)\n" + std::string(kUsage));
  if (const long long v = args.get_int("--version", 0); v > 0) cfg.tiles.version = v;
  const std::string out_path = args.require("--out", "the TUM file for the fused poses");
  const auto kitti_out = args.get("--kitti-out");
  const auto timing_out = args.get("--timing");
  // Every output is checked before the drive starts: a typo must not cost the whole drive.
  pl::check_output_path(out_path, "--out");
  if (kitti_out) pl::check_output_path(*kitti_out, "--kitti-out");
  if (timing_out) pl::check_output_path(*timing_out, "--timing");

  pl::client::LocalizerConfig& lc = cfg.localizer;
  const int beams = static_cast<int>(args.get_int("--lidar-beams", ds.meta.sensor.beams));
  if (beams < 1 || beams > ds.meta.sensor.beams || ds.meta.sensor.beams % beams != 0)
    throw Error("--lidar-beams must divide the sensor's " + std::to_string(ds.meta.sensor.beams) + " beams, got " + std::to_string(beams));
  lc.scan.beams = beams;
  lc.scan.sensor_beams = ds.meta.sensor.beams;
  auto positive = [&](const std::string& flag, double fallback) {
    const double v = args.get_double(flag, fallback);
    if (!(v > 0) || !std::isfinite(v)) throw Error(flag + " must be a positive number, got " + std::to_string(v));
    return v;
  };
  lc.scan.fov_deg = positive("--fov", 360.0);
  if (lc.scan.fov_deg > 360) throw Error("--fov takes degrees in (0, 360]");
  lc.scan.voxel_m = positive("--voxel", lc.scan.voxel_m);
  lc.scan.max_range_m = positive("--max-range", lc.scan.max_range_m);
  lc.roi_radius_m = positive("--roi-radius", lc.roi_radius_m);
  lc.icp.max_pair_m = positive("--delta", lc.icp.max_pair_m);
  lc.map.cell_m = positive("--cell", lc.map.cell_m);
  lc.icp.max_iterations = static_cast<int>(positive("--max-iterations", lc.icp.max_iterations));
  lc.icp.kernel_m = positive("--kernel", lc.icp.kernel_m);
  lc.fusion.momentum_window = static_cast<int>(positive("--momentum-window", lc.fusion.momentum_window));

  pl::client::ReplayOptions replay;
  replay.scans = choose_scans(ds, args.get_or("--scans", "all"), args.get_int("--first", 0),
                              args.get_int("--count", static_cast<long long>(ds.size())));
  replay.rings = beams < ds.meta.sensor.beams;
  replay.realtime = args.has("--realtime");

  std::string odo_kind = args.get_or("--odometry", "auto");
  if (odo_kind == "auto") odo_kind = !ds.encoder.empty() ? "encoder" : !ds.odometry.empty() ? "odometry" : "lidar";
  if (odo_kind == "encoder") {
    if (ds.encoder.empty()) throw Error("--odometry encoder: " + ds.dir + " has no encoder.csv");
    replay.odometry = pl::client::OdometrySource::Encoder;
    cfg.wheel_base_m = ds.meta.vehicle.wheel_base_m;
    if (!(cfg.wheel_base_m > 0))
      throw Error("encoder odometry needs vehicle.wheel_base_m > 0 in meta.json (got " + std::to_string(cfg.wheel_base_m) + ")");
  } else if (odo_kind == "odometry") {
    if (ds.odometry.empty()) throw Error("--odometry odometry: " + ds.dir + " has no odometry.csv");
    replay.odometry = pl::client::OdometrySource::Poses;
  } else if (odo_kind != "lidar") {
    throw Error("--odometry takes auto, encoder, odometry or lidar, got " + odo_kind);
  }

  // The start: ground truth, the first GPS fix (every heading searched), or a pose given (searched
  // round +-6 m, +-45 deg unless --init-search off).
  const std::string init = args.get_or("--init", ds.gps.empty() ? "gt" : "gps");
  const std::string init_search = args.get_or("--init-search", "on");
  if (init_search != "on" && init_search != "off") throw Error("--init-search takes on or off");
  const std::size_t i0 = replay.scans.front();
  const double t0 = ds.times[i0];
  Eigen::Isometry3d start = Eigen::Isometry3d::Identity();
  bool search = init_search == "on";
  if (init == "gt") {
    if (!ds.has_ground_truth()) throw Error("--init gt: " + ds.dir + " has no ground-truth poses; give --init x,y,z,yaw");
    start = ds.ground_truth.poses[i0];
    search = false;
  } else if (init == "gps") {
    const auto fix = std::find_if(ds.gps.begin(), ds.gps.end(), [&](const pl::GpsFix& g) { return g.status != pl::kGpsNone && g.t >= t0 - 0.5; });
    if (fix == ds.gps.end()) throw Error("--init gps: no GPS fix at the start of " + ds.dir + "; give --init x,y,z,yaw");
    start.translation() = ds.to_world(fix->position) - ds.meta.vehicle.gps_lever_arm;  // level, facing +x
    cfg.search = cfg.gps_search;
    search = true;
  } else {
    const auto v = pl::parse_number_list(init, 4, "--init");
    start = pl::make_pose(v[0], v[1], v[2], 0, 0, v[3] * M_PI / 180.0);
  }
  replay.start = [&](pl::client::VehicleLocalizer& loc) { search ? loc.start_near(start, t0) : loc.start(start, t0); };

  if (db) {
    cfg.store_path = *db;
  } else {
    cfg.tiles.server = *server;
    cfg.tiles.cache_path = args.get_or("--cache", "");
    cfg.tiles.memory_mb = positive("--cache-mb", cfg.tiles.memory_mb);
    cfg.tiles.token = args.get_or("--token", "");
  }
  args.finish();

  pl::client::VehicleLocalizer loc(cfg);
  std::unique_ptr<std::FILE, int (*)(std::FILE*)> timing(timing_out ? std::fopen(timing_out->c_str(), "w") : nullptr, std::fclose);
  if (timing_out && !timing) throw Error("cannot write " + *timing_out);
  replay.timing = timing.get();
  pl::Progress progress("localizing", replay.scans.size());
  replay.progress = [&](std::size_t done, std::size_t) { progress.update(done); };
  const pl::client::ReplayResult r = pl::client::replay(ds, loc, replay);
  progress.finish();
  if (const std::string e = loc.last_error(); !e.empty()) std::fprintf(stderr, "pl-localize: warning: %s\n", e.c_str());
  timing.reset();
  pl::write_tum_poses(out_path, r.fused);
  if (kitti_out) pl::write_kitti_poses(*kitti_out, r.per_scan);

  const std::size_t n = replay.scans.size();
  const double span = ds.times[replay.scans.back()] - t0;
  std::printf("pl-localize: %zu scans of %s, map %s v%lld (%s), %d beams, fov %.0f, odometry %s\n", n, ds.dir.c_str(),
              cfg.tiles.map.c_str(), loc.map_version(), db ? "local store" : server->c_str(), beams, lc.scan.fov_deg, odo_kind.c_str());
  std::printf("  status: %zu ok, %zu degraded, %zu lost; LiDAR fused on %zu (%.1f %%); map looked outdated on %zu\n", r.ok,
              r.degraded, r.lost, r.lidar_fused, 100.0 * static_cast<double>(r.lidar_fused) / static_cast<double>(n), r.outdated);
  std::printf("  registration ms: median %.2f, p99 %.2f; whole scan ms: median %.2f, p99 %.2f (registration on its own thread)\n",
              pl::percentile(r.registration_ms, 50), pl::percentile(r.registration_ms, 99), pl::percentile(r.total_ms, 50),
              pl::percentile(r.total_ms, 99));
  std::printf("  fused poses: %zu (%.1f Hz over %.1f s of drive) -> %s\n", r.fused.size(),
              span > 0 ? static_cast<double>(r.fused.size()) / span : 0.0, span, out_path.c_str());
  if (!db) {
    const auto st = loc.tile_status();
    std::printf("  tiles: %zu fetched, %zu from the disk cache, %zu failures, %zu retries%s%s\n", st.fetched, st.from_disk, st.failures,
                st.retries, st.last_error.empty() ? "" : "; last error: ", st.last_error.c_str());
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) { return pl::run_cli("pl-localize", body, argc, argv); }
