#include "pl/eval/command.hpp"

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>
#include <optional>

#include "pl/common/cli.hpp"
#include "pl/common/cloud_io.hpp"
#include "pl/common/error.hpp"
#include "pl/eval/ape.hpp"
#include "pl/eval/changes.hpp"
#include "pl/eval/figures.hpp"
#include "pl/eval/kitti_metrics.hpp"
#include "pl/eval/map_accuracy.hpp"
#include "pl/eval/matching.hpp"
#include "pl/eval/report.hpp"
#include "pl/eval/timing.hpp"
#include "pl/eval/topview.hpp"

namespace pl::eval {

namespace {

const char* const kApeFooter =
    "Absolute position error of the estimate against the ground truth (metres): mean, median, rmse,\n"
    "std (population), max, coverage, and the error split into longitudinal (along the ground\n"
    "truth's direction of travel), lateral (horizontal perpendicular) and vertical parts.\n"
    "KITTI files pair line by line (the estimate may be shorter); TUM files pair by timestamp\n"
    "(nearest ground-truth time within 5 ms, each pose used once). --align sim3 prints the scale\n"
    "applied to the estimate: 1/1.03 = 0.9709 for an estimate 3 % too large.";

const char* const kKittiFooter =
    "KITTI odometry relative errors: from every 10th frame, segments of 100, 200, ..., 800 m of\n"
    "ground-truth path; translation error in %, rotation error in deg/100 m, overall, by segment\n"
    "length and by speed (10 km/h bins; times from TUM stamps, else 10 Hz frames).";

const char* const kMapFooter =
    "Map accuracy against a reference cloud of the same world frame (e.g. pl-sim --map-out): for\n"
    "every map point the distance to the reference surface (default: to the plane through the\n"
    "reference points within 2.5 spacings of the nearest one, when they are planar and the nearest\n"
    "is within 2 spacings; else to the nearest point) or, --metric point, to the nearest reference\n"
    "point (exact; a reference sampled every s m inflates it by up to ~s/sqrt(2)); the share within\n"
    "--within and within 0.02, 0.05, 0.10, 0.20 m; mean, median, p90, p95, p99 (nearest-rank), max;\n"
    "the reference's point spacing; and the reference coverage: the share of reference points with\n"
    "a map point within --coverage-radius. Clouds: .pcd, .ply or KITTI .bin; two PCDs that record\n"
    "different geodetic origins are an error.";

const char* const kTopviewFooter =
    "A top view (x east, y north, equal aspect) of a map cloud as a raster of occupied cells, shaded\n"
    "grey by points per cell (log scale) or by the highest point, with trajectories (KITTI or TUM files\n"
    "in the cloud's frame, z up) as coloured polylines and their starts marked, as an SVG or a PNG by\n"
    "--out's extension. The SVG has a title, axes and a legend. The PNG has no text: its title and\n"
    "legend (colours, metres a pixel, the box shown) go into its Title and Description chunks and are\n"
    "printed; each cell is 1 to 8 whole pixels, the image at most 1600 px on its longer side (the\n"
    "cell grows where one pixel a cell would not fit). --bounds, --highlight and --removed-from draw\n"
    "in a PNG only.";

const char* const kTimingFooter =
    "Per-scan time distribution (count, min, mean, p50, p90, p99, max; nearest-rank percentiles)\n"
    "and a text histogram of one CSV column.";

void print_json(std::ostream& out, nlohmann::ordered_json j, const std::vector<std::string>& plots) {
  if (!plots.empty()) j["plots"] = plots;
  out << j.dump(2) << "\n";
}

void print_plots(std::ostream& out, const std::vector<std::string>& plots) {
  if (plots.empty()) return;
  out << "\n";
  for (const auto& p : plots) out << "wrote " << p << "\n";
}

// --est and --gt, --json, --plot: what ape and kitti share.
struct TrajectoryArgs {
  std::string est, gt, plot, align = "none", up = "auto";
  bool json = false;
};

void add_trajectory_options(CLI::App& c, TrajectoryArgs& a, const std::string& figures) {
  c.add_option("--est", a.est, "the estimated trajectory (KITTI or TUM)")->required()->type_name("FILE");
  c.add_option("--gt", a.gt, "the ground-truth trajectory (same format as --est)")->required()->type_name("FILE");
  c.add_flag("--json", a.json, "print one JSON object instead of the table");
  cli::output_folder(c, "--plot", a.plot, "write " + figures);
}

void add_ape(cli::Tool& tool, std::ostream& out) {
  auto a = std::make_shared<TrajectoryArgs>();
  CLI::App& c = tool.command("ape", "absolute position error of an estimated trajectory against the ground truth", [a, &out] {
    ApeOptions options;
    options.alignment = *parse_alignment(a->align);
    if (a->up != "auto") options.vertical_axis = parse_axis(a->up);
    const Trajectory est = read_trajectory(a->est);
    const Trajectory gt = read_trajectory(a->gt);
    const PosePairs pairs = pair_poses(est, gt, a->est, a->gt);
    const ApeResult result = compute_ape(est, gt, pairs, options);
    const std::vector<std::string> plots = a->plot.empty() ? std::vector<std::string>{} : write_ape_figures(result, a->plot);
    if (a->json) {
      print_json(out, ape_json(result), plots);
    } else {
      out << ape_text(result, a->est, a->gt);
      print_plots(out, plots);
    }
    return 0;
  });
  add_trajectory_options(c, *a, "trajectory.svg, error_over_distance.svg, error_histogram.svg");
  cli::choice(c, "--align", a->align, "none; se3: rigidly align the estimate onto the ground truth first; sim3: the same with a "
              "uniform scale as well (Umeyama)", {"none", "se3", "sim3"});
  cli::choice(c, "--up", a->up, "the ground truth's vertical axis (auto: the axis of smallest extent, z for map frames, y for "
              "KITTI camera poses)", {"auto", "x", "y", "z"});
  c.footer(kApeFooter);
}

void add_kitti(cli::Tool& tool, std::ostream& out) {
  auto a = std::make_shared<TrajectoryArgs>();
  CLI::App& c = tool.command("kitti", "KITTI odometry relative errors (translation %, rotation deg/100 m)", [a, &out] {
    const Trajectory est = read_trajectory(a->est);
    const Trajectory gt = read_trajectory(a->gt);
    const PosePairs pairs = pair_poses(est, gt, a->est, a->gt);
    const KittiResult result = compute_kitti_metrics(est, gt, pairs);
    const std::vector<std::string> plots = a->plot.empty() ? std::vector<std::string>{} : write_kitti_figures(result, a->plot);
    if (a->json) {
      print_json(out, kitti_json(result), plots);
    } else {
      out << kitti_text(result, a->est, a->gt);
      print_plots(out, plots);
    }
    return 0;
  });
  add_trajectory_options(c, *a, "kitti_errors.svg");
  c.footer(kKittiFooter);
}

void add_timing(cli::Tool& tool, std::ostream& out) {
  struct Args {
    std::string csv, column, plot;
    bool json = false;
  };
  auto a = std::make_shared<Args>();
  CLI::App& c = tool.command("timing", "the per-scan time distribution of one CSV column", [a, &out] {
    const TimingColumn data = read_timing_csv(a->csv, a->column.empty() ? std::nullopt : std::optional<std::string>(a->column));
    const TimingStats stats = timing_stats(data.values);
    const Histogram hist = make_histogram(data.values, default_bin_count(data.values.size()));
    const std::vector<std::string> plots = a->plot.empty() ? std::vector<std::string>{} : write_timing_figures(data, stats, a->plot);
    if (a->json) {
      print_json(out, timing_json(data, stats, hist), plots);
    } else {
      out << timing_text(data, stats, hist, a->csv);
      print_plots(out, plots);
    }
    return 0;
  });
  c.add_option("--csv", a->csv, "a CSV log with a header line")->required()->type_name("FILE");
  c.add_option("--column", a->column, "the column (default: registration_ms, else the only column ending in _ms)")->type_name("NAME");
  c.add_flag("--json", a->json, "print one JSON object instead of the table");
  cli::output_folder(c, "--plot", a->plot, "write timing_histogram.svg");
  c.footer(kTimingFooter);
}

void add_map(cli::Tool& tool, std::ostream& out) {
  struct Args {
    std::string map, ref, metric = "surface";
    bool json = false;
    MapAccuracyOptions options;
  };
  auto a = std::make_shared<Args>();
  CLI::App& c = tool.command("map", "map accuracy against a reference cloud of the same world frame", [a, &out] {
    MapAccuracyOptions options = a->options;
    options.surface = a->metric == "surface";
    // Non-finite points (NaN rows are common in PCD files) carry no position: dropped.
    auto finite_only = [](Cloud cloud) {
      cloud.intensity.clear();  // not used here; it would no longer line up
      auto& p = cloud.points;
      p.erase(std::remove_if(p.begin(), p.end(), [](const Eigen::Vector3d& x) { return !x.allFinite(); }), p.end());
      return cloud;
    };
    const Cloud map = finite_only(read_cloud(a->map));
    const Cloud ref = finite_only(read_cloud(a->ref));
    if (map.points.empty()) throw Error(a->map + ": the map cloud has no points");
    if (ref.points.empty()) throw Error(a->ref + ": the reference cloud has no points");
    check_same_origin(map, a->map, ref, a->ref);
    const std::optional<GeoPoint> origin = map.origin ? map.origin : ref.origin;
    const MapAccuracy result = compute_map_accuracy(map.points, ref.points, options);
    if (a->json) {
      out << map_json(result, a->map, a->ref, origin).dump(2) << "\n";
      return 0;
    }
    out << map_text(result, a->map, a->ref, origin);
    if (map.origin.has_value() != ref.origin.has_value())
      out << "  note: only " << (map.origin ? a->map : a->ref) << " records a geodetic origin; " << (map.origin ? a->ref : a->map)
          << " is taken to be in the same frame\n";
    return 0;
  });
  c.add_option("--map", a->map, "the map cloud to measure (.pcd, .ply or .bin)")->required()->type_name("FILE");
  c.add_option("--ref", a->ref, "the reference cloud of the same world (.pcd, .ply or .bin)")->required()->type_name("FILE");
  cli::choice(c, "--metric", a->metric, "distance to the reference surface, or to the nearest reference point", {"surface", "point"});
  cli::number(c, "--within", a->options.within, "the headline share: map points this close to the reference, metres", cli::above(0));
  cli::number(c, "--coverage-radius", a->options.coverage_radius, "a reference point is covered when a map point is this close, "
              "metres", cli::above(0));
  c.add_flag("--json", a->json, "print one JSON object instead of the table");
  c.footer(kMapFooter);
}

void add_topview(cli::Tool& tool, std::ostream& out) {
  struct Args {
    std::string cloud, out, shade = "count", title, bounds, highlight, removed_from;
    std::vector<std::string> traj;
    TopviewOptions options;
  };
  auto a = std::make_shared<Args>();
  CLI::App& c = tool.command("topview", "a top view of a map cloud with trajectories (SVG or PNG)", [a, &out] {
    TopviewOptions options = a->options;
    options.shade = a->shade == "height" ? TopviewShade::Height : TopviewShade::Count;
    if (!a->bounds.empty()) options.bounds = parse_bounds(a->bounds);
    const Cloud cloud = read_cloud(a->cloud);
    Points3d highlight;
    if (!a->highlight.empty()) highlight = read_cloud(a->highlight).points;
    if (!a->removed_from.empty()) highlight = points_missing_from(read_cloud(a->removed_from).points, cloud.points);
    std::vector<TopviewTrack> tracks;
    for (const auto& arg : a->traj) {
      const auto [path, label] = parse_track_argument(arg);
      TopviewTrack t;
      t.label = label;
      t.trajectory = read_trajectory(path);
      if (t.trajectory.poses.empty()) throw Error(path + ": no poses (--traj takes a KITTI or TUM trajectory)");
      tracks.push_back(std::move(t));
    }
    options.title = a->title.empty() ? "Top view of " + std::filesystem::path(a->cloud).filename().string() : a->title;
    const TopviewResult r = write_topview(cloud.points, tracks, options, a->out, highlight);
    char buf[256];
    std::snprintf(buf, sizeof buf, "%zu points in %zu cells of %.2f m", r.points, r.cells, r.cell);
    out << "top view: " << buf;
    if (r.cell > options.cell) {
      if (r.png) std::snprintf(buf, sizeof buf, " (enlarged from %.2f m to fit %d px)", options.cell, kTopviewMaxPixels);
      else std::snprintf(buf, sizeof buf, " (enlarged from %.2f m to stay within %zu cells)", options.cell, options.max_cells);
      out << buf;
    }
    out << ", " << tracks.size() << " trajector" << (tracks.size() == 1 ? "y" : "ies") << "\n";
    if (!a->removed_from.empty())
      out << highlight.size() << " points of " << a->removed_from << " are not in " << a->cloud << "\n";
    if (r.png) {
      std::snprintf(buf, sizeof buf, "%d x %d px, %d px a cell", r.width, r.height, r.pixels_per_cell);
      out << "image: " << buf << "; legend (the PNG's Description): " << r.legend << "\n";
    }
    std::snprintf(buf, sizeof buf, "%.1f", static_cast<double>(r.bytes) / 1024.0);
    out << "wrote " << a->out << " (" << buf << " KiB)\n";
    return 0;
  });
  c.add_option("--cloud", a->cloud, "the map cloud to draw (.pcd, .ply or .bin)")->required()->type_name("FILE");
  cli::output_file(c, "--out", a->out, "where to write the top view: FILE.svg (with a legend) or FILE.png (no text)")->required();
  c.add_option("--traj", a->traj, "a trajectory to draw (KITTI or TUM); repeatable; LABEL defaults to the file name")
      ->type_name("FILE[:LABEL]")->allow_extra_args(false)
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  cli::number(c, "--cell", a->options.cell, "cell side, metres; for an SVG enlarged until at most " +
              std::to_string(a->options.max_cells) + " cells are occupied, for a PNG until the image fits " +
              std::to_string(kTopviewMaxPixels) + " px", cli::above(0));
  cli::choice(c, "--shade", a->shade, "grey by points per cell (log scale) or by the highest point", {"count", "height"});
  c.add_option("--title", a->title, "the figure's title (default: \"Top view of CLOUD\"; a PNG's Title chunk)");
  c.add_option("--bounds", a->bounds, "(PNG) draw only this box of the xy plane, metres (default: everything, with a margin)")
      ->type_name("XMIN,YMIN,XMAX,YMAX");
  auto* highlight = c.add_option("--highlight", a->highlight, "(PNG) a second cloud whose cells are drawn in red over the map")
      ->type_name("FILE");
  c.add_option("--removed-from", a->removed_from, "(PNG) the cloud before a filter: its points that --cloud lacks (same "
               "coordinates, as pl-map build --moving remove leaves the rest) are drawn in red over the map")
      ->type_name("FILE")->excludes(highlight);
  c.footer(kTopviewFooter);
}

void add_changes(cli::Tool& tool, std::ostream& out) {
  struct Args {
    std::string truth, candidates;
    ChangeTruthOptions options;
  };
  auto a = std::make_shared<Args>();
  CLI::App& c = tool.command("changes", "score change candidates (pl-map changes --out) per tile against pl-sim's changes.csv", [a, &out] {
    out << change_score_text(score_changes(a->truth, a->candidates, a->options));
    return 0;
  });
  c.add_option("--truth", a->truth, "pl-sim's changes.csv of an epoch-1 drive (changes_seen.csv beside it is read too)")->required()->type_name("FILE");
  c.add_option("--candidates", a->candidates, "pl-map changes --out")->required()->type_name("FILE");
  cli::number(c, "--tile", a->options.tile_m, "the map's tile size, m", cli::above(0));
  cli::number(c, "--min-rays", a->options.min_rays, "a tile truly changed where this many of the drive's probe rays saw a "
              "change in it (changes_seen.csv, beside changes.csv)", cli::at_least(1));
}

}  // namespace

void add_commands(cli::Tool& tool, std::ostream& out) {
  add_ape(tool, out);
  add_kitti(tool, out);
  add_timing(tool, out);
  add_map(tool, out);
  add_topview(tool, out);
  add_changes(tool, out);
  tool.app().footer("Bad input exits with code 2 and a message naming the file, the line and the fix.");
}

int eval_main(int argc, char** argv, std::ostream& out) {
  cli::Tool tool("pl-eval", "Evaluate localization results and maps against ground truth.");
  add_commands(tool, out);
  return tool.main(argc, argv);
}

int eval_main(int argc, char** argv) { return eval_main(argc, argv, std::cout); }

}  // namespace pl::eval
