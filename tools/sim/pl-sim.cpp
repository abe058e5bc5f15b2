// pl-sim: a LiDAR driving simulator writing drives in the dataset layout every tool reads. The
// simulator is pl_sim (tools/sim); this is the command line.
#include <algorithm>
#include <cstdio>
#include <string>

#include "pl/common/cli.hpp"
#include "pl/common/error.hpp"
#include "pl/sim/simulate.hpp"

int main(int argc, char** argv) {
  pl::cli::Tool tool("pl-sim", "Simulates a drive through a procedural world: LiDAR scans, wheel encoders, GPS and ground "
                     "truth, written in the KITTI odometry layout with this project's sidecars (docs/dataset-layout.md).");
  CLI::App& app = tool.app();
  pl::sim::SimOptions o;
  std::string route, world, origin;
  char origin_default[96];
  std::snprintf(origin_default, sizeof origin_default, "%.9f,%.9f,%.2f", o.origin.lat_deg, o.origin.lon_deg, o.origin.alt_m);

  pl::cli::choice(app, "--route", route, "built-in route: loop (~600 m town loop) or estate (industrial estate)", {"loop", "estate"});
  app.add_option("--trajectory", o.trajectory_path, "a KITTI pose file (cam0 poses, e.g. kitti-trajectories/00.txt); its "
                 "times from --times, else times-NN.txt or times.txt beside it, else 10 Hz")->type_name("FILE");
  app.add_option("--times", o.times_path, "the times of --trajectory")->type_name("FILE");
  app.add_flag("--lidar-poses", o.lidar_poses, "--trajectory holds LiDAR poses (e.g. from pl-dataset poses), not KITTI cam0 poses");
  pl::cli::number(app, "--speed-scale", o.speed_scale, "drive the route this many times as fast, scans still at 10 Hz "
                  "(the town loop's 9 m/s straights at 30 m/s: 3.3)", pl::cli::between(0.1, 10));
  app.add_flag("--reverse", o.reverse, "drive the route the other way round: the stretch the other options give, from its "
               "end back to its start, through the same world (the same seed gives the same things and reference cloud)");
  pl::cli::output_folder(app, "--out", o.out_dir, "where to write the dataset")->required();
  pl::cli::number(app, "--frames", o.frames, "scans to write; 0: the whole route (the world is built for the stretch driven: drives share it with the same --frames)", pl::cli::at_least(0));
  pl::cli::number(app, "--seed", o.world.seed, "world and noise seed; same seed and options, same bytes", pl::cli::at_least(0));
  pl::cli::number(app, "--drive-seed", o.drive_seed, "this drive's own randomness (traffic, sensor noise, GPS): another vehicle "
                  "or another day in the same world; default: --seed", pl::cli::at_least(0));
  pl::cli::choice(app, "--world", world, "world preset (default: town, estate for --route estate)", {"town", "estate"});
  pl::cli::number(app, "--epoch", o.world.epoch, "1: the same place six months later", pl::cli::between(0, 1));
  std::string backdrop = "on";
  pl::cli::choice(app, "--backdrop", backdrop, "on: the town goes on behind the street (the next street's houses behind the back "
                  "gardens); off: the street alone, as the first simulator's world", {"on", "off"});
  pl::cli::number(app, "--change-share", o.world.change_share, "share of movable things changed in epoch 1", pl::cli::between(0, 1));
  pl::cli::number(app, "--traffic", o.traffic.count, "moving vehicles and pedestrians", pl::cli::between(0, 1000));
  pl::cli::number(app, "--truck-share", o.traffic.truck_share, "share of the vehicles that are 2.5 m x 10 m trucks",
                  pl::cli::between(0, 1));
  pl::cli::number(app, "--pedestrian-share", o.traffic.pedestrian_share, "share of the traffic on foot", pl::cli::between(0, 1));
  pl::cli::choice(app, "--lidar", o.lidar, "the sensor", {"hdl64", "vlp16", "rs16"});
  std::string sweep = "on";
  pl::cli::choice(app, "--sweep", sweep, "on: each scan swept over 0.1 s while the vehicle moves, per-point times written to "
                  "point_times/ (as drivers give them); off: every ray from one pose", {"on", "off"});
  pl::cli::number(app, "--calibration-error", o.calibration_error, "per-laser elevation, azimuth and range errors like a "
                  "calibrated HDL-64E's (0.12 deg, 0.12 deg, 2 cm sigma), times this; 0: a perfect sensor", pl::cli::between(0, 10));
  pl::cli::number(app, "--truth-error", o.truth.scale, "the ground truth written as a GNSS/INS reports it, with the errors "
                  "of drive 0005's OXTS against its LiDAR (smooth wanders of 0.1 m in height over 2 s and 0.2 m along the track "
                  "over 10 s, 2 cm jitter), times this; 0: the exact poses the scans were taken from", pl::cli::between(0, 10));
  pl::cli::number(app, "--fov", o.fov_deg, "180: the rear half is blocked by the vehicle body (360 or 180)", pl::cli::between(180, 360));
  app.add_option("--gnss-profile", o.gnss_profile, "replay a real receiver's accuracy, status and satellites (KITTI OXTS folder)")
      ->type_name("DIR");
  pl::cli::geo_option(app, "--origin", origin, "geodetic origin of the world frame")->default_str(origin_default);
  pl::cli::output_file(app, "--preview", o.preview, "top view of the world and the trajectory (SVG)");
  pl::cli::output_file(app, "--map-out", o.map_out, "dense reference cloud of the world of this epoch, no traffic (PCD)");
  pl::cli::number(app, "--map-spacing", o.map_spacing, "point spacing of --map-out, metres", pl::cli::at_least(0.02));
  pl::cli::number(app, "--threads", o.threads, "worker threads; 0: all cores (the output does not depend on it)",
                  pl::cli::between(0, 256));
  app.add_flag("--force", o.force, "replace DIR when it already holds a dataset");

  tool.body([&] {
    if (route.empty() == o.trajectory_path.empty()) throw pl::Error("give either --route loop|estate or --trajectory FILE");
    o.sweep = sweep == "on";
    o.world.backdrop = backdrop == "on";
    if (o.lidar_poses && o.trajectory_path.empty()) throw pl::Error("--lidar-poses goes with --trajectory FILE");
    if (!route.empty()) {
      o.route = route;
      o.world.preset = route == "estate" ? "estate" : "town";
    }
    if (!world.empty()) o.world.preset = world;
    if (!origin.empty()) o.origin = pl::cli::geo_point(origin, "--origin");
    if (o.fov_deg != 360.0 && o.fov_deg != 180.0) throw pl::Error("--fov takes 360 or 180");
    const pl::sim::SimReport r = pl::sim::simulate(o);
    std::printf("wrote %zu scans to %s in %.1f s (%.1f scans/s, %d threads)\n", r.frames, o.out_dir.c_str(), r.seconds,
                r.frames / std::max(r.seconds, 1e-9), r.threads);
    std::printf("  route %.0f m over %.1f s, up to %.1f m/s; world: %zu objects (%zu movable), epoch %d, %s\n", r.length_m, r.duration_s,
                r.max_speed_mps, r.objects, r.movable, o.world.epoch, o.world.preset.c_str());
    std::printf("  points a scan: min %zu, median %.0f, max %zu (%s, %.0f deg, %s, calibration errors x%g)\n", r.points_min,
                r.points_median, r.points_max, o.lidar.c_str(), o.fov_deg, o.sweep ? "swept over 0.1 s" : "one pose a scan",
                o.calibration_error);
    std::printf("  encoder: %zu samples at 100 Hz; gps: %zu fixes (%s)\n", r.encoder_samples, r.gps_fixes, r.gps_mix.c_str());
    if (o.traffic.count) std::printf("  traffic: %d agents\n", o.traffic.count);
    if (o.world.epoch >= 1) std::printf("  changed since epoch 0: %zu things (changes.csv)\n", r.changes);
    if (o.truth.scale > 0) std::printf("  ground truth: as a GNSS/INS reports it (errors x%g)\n", o.truth.scale);
    if (!o.preview.empty()) std::printf("  preview: %s\n", o.preview.c_str());
    if (!o.map_out.empty()) std::printf("  reference cloud: %s (%zu points)\n", o.map_out.c_str(), r.map_points);
    return 0;
  });
  return tool.main(argc, argv);
}
