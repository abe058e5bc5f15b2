// pl-sim: a LiDAR driving simulator writing drives in the dataset layout every tool reads.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <map>
#include <thread>

#include "pl/common/cli.hpp"
#include "pl/common/error.hpp"
#include "pl/common/cloud_io.hpp"
#include "pl/common/progress.hpp"
#include "pl/common/text.hpp"
#include "pl/sim/simulate.hpp"

namespace {

const char* kUsage =
    "usage: pl-sim (--route loop|estate | --trajectory FILE [--times FILE]) --out DIR [options]\n"
    "\n"
    "Simulates a drive through a procedural world: LiDAR scans, wheel encoders, GPS and ground truth,\n"
    "written in the KITTI odometry layout with this project's sidecars (docs/dataset-layout.md).\n"
    "\n"
    "  --route NAME         built-in route: loop (~600 m town loop) or estate (industrial estate)\n"
    "  --trajectory FILE    a KITTI pose file (cam0 poses, e.g. kitti-trajectories/00.txt); its times\n"
    "                       from --times, else times-NN.txt or times.txt beside it, else 10 Hz\n"
    "  --frames N           scans to write (default: the whole route)\n"
    "  --seed S             world and noise seed (default 1); same seed and options, same bytes\n"
    "  --world town|estate  world preset (default: town, estate for --route estate)\n"
    "  --epoch 0|1          1 = the same place six months later (default 0)\n"
    "  --change-share X     share of movable things changed in epoch 1 (default 0.15)\n"
    "  --traffic N          moving vehicles and pedestrians (default 0)\n"
    "  --truck-share X      share of the vehicles that are 2.5 m x 10 m trucks (default 0.3)\n"
    "  --pedestrian-share X share of the traffic on foot (default 0.3)\n"
    "  --lidar NAME         hdl64 (default), vlp16 or rs16\n"
    "  --fov 360|180        180: the rear half is blocked by the vehicle body (default 360)\n"
    "  --gnss-profile DIR   replay a real receiver's accuracy, status and satellites (KITTI OXTS folder)\n"
    "  --origin LAT,LON,ALT geodetic origin of the world frame (default 49.011213,8.422885,112.83)\n"
    "  --preview FILE.svg   top view of the world and the trajectory\n"
    "  --map-out FILE.pcd   dense reference cloud of the world of this epoch (no traffic)\n"
    "  --map-spacing M      point spacing of --map-out (default 0.1)\n"
    "  --threads N          worker threads (default: all cores); the output does not depend on it\n"
    "  --force              replace DIR when it already holds a dataset\n";

int body(int argc, char** argv) {
  for (int i = 1; i < argc; ++i)
    if (std::string(argv[i]) == "--help" || std::string(argv[i]) == "-h") {
      std::fputs(kUsage, stdout);
      return 0;
    }
  if (argc < 2) {
    std::fputs(kUsage, stderr);
    return 2;
  }
  pl::Args args(argc, argv, 1, {"--force"});
  pl::sim::SimOptions o;
  auto route = args.get("--route");
  auto traj = args.get("--trajectory");
  o.times_path = args.get_or("--times", "");
  o.out_dir = args.require("--out", "DIR (where to write the dataset)");
  o.frames = args.get_int("--frames", 0);
  o.world.seed = static_cast<std::uint64_t>(args.get_int("--seed", 1));
  o.world.epoch = static_cast<int>(args.get_int("--epoch", 0));
  o.world.change_share = args.get_double("--change-share", o.world.change_share);
  o.traffic.count = static_cast<int>(args.get_int("--traffic", 0));
  o.traffic.truck_share = args.get_double("--truck-share", o.traffic.truck_share);
  o.traffic.pedestrian_share = args.get_double("--pedestrian-share", o.traffic.pedestrian_share);
  o.lidar = args.get_or("--lidar", "hdl64");
  o.fov_deg = args.get_double("--fov", 360.0);
  o.gnss_profile = args.get_or("--gnss-profile", "");
  auto world = args.get("--world");
  auto origin = args.get("--origin");
  o.preview = args.get_or("--preview", "");
  o.map_out = args.get_or("--map-out", "");
  o.map_spacing = args.get_double("--map-spacing", o.map_spacing);
  o.threads = static_cast<int>(args.get_int("--threads", 0));
  o.force = args.has("--force");
  args.finish();
  if (!args.positional().empty()) throw pl::Error("unexpected argument \"" + args.positional()[0] + "\" (see --help)");
  if (route.has_value() == traj.has_value()) throw pl::Error("give either --route loop|estate or --trajectory FILE");
  if (route) {
    if (!pl::sim::is_builtin_route(*route)) throw pl::Error("--route takes loop or estate, got \"" + *route + "\"");
    o.route = *route;
    o.world.preset = *route == "estate" ? "estate" : "town";
  } else {
    o.trajectory_path = *traj;
  }
  if (world) o.world.preset = *world;
  if (origin) {
    auto v = pl::parse_number_list(*origin, 3, "--origin");
    o.origin = {v[0], v[1], v[2]};
  }
  if (o.fov_deg != 360.0 && o.fov_deg != 180.0) throw pl::Error("--fov takes 360 or 180");
  if (o.frames < 0) throw pl::Error("--frames must be positive");
  if (o.traffic.count < 0 || o.traffic.count > 1000) throw pl::Error("--traffic takes 0 to 1000 agents");
  if (!(o.map_spacing >= 0.02)) throw pl::Error("--map-spacing must be at least 0.02 m");

  pl::sim::SimReport r = pl::sim::simulate(o);
  std::printf("wrote %zu scans to %s in %.1f s (%.1f scans/s, %d threads)\n", r.frames, o.out_dir.c_str(), r.seconds,
              r.frames / std::max(r.seconds, 1e-9), r.threads);
  std::printf("  route %.0f m over %.1f s; world: %zu objects (%zu movable), epoch %d, %s\n", r.length_m, r.duration_s,
              r.objects, r.movable, o.world.epoch, o.world.preset.c_str());
  std::printf("  points a scan: min %zu, median %.0f, max %zu (%s, %.0f deg)\n", r.points_min, r.points_median, r.points_max,
              o.lidar.c_str(), o.fov_deg);
  std::printf("  encoder: %zu samples at 100 Hz; gps: %zu fixes (%s)\n", r.encoder_samples, r.gps_fixes, r.gps_mix.c_str());
  if (o.traffic.count) std::printf("  traffic: %d agents\n", o.traffic.count);
  if (!o.preview.empty()) std::printf("  preview: %s\n", o.preview.c_str());
  if (!o.map_out.empty()) std::printf("  reference cloud: %s (%zu points)\n", o.map_out.c_str(), r.map_points);
  return 0;
}

}  // namespace

int main(int argc, char** argv) { return pl::run_cli("pl-sim", body, argc, argv); }
