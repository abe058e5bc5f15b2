// pl-dataset: what a drive folder holds, its ground-truth poses and GPS, and a copy of a drive with
// a degraded (consumer-grade) GPS. The work is in pl_dataset (tools/dataset); this is the command line.
#include <cstdio>
#include <functional>
#include <memory>
#include <optional>
#include <string>

#include "pl/common/cli.hpp"
#include "pl/common/error.hpp"
#include "pl/common/progress.hpp"
#include "pl/dataset/degrade_gps.hpp"
#include "pl/dataset/gps_export.hpp"
#include "pl/dataset/info.hpp"
#include "pl/dataset/scan_stats.hpp"
#include "pl/recordings/dataset.hpp"
#include "pl/recordings/dataset_cli.hpp"

namespace {

using pl::cli::Tool;

// A progress(done, total) callback drawing one bar.
struct Bar {
  std::optional<pl::Progress> bar;
  std::string label;
  std::function<void(std::size_t, std::size_t)> callback() {
    return [this](std::size_t done, std::size_t total) {
      if (!bar) bar.emplace(label, total);
      bar->update(done);
    };
  }
};

CLI::App& dir_command(Tool& tool, const std::string& name, const std::string& help, std::string& dir, pl::DatasetOptions& topics,
                      std::function<int()> body) {
  CLI::App& c = tool.command(name, help, std::move(body));
  c.add_option("DIR", dir, "the drive: a KITTI odometry or raw folder, pl-sim's output, a ROS 1 bag, a ROS 2 bag (folder or .db3) "
               "or an MCAP file")->required();
  pl::cli::topic_options(c, topics);
  return c;
}

void add_info(Tool& tool) {
  struct State {
    std::string dir;
    pl::DatasetOptions topics;
    bool json = false;
    pl::dataset::InfoConfig cfg;
  };
  auto s = std::make_shared<State>();
  CLI::App& c = dir_command(tool, "info", "the layout found, scans, duration, points per scan, beams, ground-truth path length, "
                            "GPS fixes and their status mix, and the sidecar files present (or what is wrong)", s->dir, s->topics, [s] {
    const pl::Dataset ds = pl::open_dataset(s->dir, s->topics);
    Bar bar{{}, "reading scans"};
    const auto info = pl::dataset::dataset_info(ds, s->cfg, bar.callback());
    if (bar.bar) bar.bar->finish();
    std::fputs(s->json ? (info.dump(2) + "\n").c_str() : pl::dataset::dataset_info_text(ds, info).c_str(), stdout);
    return 0;
  });
  c.add_flag("--json", s->json, "print one JSON object instead of the table");
  pl::cli::number(c, "--sample", s->cfg.sample, "scans read (evenly spaced) for the per-scan figures", pl::cli::at_least(1));
}

void add_poses(Tool& tool) {
  struct State {
    std::string dir, out, format = "kitti";
    pl::DatasetOptions topics;
  };
  auto s = std::make_shared<State>();
  CLI::App& c = dir_command(tool, "poses", "the ground-truth LiDAR poses, one per scan (KITTI: 12 numbers a line; TUM: t x y z qx qy qz qw)",
                            s->dir, s->topics, [s] {
    const pl::Dataset ds = pl::open_dataset(s->dir, s->topics);
    if (!ds.has_ground_truth())
      throw pl::Error(ds.dir + ": no ground truth (a KITTI odometry folder needs poses.txt; a raw drive needs oxts/)");
    pl::Trajectory gt = ds.ground_truth;
    gt.frame = "lidar";  // the header says so, and which frame of the drive each line is
    gt.frame_ids = ds.frame_ids;
    pl::write_trajectory(s->out, gt, *pl::parse_pose_format(s->format));
    std::printf("wrote %zu ground-truth LiDAR poses to %s (%s)\n", ds.ground_truth.size(), s->out.c_str(), s->format.c_str());
    return 0;
  });
  pl::cli::output_file(c, "--out", s->out, "where to write the poses")->required();
  pl::cli::choice(c, "--format", s->format, "pose file format", {"kitti", "tum"});
}

void add_scans(Tool& tool) {
  struct State {
    std::string dir, timing;
    pl::DatasetOptions topics;
    pl::ScanPrepConfig cfg = pl::dataset::scan_stats_defaults();
  };
  auto s = std::make_shared<State>();
  CLI::App& c = dir_command(tool, "scans", "prepares every scan as the localizer does (beam choice, field-of-view and range "
                            "crops, voxel grid) and reports points in and out", s->dir, s->topics, [s] {
    const pl::Dataset ds = pl::open_dataset(s->dir, s->topics);
    Bar bar{{}, "preparing scans"};
    const auto stats = pl::dataset::prepare_every_scan(ds, s->cfg, s->timing, bar.callback());
    if (bar.bar) bar.bar->finish();
    std::fputs(pl::dataset::scan_stats_text(stats, s->cfg).c_str(), stdout);
    if (!s->timing.empty()) std::printf("per-scan figures in %s\n", s->timing.c_str());
    return 0;
  });
  pl::cli::number(c, "--beams", s->cfg.beams, "keep this many of the sensor's beams (every k-th ring); 0 keeps all", pl::cli::at_least(0));
  pl::cli::number(c, "--fov", s->cfg.fov_deg, "horizontal field of view kept, degrees, centred straight ahead", pl::cli::above_up_to(0, 360));
  pl::cli::number(c, "--min-range", s->cfg.min_range_m, "returns closer than this are dropped, metres", pl::cli::at_least(0));
  pl::cli::number(c, "--max-range", s->cfg.max_range_m, "returns farther than this are dropped, metres", pl::cli::above(0));
  pl::cli::number(c, "--voxel", s->cfg.voxel_m, "voxel-grid side, metres; 0 keeps every point", pl::cli::at_least(0));
  pl::cli::output_file(c, "--timing", s->timing, "write frame,points_in,points_out,prepare_ms per scan (CSV)");
}

void add_gps(Tool& tool) {
  struct State {
    std::string dir, out, truth, status;
    pl::DatasetOptions topics;
  };
  auto s = std::make_shared<State>();
  CLI::App& c = dir_command(tool, "gps", "the GPS fixes as positions in the dataset's world frame (TUM, identity rotations)", s->dir, s->topics, [s] {
    std::optional<int> wanted;
    for (int k = pl::kGpsSingle; k <= pl::kGpsFixed; ++k)
      if (s->status == pl::gps_status_name(k)) wanted = k;
    const pl::Dataset ds = pl::open_dataset(s->dir, s->topics);
    const auto r = pl::dataset::gps_positions(ds, wanted, !s->truth.empty());
    pl::write_tum_poses(s->out, r.fixes);
    std::printf("wrote %zu GPS positions to %s", r.fixes.size(), s->out.c_str());
    if (!s->truth.empty()) {
      pl::write_tum_poses(s->truth, r.truth);
      std::printf(" and the true antenna positions to %s", s->truth.c_str());
    }
    std::printf("%s\n", r.skipped ? (" (" + std::to_string(r.skipped) + " fixes outside the drive left out)").c_str() : "");
    return 0;
  });
  pl::cli::output_file(c, "--out", s->out, "where to write the GPS positions (TUM)")->required();
  pl::cli::output_file(c, "--truth", s->truth, "also write where the antenna really was at each fix (ground truth + lever arm), so "
                       "that pl-eval ape --est FILE --gt TRUTH measures the receiver");
  pl::cli::choice(c, "--status", s->status, "keep the fixes of one status only", {"rtk-fixed", "rtk-float", "dgps", "single"});
}

void add_degrade_gps(Tool& tool) {
  struct State {
    std::string dir, out;
    pl::DatasetOptions topics;
    pl::dataset::DegradeGpsConfig cfg;
  };
  auto s = std::make_shared<State>();
  CLI::App& c = dir_command(tool, "degrade-gps", "writes OUT_DIR: the same drive with a consumer-grade gps.csv", s->dir, s->topics, [s] {
    const pl::Dataset ds = pl::open_dataset(s->dir, s->topics);
    const auto r = pl::dataset::degrade_gps(ds, s->out, s->cfg);
    std::fputs(pl::dataset::degrade_gps_text(r, ds.dir, s->out, s->cfg).c_str(), stdout);
    return 0;
  });
  pl::cli::output_folder(c, "--out", s->out, "the folder of the new drive")->required()->type_name("OUT_DIR");
  pl::cli::number(c, "--rate", s->cfg.rate_hz, "fixes kept a second (at most the source's rate)", pl::cli::above(0));
  pl::cli::number(c, "--sigma", s->cfg.sigma_m, "noise per horizontal axis, metres (1.5 x sigma vertically)", pl::cli::at_least(0));
  pl::cli::number(c, "--seed", s->cfg.seed, "noise seed: same seed, same file", pl::cli::at_least(0));
  c.footer("Every file of DIR is reached through a symlink (nothing is copied); gps.csv holds DIR's fixes thinned to --rate,\n"
           "each moved by zero-mean Gaussian noise (white: independent from fix to fix), status single, std_m = sigma.\n"
           "OUT_DIR must either not exist, be empty, or be an earlier degrade-gps output (marked by .pl-degrade-gps; it\n"
           "is replaced).");
}

}  // namespace

int main(int argc, char** argv) {
  Tool tool("pl-dataset", "What a drive folder holds, its ground-truth poses and GPS, and a copy of a drive with a "
            "degraded (consumer-grade) GPS.");
  add_info(tool);
  add_poses(tool);
  add_scans(tool);
  add_gps(tool);
  add_degrade_gps(tool);
  return tool.main(argc, argv);
}
