#include "pl/eval/command.hpp"

#include <algorithm>

#include <cstdio>
#include <filesystem>
#include <iostream>
#include <optional>

#include "pl/common/cli.hpp"
#include "pl/common/cloud_io.hpp"
#include "pl/common/error.hpp"
#include "pl/eval/ape.hpp"
#include "pl/eval/figures.hpp"
#include "pl/eval/kitti_metrics.hpp"
#include "pl/eval/map_accuracy.hpp"
#include "pl/eval/matching.hpp"
#include "pl/eval/report.hpp"
#include "pl/eval/timing.hpp"
#include "pl/eval/topview.hpp"

namespace pl::eval {

namespace {

const char* const kApeUsage =
    "pl-eval ape --est FILE --gt FILE [--align none|se3|sim3] [--up auto|x|y|z] [--json] [--plot DIR]\n"
    "  Absolute position error of the estimate against the ground truth (metres): mean, median, rmse,\n"
    "  std (population), max, coverage, and the error split into longitudinal (along the ground\n"
    "  truth's direction of travel), lateral (horizontal perpendicular) and vertical parts.\n"
    "  KITTI files pair line by line (the estimate may be shorter); TUM files pair by timestamp\n"
    "  (nearest ground-truth time within 5 ms, each pose used once).\n"
    "  --align se3  rigidly align the estimate onto the ground truth first (default: none)\n"
    "  --align sim3 the same with a uniform scale as well (Umeyama); prints the scale applied to the\n"
    "               estimate: 1/1.03 = 0.9709 for an estimate 3 % too large\n"
    "  --up AXIS    the ground truth's vertical axis (default auto: the axis of smallest extent,\n"
    "               z for map frames, y for KITTI camera poses)\n"
    "  --json       print one JSON object instead of the table\n"
    "  --plot DIR   write trajectory.svg, error_over_distance.svg, error_histogram.svg\n";

const char* const kKittiUsage =
    "pl-eval kitti --est FILE --gt FILE [--json] [--plot DIR]\n"
    "  KITTI odometry relative errors: from every 10th frame, segments of 100, 200, ..., 800 m of\n"
    "  ground-truth path; translation error in %, rotation error in deg/100 m, overall, by segment\n"
    "  length and by speed (10 km/h bins; times from TUM stamps, else 10 Hz frames).\n"
    "  --plot DIR   write kitti_errors.svg\n";

const char* const kMapUsage =
    "pl-eval map --map MAP --ref REF [--metric surface|point] [--within 0.05] [--coverage-radius 0.5] [--json]\n"
    "  Map accuracy against a reference cloud of the same world frame (e.g. pl-sim --map-out): for\n"
    "  every map point the distance to the reference surface (default: to the plane through the\n"
    "  reference points within 2.5 spacings of the nearest one, when they are planar and the nearest\n"
    "  is within 2 spacings; else to the nearest point) or, --metric point, to the nearest reference\n"
    "  point (exact; a reference sampled every s m inflates it by up to ~s/sqrt(2)); the share within\n"
    "  --within and within 0.02, 0.05, 0.10, 0.20 m; mean, median, p90, p95, p99, max;\n"
    "  the reference's point spacing; and the reference coverage: the share of reference points with\n"
    "  a map point within --coverage-radius. Clouds: .pcd, .ply or KITTI .bin; two PCDs that record\n"
    "  different geodetic origins are an error.\n";

const char* const kTopviewUsage =
    "pl-eval topview --cloud MAP --out FILE.svg [--traj FILE[:LABEL]]... [--cell 1.0] [--shade count|height]\n"
    "                [--title TEXT]\n"
    "  An SVG top view (x east, y north, equal aspect) of a map cloud as a raster of occupied cells,\n"
    "  shaded grey by points per cell (log scale) or by the highest point, with trajectories (KITTI or\n"
    "  TUM files in the cloud's frame, z up) as coloured polylines, a legend and their starts marked.\n"
    "  --cell M     cell side in metres (default 1.0), enlarged until at most 60000 cells are occupied\n"
    "  --traj       repeatable; LABEL defaults to the file name\n";

const char* const kTimingUsage =
    "pl-eval timing --csv FILE [--column NAME] [--json] [--plot DIR]\n"
    "  Per-scan time distribution (count, min, mean, p50, p90, p99, max; percentiles interpolated\n"
    "  linearly between the closest ranks, as numpy does)\n"
    "  and a text histogram of one CSV column. Default column: registration_ms, else the only\n"
    "  column ending in _ms.\n"
    "  --plot DIR   write timing_histogram.svg\n";

void reject_positionals(const Args& args, const char* command) {
  if (!args.positional().empty())
    throw Error("unexpected argument \"" + args.positional().front() + "\" for pl-eval " + command +
                " (files go after their flag: --est, --gt, --csv, --map, --ref, --cloud, --traj; see pl-eval " + command + " --help)");
}

void print_json(std::ostream& out, nlohmann::ordered_json j, const std::vector<std::string>& plots) {
  if (!plots.empty()) j["plots"] = plots;
  out << j.dump(2) << "\n";
}

void print_plots(std::ostream& out, const std::vector<std::string>& plots) {
  if (plots.empty()) return;
  out << "\n";
  for (const auto& p : plots) out << "wrote " << p << "\n";
}

int run_ape(const Args& args, std::ostream& out) {
  if (args.has("--help")) {
    out << "usage: " << kApeUsage;
    return 0;
  }
  const std::string est_path = args.require("--est", "FILE (the estimated trajectory, KITTI or TUM)");
  const std::string gt_path = args.require("--gt", "FILE (the ground-truth trajectory, same format as --est)");
  const std::string align = args.get_or("--align", "none");
  const std::string up = args.get_or("--up", "auto");
  const bool json = args.has("--json");
  const std::optional<std::string> plot = args.get("--plot");
  args.finish();
  reject_positionals(args, "ape");

  ApeOptions options;
  const auto alignment = parse_alignment(align);
  if (!alignment) throw Error("--align takes none, se3 or sim3, got \"" + align + "\"");
  options.alignment = *alignment;
  if (up != "auto") {
    options.vertical_axis = parse_axis(up);
    if (options.vertical_axis < 0) throw Error("--up takes auto, x, y or z, got \"" + up + "\"");
  }

  const Trajectory est = read_trajectory(est_path);
  const Trajectory gt = read_trajectory(gt_path);
  const PosePairs pairs = pair_poses(est, gt, est_path, gt_path);
  const ApeResult result = compute_ape(est, gt, pairs, options);
  const std::vector<std::string> plots = plot ? write_ape_figures(result, *plot) : std::vector<std::string>{};
  if (json) {
    print_json(out, ape_json(result), plots);
  } else {
    out << ape_text(result, est_path, gt_path);
    print_plots(out, plots);
  }
  return 0;
}

int run_kitti(const Args& args, std::ostream& out) {
  if (args.has("--help")) {
    out << "usage: " << kKittiUsage;
    return 0;
  }
  const std::string est_path = args.require("--est", "FILE (the estimated trajectory, KITTI or TUM)");
  const std::string gt_path = args.require("--gt", "FILE (the ground-truth trajectory, same format as --est)");
  const bool json = args.has("--json");
  const std::optional<std::string> plot = args.get("--plot");
  args.finish();
  reject_positionals(args, "kitti");

  const Trajectory est = read_trajectory(est_path);
  const Trajectory gt = read_trajectory(gt_path);
  const PosePairs pairs = pair_poses(est, gt, est_path, gt_path);
  const KittiResult result = compute_kitti_metrics(est, gt, pairs);
  const std::vector<std::string> plots = plot ? write_kitti_figures(result, *plot) : std::vector<std::string>{};
  if (json) {
    print_json(out, kitti_json(result), plots);
  } else {
    out << kitti_text(result, est_path, gt_path);
    print_plots(out, plots);
  }
  return 0;
}

int run_timing(const Args& args, std::ostream& out) {
  if (args.has("--help")) {
    out << "usage: " << kTimingUsage;
    return 0;
  }
  const std::string csv = args.require("--csv", "FILE (a CSV log with a header line)");
  const std::optional<std::string> column = args.get("--column");
  const bool json = args.has("--json");
  const std::optional<std::string> plot = args.get("--plot");
  args.finish();
  reject_positionals(args, "timing");

  const TimingColumn data = read_timing_csv(csv, column);
  const TimingStats stats = timing_stats(data.values);
  const Histogram hist = make_histogram(data.values, default_bin_count(data.values.size()));
  const std::vector<std::string> plots = plot ? write_timing_figures(data, stats, *plot) : std::vector<std::string>{};
  if (json) {
    print_json(out, timing_json(data, stats, hist), plots);
  } else {
    out << timing_text(data, stats, hist, csv);
    print_plots(out, plots);
  }
  return 0;
}

int run_map(const Args& args, std::ostream& out) {
  if (args.has("--help")) {
    out << "usage: " << kMapUsage;
    return 0;
  }
  const std::string map_path = args.require("--map", "FILE (the map cloud to measure: .pcd, .ply or .bin)");
  const std::string ref_path = args.require("--ref", "FILE (the reference cloud of the same world: .pcd, .ply or .bin)");
  MapAccuracyOptions options;
  options.within = args.get_double("--within", options.within);
  options.coverage_radius = args.get_double("--coverage-radius", options.coverage_radius);
  const std::string metric = args.get_or("--metric", "surface");
  const bool json = args.has("--json");
  args.finish();
  reject_positionals(args, "map");
  if (metric != "surface" && metric != "point") throw Error("--metric takes surface or point, not " + metric);
  options.surface = metric == "surface";
  if (!(options.within > 0.0)) throw Error("--within takes a distance in metres above 0, e.g. --within 0.05");
  if (!(options.coverage_radius > 0.0))
    throw Error("--coverage-radius takes a distance in metres above 0, e.g. --coverage-radius 0.5");

  // Non-finite points (NaN rows are common in PCD files) carry no position: dropped.
  auto finite_only = [](Cloud c) {
    c.intensity.clear();  // not used here; it would no longer line up
    c.points.erase(std::remove_if(c.points.begin(), c.points.end(), [](const Eigen::Vector3d& p) { return !p.allFinite(); }),
                   c.points.end());
    return c;
  };
  const Cloud map = finite_only(read_cloud(map_path));
  const Cloud ref = finite_only(read_cloud(ref_path));
  if (map.points.empty()) throw Error(map_path + ": the map cloud has no points");
  if (ref.points.empty()) throw Error(ref_path + ": the reference cloud has no points");
  check_same_origin(map, map_path, ref, ref_path);
  const std::optional<GeoPoint> origin = map.origin ? map.origin : ref.origin;
  const MapAccuracy result = compute_map_accuracy(map.points, ref.points, options);
  if (json) {
    out << map_json(result, map_path, ref_path, origin).dump(2) << "\n";
    return 0;
  }
  out << map_text(result, map_path, ref_path, origin);
  if (map.origin.has_value() != ref.origin.has_value())
    out << "  note: only " << (map.origin ? map_path : ref_path) << " records a geodetic origin; "
        << (map.origin ? ref_path : map_path) << " is taken to be in the same frame\n";
  return 0;
}

int run_topview(const Args& args, std::ostream& out) {
  if (args.has("--help")) {
    out << "usage: " << kTopviewUsage;
    return 0;
  }
  const std::string cloud_path = args.require("--cloud", "FILE (the map cloud to draw: .pcd, .ply or .bin)");
  const std::string out_path = args.require("--out", "FILE.svg (where to write the top view)");
  const std::vector<std::string> traj_args = args.get_all("--traj");
  TopviewOptions options;
  options.cell = args.get_double("--cell", options.cell);
  const std::string shade = args.get_or("--shade", "count");
  const std::optional<std::string> title = args.get("--title");
  args.finish();
  reject_positionals(args, "topview");
  if (!(options.cell > 0.0)) throw Error("--cell takes a cell side in metres above 0, e.g. --cell 1.0");
  if (shade == "count")
    options.shade = TopviewShade::Count;
  else if (shade == "height")
    options.shade = TopviewShade::Height;
  else
    throw Error("--shade takes count or height, got \"" + shade + "\"");

  const Cloud cloud = read_cloud(cloud_path);
  std::vector<TopviewTrack> tracks;
  for (const auto& a : traj_args) {
    const auto [path, label] = parse_track_argument(a);
    TopviewTrack t;
    t.label = label;
    t.trajectory = read_trajectory(path);
    if (t.trajectory.poses.empty()) throw Error(path + ": no poses (--traj takes a KITTI or TUM trajectory)");
    tracks.push_back(std::move(t));
  }
  options.title = title ? *title : "Top view of " + std::filesystem::path(cloud_path).filename().string();
  const TopviewResult r = write_topview(cloud.points, tracks, options, out_path);
  char buf[256];
  std::snprintf(buf, sizeof buf, "%zu points in %zu cells of %.2f m", r.points, r.cells, r.cell);
  out << "top view: " << buf;
  if (r.cell > options.cell) {
    std::snprintf(buf, sizeof buf, " (enlarged from %.2f m to stay within 60000 cells)", options.cell);
    out << buf;
  }
  out << ", " << tracks.size() << " trajector" << (tracks.size() == 1 ? "y" : "ies") << "\n";
  std::snprintf(buf, sizeof buf, "%.1f", static_cast<double>(r.bytes) / 1024.0);
  out << "wrote " << out_path << " (" << buf << " KiB)\n";
  return 0;
}

}  // namespace

std::string usage() {
  return std::string(
             "pl-eval: evaluate localization results and maps against ground truth\n"
             "usage:\n\n") +
         kApeUsage + "\n" + kKittiUsage + "\n" + kTimingUsage + "\n" + kMapUsage + "\n" + kTopviewUsage +
         "\nBad input exits with code 2 and a message naming the file, the line and the fix.\n";
}

int eval_main(int argc, char** argv, std::ostream& out) {
  if (argc < 2) throw Error("missing command: pl-eval ape|kitti|timing|map|topview ... (see pl-eval --help)");
  const std::string command = argv[1];
  if (command == "--help" || command == "-h" || command == "help") {
    out << usage();
    return 0;
  }
  const Args args(argc, argv, 2, {"--json", "--help"});
  if (command == "ape") return run_ape(args, out);
  if (command == "kitti") return run_kitti(args, out);
  if (command == "timing") return run_timing(args, out);
  if (command == "map") return run_map(args, out);
  if (command == "topview") return run_topview(args, out);
  throw Error("unknown command \"" + command +
              "\"; the commands are ape, kitti, timing, map and topview (see pl-eval --help)");
}

int eval_main(int argc, char** argv) { return eval_main(argc, argv, std::cout); }

}  // namespace pl::eval
