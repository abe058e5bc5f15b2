#include "pl/eval/command.hpp"

#include <iostream>
#include <optional>

#include "pl/common/cli.hpp"
#include "pl/common/error.hpp"
#include "pl/eval/ape.hpp"
#include "pl/eval/figures.hpp"
#include "pl/eval/kitti_metrics.hpp"
#include "pl/eval/matching.hpp"
#include "pl/eval/report.hpp"
#include "pl/eval/timing.hpp"

namespace pl::eval {

namespace {

const char* const kApeUsage =
    "pl-eval ape --est FILE --gt FILE [--align none|se3] [--up auto|x|y|z] [--json] [--plot DIR]\n"
    "  Absolute position error of the estimate against the ground truth (metres): mean, median, rmse,\n"
    "  std (population), max, coverage, and the error split into longitudinal (along the ground\n"
    "  truth's direction of travel), lateral (horizontal perpendicular) and vertical parts.\n"
    "  KITTI files pair line by line (the estimate may be shorter); TUM files pair by timestamp\n"
    "  (nearest ground-truth time within 5 ms, each pose used once).\n"
    "  --align se3  rigidly align the estimate onto the ground truth first (default: none)\n"
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

const char* const kTimingUsage =
    "pl-eval timing --csv FILE [--column NAME] [--json] [--plot DIR]\n"
    "  Per-scan time distribution (count, min, mean, p50, p90, p99, max; nearest-rank percentiles)\n"
    "  and a text histogram of one CSV column. Default column: registration_ms, else the only\n"
    "  column ending in _ms.\n"
    "  --plot DIR   write timing_histogram.svg\n";

void reject_positionals(const Args& args, const char* command) {
  if (!args.positional().empty())
    throw Error("unexpected argument \"" + args.positional().front() + "\" for pl-eval " + command +
                " (files go after --est/--gt/--csv; see pl-eval " + command + " --help)");
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
  if (!alignment) throw Error("--align takes none or se3, got \"" + align + "\"");
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

}  // namespace

std::string usage() {
  return std::string(
             "pl-eval: evaluate localization results against ground truth\n"
             "usage:\n\n") +
         kApeUsage + "\n" + kKittiUsage + "\n" + kTimingUsage +
         "\nBad input exits with code 2 and a message naming the file, the line and the fix.\n";
}

int eval_main(int argc, char** argv, std::ostream& out) {
  if (argc < 2) throw Error("missing command: pl-eval ape|kitti|timing ... (see pl-eval --help)");
  const std::string command = argv[1];
  if (command == "--help" || command == "-h" || command == "help") {
    out << usage();
    return 0;
  }
  const Args args(argc, argv, 2, {"--json", "--help"});
  if (command == "ape") return run_ape(args, out);
  if (command == "kitti") return run_kitti(args, out);
  if (command == "timing") return run_timing(args, out);
  throw Error("unknown command \"" + command + "\"; the commands are ape, kitti and timing (see pl-eval --help)");
}

int eval_main(int argc, char** argv) { return eval_main(argc, argv, std::cout); }

}  // namespace pl::eval
