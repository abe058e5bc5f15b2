// pl-localize: localizes a drive (dataset directory) against a tiled map, streamed from pl-server or
// read from a local map store, and writes the poses: a replay of the drive through
// pl::client::VehicleLocalizer, the API a vehicle program embeds. See docs/pl-localize.md.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>

#include "pl/client/config_fields.hpp"
#include "pl/client/replay.hpp"
#include "pl/client/report_outbox.hpp"
#include "pl/client/run_log.hpp"
#include "pl/client/status_reporter.hpp"
#include "pl/client/vehicle_localizer.hpp"
#include "pl/common/cli.hpp"
#include "pl/common/dataset.hpp"
#include "pl/common/error.hpp"
#include "pl/common/geo.hpp"
#include "pl/common/progress.hpp"
#include "pl/common/stats.hpp"

namespace {

using pl::Error;
namespace cli = pl::cli;

// The dataset indices of --scans all|even|odd, every --every-th of them from the --phase-th, then
// --first K and --count N.
std::vector<std::size_t> choose_scans(const pl::Dataset& ds, const std::string& which, std::size_t every, std::size_t phase,
                                      std::size_t first, std::size_t count) {
  std::vector<std::size_t> scans;
  for (std::size_t i = 0; i < ds.size(); ++i) {
    const long f = ds.frame_ids.empty() ? static_cast<long>(i) : ds.frame_ids[i];
    if (which == "all" || (which == "even") == (f % 2 == 0)) scans.push_back(i);
  }
  if (every > 1) {
    std::vector<std::size_t> kept;
    for (std::size_t k = phase; k < scans.size(); k += every) kept.push_back(scans[k]);
    scans.swap(kept);
  }
  if (first >= scans.size())
    throw Error("--first " + std::to_string(first) + " is not one of the " + std::to_string(scans.size()) + " " + which + " scans");
  const std::size_t end = first + std::min(count, scans.size() - first);  // (first + count would wrap: count defaults to the largest size_t)
  return std::vector<std::size_t>(scans.begin() + static_cast<long>(first), scans.begin() + static_cast<long>(end));
}

// The start: ground truth, the first GPS fix (every heading searched), a pose given (searched within
// --init-radius unless --init-search off), or none (global: the map's places).
// Returns the start's position in the map frame when it is known before the map is (not with
// --init global, nor a GPS fix placed about the map's origin).
std::optional<Eigen::Vector3d> choose_start(const pl::Dataset& ds, const std::string& init, bool search,
                                            pl::client::VehicleLocalizerConfig& cfg, pl::client::ReplayOptions& replay) {
  const double t0 = ds.times[replay.scans.front()];
  Eigen::Isometry3d start = Eigen::Isometry3d::Identity();
  if (init == "global") {
    replay.start = [t0](pl::client::VehicleLocalizer& loc) { loc.start_global(t0); };
    return std::nullopt;
  }
  if (init == "gt") {
    if (!ds.has_ground_truth()) throw Error("--init gt: " + ds.dir + " has no ground-truth poses; give --init x,y,z,yaw");
    start = ds.ground_truth.poses[replay.scans.front()];
    search = false;
  } else if (init == "gps") {
    const auto fix = std::find_if(ds.gps.begin(), ds.gps.end(), [&](const pl::GpsFix& g) { return g.status != pl::kGpsNone && g.t >= t0 - 0.5; });
    if (fix == ds.gps.end()) throw Error("--init gps: no GPS fix at the start of " + ds.dir + "; give --init x,y,z,yaw");
    start.translation() = ds.to_world(fix->position) - ds.meta.vehicle.gps_lever_arm;  // level, facing +x
    cfg.search = cfg.gps_search;
    // A drive whose world frame is ENU about its own origin (a recording: its first fix) places the
    // fix about the map's origin instead: the map may come from another drive.
    if (ds.projection.kind == pl::WorldProjection::Kind::Enu && ds.projection.world_from_projected.isApprox(Eigen::Isometry3d::Identity())) {
      const pl::GeoPoint at = fix->position;
      const Eigen::Vector3d lever = ds.meta.vehicle.gps_lever_arm;
      replay.start = [at, lever, t0](pl::client::VehicleLocalizer& loc) {
        Eigen::Isometry3d p = Eigen::Isometry3d::Identity();
        p.translation() = pl::EnuFrame(loc.map_origin()).to_enu(at) - lever;
        loc.start_near(p, t0);
      };
      return std::nullopt;
    }
    search = true;
  } else {
    const auto v = pl::parse_number_list(init, 4, "--init");
    start = pl::make_pose(v[0], v[1], v[2], 0, 0, v[3] * M_PI / 180.0);
  }
  replay.start = [start, t0, search](pl::client::VehicleLocalizer& loc) { search ? loc.start_near(start, t0) : loc.start(start, t0); };
  return start.translation();
}

// A start outside the map finds nothing to register to: said before the drive, with what would
// find the vehicle.
void check_start(const pl::client::VehicleLocalizer& loc, const std::optional<Eigen::Vector3d>& start, const std::string& map) {
  const auto extent = loc.map_extent();
  if (!start || !extent) return;
  const double off = extent->distance(start->x(), start->y());
  if (off <= 0) return;
  std::fprintf(stderr,
               "pl-localize: the start (%.1f, %.1f) lies %.0f m outside map '%s' (its points span x %.0f..%.0f m, y %.0f..%.0f m): "
               "the scans will find no map there; --init global (the map's places) or --init gps (the drive's first GPS fix) "
               "finds the vehicle\n",
               start->x(), start->y(), off, map.c_str(), extent->min_x, extent->max_x, extent->min_y, extent->max_y);
}

// The settings pl-localize sets itself from its options and the drive: the map source (set after
// --set is applied) and the beams (which also decide whether the rings are handed over). --set
// refuses them: it would be overruled silently, or contradict the drive.
const char* owner_of_setting(const std::string& name) {
  if (name == "localizer/scan/beams") return "--beams";
  if (name == "localizer/scan/sensor_beams") return "the drive's sensor";
  if (name == "tiles/server") return "--server";
  if (name == "store_path") return "--db";
  if (name == "tiles/map") return "--map";
  return nullptr;
}

// --set NAME=VALUE, checked while parsing (against a scratch config: the value is applied later).
std::string setting_problem(const std::string& text) {
  const auto eq = text.find('=');
  if (eq == std::string::npos)
    return "--set takes NAME=VALUE, got \"" + text + "\"; pl-localize --list-settings lists the names";
  const std::string name = text.substr(0, eq);
  if (const char* owner = owner_of_setting(name))
    return "--set " + name + ": pl-localize sets it from " + owner + "; use that instead";
  pl::client::VehicleLocalizerConfig scratch;
  const auto fields = pl::client::config_fields(scratch);
  const auto field = std::find_if(fields.begin(), fields.end(), [&](const auto& f) { return f.name == name; });
  try {
    pl::client::set_config_field(scratch, name, text.substr(eq + 1));
  } catch (const Error& e) {
    // "--set X takes a number, got ..." names the setting already; an unknown name points at the list.
    return field != fields.end() ? std::string("--set ") + e.what()
                                 : std::string("--set: ") + e.what() + "; pl-localize --list-settings lists them all";
  }
  // Its range (a setting against another, such as min_range_m below max_range_m, is checked when
  // the localizer is made, with every --set applied).
  const std::string problem = pl::client::config_field_range_problem(*field);
  return problem.empty() ? "" : "--set " + problem;
}

void apply_settings(pl::client::VehicleLocalizerConfig& cfg, const std::vector<std::string>& settings) {
  for (const std::string& s : settings) {
    const auto eq = s.find('=');
    pl::client::set_config_field(cfg, s.substr(0, eq), s.substr(eq + 1));
  }
}

// --list-settings: NAME=VALUE (the value before the drive is read: the defaults, with the options
// and --set given), then what it does and what it takes; one a line.
void list_settings(pl::client::VehicleLocalizerConfig cfg, const std::vector<std::string>& settings) {
  apply_settings(cfg, settings);
  const auto fields = pl::client::config_fields(cfg);
  std::vector<std::string> lefts;
  std::size_t width = 0;
  for (const auto& f : fields) {
    lefts.push_back(f.name + "=" + pl::client::config_field_text(f));
    width = std::max(width, lefts.back().size());
  }
  for (std::size_t i = 0; i < fields.size(); ++i) {
    const char* owner = owner_of_setting(fields[i].name);
    std::printf("%-*s  %s (%s%s%s)\n", static_cast<int>(width), lefts[i].c_str(), fields[i].help.c_str(),
                pl::client::config_field_type(fields[i]), owner ? "; pl-localize sets it from " : "", owner ? owner : "");
  }
}

}  // namespace

int main(int argc, char** argv) {
  cli::Tool tool("pl-localize", "Localizes a drive against a tiled map (from pl-server, or a local map store) and writes the "
                 "fused poses: the drive replayed through the embeddable VehicleLocalizer.");
  CLI::App& app = tool.app();
  pl::client::VehicleLocalizerConfig cfg;
  pl::client::LocalizerConfig& lc = cfg.localizer;
  std::string dataset, server, db, out, kitti_out, timing_out, log_out, odometry = "auto", init, init_search = "on", scans = "all";
  long long version = 0;
  int beams = 0;
  std::size_t every = 1, phase = 0, first = 0, count = std::numeric_limits<std::size_t>::max();
  bool realtime = false;
  pl::DatasetOptions topics;
  cli::dataset_option(app, dataset, topics, "the drive to localize");
  auto* server_opt = app.add_option("--server", server, "pl-server's address: https://HOST[:PORT] (http:// to this machine, or with --insecure-http)")->type_name("URL");
  auto* db_opt = app.add_option("--db", db, "a local map store instead of a server")->type_name("FILE");
  server_opt->excludes(db_opt);
  app.add_option("--map", cfg.tiles.map, "the map's name (pl-map list)")->required();
  cli::number(app, "--map-version", version, "the map version (default: the current one)", cli::at_least(1))->default_str("");
  cli::number(app, "--follow", cfg.tiles.follow_s, "with --server: ask this often which map version is current and move to a newer "
              "one mid-drive, its tiles loaded first (0: stay on the version of the start), s", cli::at_least(0));
  cli::number(app, "--beams", beams, "beams kept of the sensor's (every k-th ring; default: all)", cli::between(1, 1024))->default_str("");
  cli::number(app, "--fov", lc.scan.fov_deg, "horizontal field of view kept, degrees, centred ahead", cli::above_up_to(0, 360));
  cli::choice(app, "--odometry", odometry, "what predicts between scans (auto: encoder, else odometry, else lidar momentum)",
              {"auto", "encoder", "odometry", "lidar"});
  app.add_option("--init", init, "start: x,y,z,yaw (degrees), gt, gps, or global (no pose: the map's places are searched; "
                 "default: gps when the drive has fixes, else gt)");
  cli::choice(app, "--init-search", init_search, "search round an --init x,y,z,yaw (within --init-radius, +-45 deg)", {"on", "off"});
  cli::number(app, "--init-radius", cfg.search.radius_m, "how far from an --init x,y,z,yaw the vehicle may be, metres",
              cli::above(0));
  std::string lidar_odometry = "on", deskew = "auto";
  cli::choice(app, "--deskew", deskew, "correct each scan for the motion during its sweep with the predicted motion, each point "
              "timed by its azimuth (auto: on when the drive has point_times/, as pl-sim's; off otherwise: on KITTI raw it "
              "did not help, see docs/pl-localize.md; use on with a map built with pl-map build --deskew on)", {"auto", "on", "off"});
  cli::choice(app, "--lidar-odometry", lidar_odometry, "LiDAR odometry where no other odometry covers the motion", {"on", "off"});
  cli::choice(app, "--scans", scans, "which scans", {"all", "even", "odd"});
  cli::number(app, "--every", every, "keep every k-th of those scans (the same drive k times faster)", cli::between(1, 1000));
  cli::number(app, "--phase", phase, "with --every K, start at the P-th of those scans, 0 to K-1 (each phase is one of "
              "the K drives interleaved in the recording)", cli::at_least(0));
  std::vector<std::size_t> cut;
  std::string cut_clock = "keep";
  app.add_option("--cut", cut, "leave out N scans after the K-th of those kept (the vehicle moved while blind)")
      ->type_name("K,N")->delimiter(',')->expected(2);
  cli::choice(app, "--cut-clock", cut_clock, "keep: the clock runs on over the cut; close: it does not (a kidnapping with no "
              "hint; LiDAR only)", {"keep", "close"});
  cli::number(app, "--first", first, "skip this many of them", cli::at_least(0));
  cli::number(app, "--count", count, "localize at most this many", cli::at_least(1))->default_str("all");
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
  std::string report_out, vehicle = "vehicle", drive_id;
  double drive_start = -1;
  cli::output_file(app, "--change-report", report_out, "keep change evidence from the ok scans and write the drive's change "
                   "report (JSON, what POST /v1/maps/{map}/reports takes; docs/map-updates.md)");
  std::string spool, report_server, report_token;
  app.add_option("--report-spool", spool, "keep change evidence and put the drive's report in this spool directory, then send "
                 "what waits there to the map service (POST /v1/maps/{map}/reports; kept until it is taken)")->type_name("DIR");
  app.add_option("--report-server", report_server, "where --report-spool sends to (default: --server)")->type_name("URL");
  app.add_option("--report-token", report_token, "a token of the report role, for --report-spool and --status-every");
  double status_every = 0;
  cli::number(app, "--status-every", status_every, "tell the map service the vehicle's position and health every this many "
              "seconds (POST /v1/maps/{map}/vehicles/{--vehicle}: the viewer shows it live; needs --report-token)",
              cli::between(0.05, 3600))->default_str("off");
  app.add_option("--vehicle", vehicle, "the report's vehicle id (drives of one vehicle are not independent evidence)");
  app.add_option("--drive-id", drive_id, "the report's drive id (default: the drive folder's name and the start time)");
  cli::number(app, "--drive-start", drive_start, "the drive's start, seconds since 1970, for the report (default: now "
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
  app.add_flag("--realtime", realtime, "pace the replay at the drive's clock");
  // Every other setting by name (pl/client/config_fields.hpp, the table a ROS node's parameters use).
  std::vector<std::string> settings;
  app.add_option("--set", settings, "any localizer setting, repeatable; applied after the other options and what is taken "
                 "from the drive (--list-settings lists them)")
      ->type_name("NAME=VALUE")
      ->allow_extra_args(false)
      ->check(CLI::Validator([](std::string& text) { return setting_problem(text); }, ""));
  // Defined after --set: CLI11 runs the callbacks in the options' order, so the list shows the --set values.
  app.add_flag_callback("--list-settings", [&] {
        list_settings(cfg, settings);
        throw CLI::Success();
      }, "print every setting --set takes, NAME=VALUE with its value, what it does and its type, and exit");

  tool.body([&] {
    if (server.empty() == db.empty()) throw Error("give exactly one of --server URL (pl-server) or --db FILE (a local map store)");
    if (phase >= every)
      throw Error("--phase " + std::to_string(phase) + " must be below --every " + std::to_string(every) +
                  ": the phases of --every K are 0 to K-1 (run pl-localize --help)");
    const pl::Dataset ds = pl::open_dataset(dataset, topics);
    const int sensor = ds.meta.sensor.beams;
    if (beams == 0) beams = sensor;
    if (beams > sensor || sensor % beams != 0)
      throw Error("--beams must divide the sensor's " + std::to_string(sensor) + " beams, got " + std::to_string(beams));
    lc.scan.beams = beams;
    lc.lidar_odometry = lidar_odometry == "on";
    lc.scan.sensor_beams = sensor;
    if (version > 0) cfg.tiles.version = version;
    pl::client::ReplayOptions replay;
    replay.scans = choose_scans(ds, scans, every, phase, first, count);
    if (!cut.empty()) {
      if (cut[0] < 1 || cut[0] + cut[1] >= replay.scans.size())
        throw Error("--cut " + std::to_string(cut[0]) + "," + std::to_string(cut[1]) + ": keep at least one scan before and after the cut (of " +
                    std::to_string(replay.scans.size()) + ")");
      const double gap = ds.times[replay.scans[cut[0] + cut[1]]] - ds.times[replay.scans[cut[0]]];
      replay.scans.erase(replay.scans.begin() + static_cast<long>(cut[0]), replay.scans.begin() + static_cast<long>(cut[0] + cut[1]));
      if (cut_clock == "close") {
        replay.time_shift.assign(replay.scans.size(), 0.0);
        for (std::size_t k = cut[0]; k < replay.scans.size(); ++k) replay.time_shift[k] = -gap;
      }
    }
    replay.rings = beams < sensor;
    replay.realtime = realtime;
    if (odometry == "auto") odometry = !ds.encoder.empty() ? "encoder" : !ds.odometry.empty() ? "odometry" : "lidar";
    if (odometry == "encoder") {
      if (ds.encoder.empty()) throw Error("--odometry encoder: " + ds.dir + " has no encoder.csv");
      cfg.wheel_base_m = ds.meta.vehicle.wheel_base_m;
      if (!(cfg.wheel_base_m > 0))
        throw Error("encoder odometry needs vehicle.wheel_base_m > 0 in meta.json (got " + std::to_string(cfg.wheel_base_m) + ")");
      replay.odometry = pl::client::OdometrySource::Encoder;
    } else if (odometry == "odometry") {
      if (ds.odometry.empty()) throw Error("--odometry odometry: " + ds.dir + " has no odometry.csv");
      replay.odometry = pl::client::OdometrySource::Poses;
    }
    if (!replay.time_shift.empty() && replay.odometry != pl::client::OdometrySource::None)
      throw Error("--cut-clock close needs --odometry lidar (the odometry's own clock cannot be closed over the cut)");
    // auto: on for scans that carry their points' times (the sensor says it sweeps), off otherwise.
    lc.compensate_motion = deskew == "on" || (deskew == "auto" && ds.has_point_times());
    if (ds.meta.sensor.rate_hz > 0) lc.sweep_s = 1.0 / ds.meta.sensor.rate_hz;
    // --set last, over the options and the drive's values; before the start, which copies gps_search.
    apply_settings(cfg, settings);
    const auto start = choose_start(ds, init.empty() ? (ds.gps.empty() ? "gt" : "gps") : init, init_search == "on", cfg, replay);
    if (db.empty()) cfg.tiles.server = server;
    else cfg.store_path = db;
    cfg.on_wait = [](const std::string& line) { std::fprintf(stderr, "pl-localize: %s\n", line.c_str()); };

    cfg.changes.enabled = !report_out.empty() || !spool.empty();
    std::unique_ptr<pl::client::ReportOutbox> outbox;
    if (!spool.empty()) {  // opened before the drive: a spool that cannot be written is said at once
      pl::client::ReportOutboxConfig oc;
      oc.dir = spool;
      oc.server = report_server.empty() ? server : report_server;
      oc.token = report_token;
      oc.http.ca_file = cfg.tiles.ca_file;
      oc.http.insecure_http = cfg.tiles.insecure_http;
      outbox = std::make_unique<pl::client::ReportOutbox>(oc);
    }
    std::unique_ptr<pl::client::StatusReporter> status;
    if (status_every > 0) {
      pl::client::StatusReporterConfig sc;
      sc.server = report_server.empty() ? server : report_server;
      sc.token = report_token;
      sc.map = cfg.tiles.map;
      sc.vehicle = vehicle;
      sc.every_s = status_every;
      sc.http.ca_file = cfg.tiles.ca_file;
      sc.http.insecure_http = cfg.tiles.insecure_http;
      sc.http.timeout_s = 2.0;
      status = std::make_unique<pl::client::StatusReporter>(sc);
    }
    pl::client::VehicleLocalizer loc(cfg);  // after the reporter: its callback may run until the localizer stops
    check_start(loc, start, cfg.tiles.map);
    if (status) {
      const Eigen::Isometry3d lidar_to_base = cfg.base_from_lidar.inverse();
      loc.on_scan([&status, lidar_to_base](const pl::client::ScanReport& r) { status->update(r.fused * lidar_to_base, r.health, r.t); });
    }
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
    std::size_t report_tiles = 0, report_bytes = 0;
    std::vector<std::string> dropped;
    pl::client::OutboxSend sent;
    if (!report_out.empty() || outbox) {
      pl::schema::ChangeReport rep;
      rep.map = cfg.tiles.map;
      rep.version = loc.map_version();
      rep.vehicle = vehicle;
      rep.start = drive_start >= 0 ? drive_start : static_cast<double>(std::time(nullptr)) - span;
      rep.end = rep.start + span;
      rep.drive = drive_id.empty() ? std::filesystem::path(ds.dir).filename().string() + "-" + std::to_string(static_cast<long long>(rep.start))
                                   : drive_id;
      rep.voxel_m = cfg.changes.voxel_m;
      rep.tile_m = loc.tile_size();
      rep.tiles = loc.change_evidence();
      const std::string text = pl::schema::change_report_json(rep);
      pl::schema::parse_change_report(text);  // what the service will accept (names, ids, bounds)
      if (!report_out.empty()) {
        const std::string tmp = report_out + ".partial";
        {
          std::ofstream f(tmp, std::ios::binary | std::ios::trunc);
          f << text;
          if (!f.flush()) throw pl::Error(tmp + ": write failed");
        }
        std::filesystem::rename(tmp, report_out);
      }
      report_tiles = rep.tiles.size();
      report_bytes = text.size();
      if (outbox) {
        dropped = outbox->put(rep);
        sent = outbox->send();
      }
    }
    std::printf("pl-localize: %zu scans of %s, map %s v%lld (%s), %d beams, fov %.0f, odometry %s\n", n, ds.dir.c_str(),
                cfg.tiles.map.c_str(), loc.map_version(), db.empty() ? server.c_str() : "local store", beams, lc.scan.fov_deg,
                odometry.c_str());
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
    if (!report_out.empty() || outbox) {
      const auto cs = loc.change_stats();
      std::printf("  change report: evidence from %zu ok scans (%zu passed over, the next scan waiting; median %.1f ms a scan), "
                  "%zu tiles, %.1f kB -> %s\n",
                  cs.scans, cs.skipped, cs.ms.empty() ? 0.0 : pl::percentile(cs.ms, 50), report_tiles,
                  static_cast<double>(report_bytes) / 1e3, report_out.empty() ? spool.c_str() : report_out.c_str());
    }
    if (status) {
      const auto st = status->stats();
      std::printf("  status to the map service: %zu sent, %zu failed%s%s\n", st.sent, st.failed, st.last_error.empty() ? "" : ": ",
                  st.last_error.c_str());
    }
    if (outbox) {
      for (const auto& d : dropped) std::fprintf(stderr, "pl-localize: warning: the report spool is full: dropped %s\n", d.c_str());
      std::printf("  report spool: %zu sent (%.1f kB gzipped), %zu held by the service already, %zu refused (%s/refused), "
                  "%zu waiting%s%s\n", sent.sent, static_cast<double>(sent.bytes) / 1e3, sent.already, sent.refused, spool.c_str(),
                  sent.waiting, sent.last_error.empty() ? "" : ": ", sent.last_error.c_str());
    }
    if (db.empty()) {
      const auto st = loc.tile_status();
      std::printf("  tiles: %zu fetched, %zu from the disk cache, %zu failures, %zu retries%s%s\n", st.fetched, st.from_disk, st.failures,
                  st.retries, st.last_error.empty() ? "" : "; last error: ", st.last_error.c_str());
    }
    return 0;
  });
  return tool.main(argc, argv);
}
