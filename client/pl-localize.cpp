// pl-localize: localizes a drive (dataset directory) against a tiled map, streamed from pl-server or
// read from a local map store, and writes the poses: a replay of the drive through
// pl::client::VehicleLocalizer, the API a vehicle program embeds. See docs/pl-localize.md.
#include <cstdio>
#include <memory>

#include "pl/client/config_fields.hpp"
#include "pl/client/drive_reports.hpp"
#include "pl/client/replay.hpp"
#include "pl/client/run_log.hpp"
#include "pl/client/vehicle_localizer.hpp"
#include "pl/common/cli.hpp"
#include "pl/common/error.hpp"
#include "pl/common/progress.hpp"
#include "pl/common/stats.hpp"
#include "pl/recordings/dataset.hpp"
#include "pl/recordings/dataset_cli.hpp"

namespace cli = pl::cli;
using pl::Error;

int main(int argc, char** argv) {
  cli::Tool tool("pl-localize", "Localizes a drive against a tiled map (from pl-server, or a local map store) and writes the "
                 "fused poses: the drive replayed through the embeddable VehicleLocalizer.");
  CLI::App& app = tool.app();
  pl::client::VehicleLocalizerConfig cfg;
  pl::client::LocalizerConfig& lc = cfg.localizer;
  pl::client::ReplayPlan plan;
  pl::client::DriveReportsConfig reporting;
  std::string dataset, server, db, out, kitti_out, timing_out, log_out;
  long long version = 0;
  pl::DatasetOptions topics;
  cli::dataset_option(app, dataset, topics, "the drive to localize");
  auto* server_opt = app.add_option("--server", server, "pl-server's address: https://HOST[:PORT] (http:// to this machine, or with --insecure-http)")->type_name("URL");
  auto* db_opt = app.add_option("--db", db, "a local map store instead of a server")->type_name("FILE");
  server_opt->excludes(db_opt);
  app.add_option("--map", cfg.tiles.map, "the map's name (pl-map list)")->required();
  cli::number(app, "--map-version", version, "the map version (default: the current one)", cli::at_least(1))->default_str("");
  cli::number(app, "--follow", cfg.tiles.follow_s, "with --server: ask this often which map version is current and move to a newer "
              "one mid-drive, its tiles loaded first (0: stay on the version of the start), s", cli::at_least(0));
  cli::number(app, "--beams", plan.beams, "beams kept of the sensor's (every k-th ring; default: all)", cli::between(1, 1024))->default_str("");
  cli::number(app, "--fov", lc.scan.fov_deg, "horizontal field of view kept, degrees, centred ahead", cli::above_up_to(0, 360));
  cli::choice(app, "--odometry", plan.odometry, "what predicts between scans (auto: encoder, else odometry, else lidar momentum)",
              {"auto", "encoder", "odometry", "lidar"});
  app.add_option("--init", plan.init, "start: x,y,z,yaw (degrees), gt, gps, or global (no pose: the map's places are searched; "
                 "default: gps when the drive has fixes, else gt)");
  cli::choice(app, "--init-search", plan.init_search, "search round an --init x,y,z,yaw (within --init-radius, +-45 deg)", {"on", "off"});
  cli::number(app, "--init-radius", cfg.search.radius_m, "how far from an --init x,y,z,yaw the vehicle may be, metres",
              cli::above(0));
  cli::choice(app, "--deskew", plan.deskew, "correct each scan for the motion during its sweep with the predicted motion, each point "
              "timed by its azimuth (auto: on when the drive has point_times/, as pl-sim's; off otherwise: on KITTI raw it "
              "did not help, see docs/pl-localize.md; use on with a map built with pl-map build --deskew on)", {"auto", "on", "off"});
  cli::choice(app, "--lidar-odometry", plan.lidar_odometry, "LiDAR odometry where no other odometry covers the motion", {"on", "off"});
  cli::choice(app, "--scans", plan.scans, "which scans", {"all", "even", "odd"});
  cli::number(app, "--every", plan.every, "keep every k-th of those scans (the same drive k times faster)", cli::between(1, 1000));
  cli::number(app, "--phase", plan.phase, "with --every K, start at the P-th of those scans, 0 to K-1 (each phase is one of "
              "the K drives interleaved in the recording)", cli::at_least(0));
  app.add_option("--cut", plan.cut, "leave out N scans after the K-th of those kept (the vehicle moved while blind)")
      ->type_name("K,N")->delimiter(',')->expected(2);
  cli::choice(app, "--cut-clock", plan.cut_clock, "keep: the clock runs on over the cut; close: it does not (a kidnapping with no "
              "hint; LiDAR only)", {"keep", "close"});
  cli::number(app, "--first", plan.first, "skip this many of them", cli::at_least(0));
  cli::number(app, "--count", plan.count, "localize at most this many", cli::at_least(1))->default_str("all");
  cli::number(app, "--voxel", lc.scan.voxel_m, "registration voxels, m", cli::above(0));
  cli::number(app, "--max-range", lc.scan.max_range_m, "scan range kept, m", cli::above(0));
  cli::number(app, "--roi-radius", lc.roi_radius_m, "map tiles kept round the prediction, m", cli::above(0));
  cli::number(app, "--delta", lc.icp.max_pair_m, "pairs farther apart are dropped, m", cli::above(0));
  cli::number(app, "--cell", lc.map.cell_m, "ROI map hash cell, m", cli::above(0));
  cli::number(app, "--max-iterations", lc.icp.max_iterations, "ICP iterations at most", cli::between(1, 10000));
  cli::number(app, "--kernel", lc.icp.kernel_m, "Geman-McClure kernel floor, m", cli::above(0));
  cli::number(app, "--momentum-window", lc.fusion.momentum_window, "scan intervals of the momentum's height, roll and pitch velocity", cli::between(1, 100));
  cli::number(app, "--momentum-plane-s", lc.fusion.momentum_plane_s,
              "seconds of the momentum's velocity in the ground plane (along, across, yaw): the last scan intervals within it, at "
              "least one", cli::between(0, 100));
  cli::output_file(app, "--out", out, "the fused poses (TUM)")->required();
  cli::output_file(app, "--kitti-out", kitti_out, "one pose per scan (KITTI)");
  cli::output_file(app, "--change-report", reporting.file, "keep change evidence from the ok scans and write the drive's change "
                   "report (JSON, what POST /v1/maps/{map}/reports takes; docs/map-updates.md)");
  app.add_option("--report-spool", reporting.spool, "keep change evidence and put the drive's report in this spool directory, then send "
                 "what waits there to the map service (POST /v1/maps/{map}/reports; kept until it is taken)")->type_name("DIR");
  app.add_option("--report-server", reporting.server, "where --report-spool sends to (default: --server)")->type_name("URL");
  app.add_option("--report-token", reporting.token, "a token of the report role, for --report-spool and --status-every");
  cli::number(app, "--status-every", reporting.status_every_s, "tell the map service the vehicle's position and health every this many "
              "seconds (POST /v1/maps/{map}/vehicles/{--vehicle}: the viewer shows it live; needs --report-token)",
              cli::between(0.05, 3600))->default_str("off");
  app.add_option("--vehicle", reporting.vehicle, "the report's vehicle id (drives of one vehicle are not independent evidence)");
  app.add_option("--drive-id", reporting.drive, "the report's drive id (default: the drive folder's name and the start time)");
  cli::number(app, "--drive-start", reporting.start, "the drive's start, seconds since 1970, for the report (default: now "
              "minus the drive's span)", cli::at_least(0))->default_str("");
  cli::output_file(app, "--timing", timing_out, "per-scan CSV: times, pairs, health");
  pl::client::RunLogOptions log_options;
  cli::output_file(app, "--log", log_out, "the run as an MCAP file Foxglove opens: fused poses, scans as registered, the ROI "
                   "map's tiles, GPS fixes, per-scan health and timings (docs/run-logs.md)");
  cli::number(app, "--log-scan-voxel", log_options.scan_voxel_m, "--log: the scans' points thinned to one per voxel of this, m",
              cli::above(0));
  cli::number(app, "--log-map-voxel", log_options.map_voxel_m, "--log: the map tiles' points thinned to one per voxel of this, m",
              cli::above(0));
  cli::output_file(app, "--cache", cfg.tiles.cache_path, "the tile client's disk cache (SQLite)");
  cli::number(app, "--cache-mb", cfg.tiles.memory_mb, "decoded tiles kept in memory, MiB", cli::above(0));
  app.add_option("--token", cfg.tiles.token, "bearer token when the server requires one for reads");
  app.add_option("--ca-file", cfg.tiles.ca_file, "https: PEM file of the CA the server's certificate must chain to (default: the system's)")->type_name("FILE");
  app.add_flag("--insecure-http", cfg.tiles.insecure_http, "allow plain http:// to another machine (the map and the token in clear)");
  app.add_option("--fleet-keys", cfg.tiles.fleet_keys, "PEM file of the fleet's Ed25519 public key(s) (pl-map key-gen): use only map "
                 "versions signed with one of them, and each tile only with the hash the signed manifest gives")->type_name("FILE");
  app.add_option("--timestamp-keys", cfg.tiles.timestamp_keys, "PEM file of the map service's timestamp public key(s) (pl-server "
                 "--timestamp-key; with --fleet-keys): start only on the version a fresh signed statement names current, or on the "
                 "newest one this vehicle has verified")->type_name("FILE");
  app.add_flag("--realtime", plan.realtime, "pace the replay at the drive's clock");
  // Every other setting by name (pl/client/config_fields.hpp, the table a ROS node's parameters use).
  std::vector<std::string> settings;
  app.add_option("--set", settings, "any localizer setting, repeatable; applied after the other options and what is taken "
                 "from the drive (--list-settings lists them)")
      ->type_name("NAME=VALUE")
      ->allow_extra_args(false)
      ->check(CLI::Validator([](std::string& text) { return pl::client::setting_problem(text); }, ""));
  // Defined after --set: CLI11 runs the callbacks in the options' order, so the list shows the --set values.
  app.add_flag_callback("--list-settings", [&] {
        std::fputs(pl::client::settings_list(cfg, settings).c_str(), stdout);
        throw CLI::Success();
      }, "print every setting --set takes, NAME=VALUE with its value, what it does and its type, and exit");

  tool.body([&] {
    if (server.empty() == db.empty()) throw Error("give exactly one of --server URL (pl-server) or --db FILE (a local map store)");
    if (plan.phase >= plan.every)
      throw Error("--phase " + std::to_string(plan.phase) + " must be below --every " + std::to_string(plan.every) +
                  ": the phases of --every K are 0 to K-1 (run pl-localize --help)");
    const pl::Dataset ds = pl::open_dataset(dataset, topics);
    if (version > 0) cfg.tiles.version = version;
    pl::client::ReplayOptions replay = pl::client::plan_replay(ds, plan, cfg);
    // --set last, over the options and the drive's values; before the start, which copies gps_search.
    pl::client::apply_settings(cfg, settings);
    const auto start = pl::client::choose_start(ds, plan, cfg, replay);
    if (db.empty()) cfg.tiles.server = server;
    else cfg.store_path = db;
    cfg.on_wait = [](const std::string& line) { std::fprintf(stderr, "pl-localize: %s\n", line.c_str()); };
    if (reporting.server.empty()) reporting.server = server;
    pl::client::DriveReports reports(reporting, cfg);
    pl::client::VehicleLocalizer loc(cfg);  // after the reports: the status reporter's callback may run until the localizer stops
    if (const std::string w = pl::client::start_outside_map(loc, start, cfg.tiles.map); !w.empty())
      std::fprintf(stderr, "pl-localize: %s\n", w.c_str());
    reports.watch(loc, cfg.base_from_lidar);
    std::unique_ptr<std::FILE, int (*)(std::FILE*)> timing(timing_out.empty() ? nullptr : std::fopen(timing_out.c_str(), "w"), std::fclose);
    if (!timing_out.empty() && !timing) throw Error("cannot write " + timing_out);
    replay.timing = timing.get();
    std::unique_ptr<pl::client::RunLog> log;
    if (!log_out.empty()) {
      log_options.scan = lc.scan;  // the points the localizer keeps (beams, field of view, range)
      log = std::make_unique<pl::client::RunLog>(log_out, log_options);
      replay.log = log.get();
    }
    pl::Progress progress("localizing", replay.scans.size());
    replay.progress = [&](std::size_t done, std::size_t) { progress.update(done); };
    const pl::client::ReplayResult r = pl::client::replay(ds, loc, replay);
    progress.finish();
    if (const std::string e = loc.last_error(); !e.empty()) std::fprintf(stderr, "pl-localize: warning: %s\n", e.c_str());
    timing.reset();
    if (log) log->close();
    pl::write_tum_poses(out, r.fused);
    if (!kitti_out.empty()) pl::write_kitti_poses(kitti_out, r.per_scan);
    const std::size_t n = replay.scans.size();
    const double span = ds.times[replay.scans.back()] - ds.times[replay.scans.front()];
    reports.finish(loc, ds.dir, span);

    std::printf("pl-localize: %zu scans of %s, map %s v%lld (%s), %d beams, fov %.0f, odometry %s\n", n, ds.dir.c_str(),
                cfg.tiles.map.c_str(), loc.map_version(), db.empty() ? server.c_str() : "local store", plan.beams, lc.scan.fov_deg,
                plan.odometry.c_str());
    if (loc.version_moves() > 0)
      std::printf("  map version moved %zu time(s) mid-drive, to v%lld\n", loc.version_moves(), loc.map_version());
    std::printf("  status: %zu ok, %zu degraded, %zu lost; LiDAR fused on %zu (%.1f %%); map looked outdated on %zu; "
                "unpaired share %.1f %%\n", r.ok, r.degraded, r.lost, r.lidar_fused,
                100.0 * static_cast<double>(r.lidar_fused) / static_cast<double>(n), r.outdated, 100.0 * r.unpaired_share());
    std::printf("  registration ms: median %.2f, p99 %.2f; whole scan ms: median %.2f, p99 %.2f (registration on its own thread)\n",
                pl::percentile(r.registration_ms, 50), pl::percentile(r.registration_ms, 99), pl::percentile(r.total_ms, 50),
                pl::percentile(r.total_ms, 99));
    std::printf("  fused poses: %zu (%.1f Hz over %.1f s of drive) -> %s\n", r.fused.size(),
                span > 0 ? static_cast<double>(r.fused.size()) / span : 0.0, span, out.c_str());
    if (log) {
      const auto& c = log->counts();
      std::printf("  log: %llu poses, %llu scans, %llu map updates, %llu GPS fixes -> %s (%.1f MB)\n",
                  static_cast<unsigned long long>(c.at("/pose")), static_cast<unsigned long long>(c.at("/scan")),
                  static_cast<unsigned long long>(c.at("/map")), static_cast<unsigned long long>(c.at("/gps")), log_out.c_str(),
                  static_cast<double>(log->bytes()) / 1e6);
    }
    reports.print_summary(loc, stdout, stderr);
    if (db.empty()) {
      const auto st = loc.tile_status();
      std::printf("  tiles: %zu fetched, %zu from the disk cache, %zu failures, %zu retries%s%s\n", st.fetched, st.from_disk, st.failures,
                  st.retries, st.last_error.empty() ? "" : "; last error: ", st.last_error.c_str());
    }
    return 0;
  });
  return tool.main(argc, argv);
}
