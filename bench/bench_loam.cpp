// LOAM-style odometry alone over a drive: per-scan time of LoamOdometry::add (features + scan-to-map +
// map update, one thread; reading the scan and its rings is not timed), and the drift against the
// dataset's ground truth when it has one (started at its first pose).
//   bench_loam DATASET_DIR [--frames N] [--every K] [--deskew auto|on|off] [--set name=value,...]
//              [--traj-out FILE] [--timing FILE.csv]
// --deskew auto: on for real recordings (no meta.json), off for pl-sim drives (as pl-map build).
// --every K runs every K-th scan only (a lower scan rate). --set overrides LoamConfig fields
// (pl/maps/loam.hpp) by name. --traj-out writes one pose per scan run (KITTI format) for
// `pl-eval kitti --est FILE --gt GT`; --timing a CSV of each scan's time and matched features.
// The benchmark reports; it never fails on a figure.
#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include "bench_util.hpp"
#include "pl/common/cli.hpp"
#include "pl/common/error.hpp"
#include "pl/maps/loam.hpp"
#include "pl/recordings/dataset.hpp"

namespace {

// --set name=value,name=value: overrides of the odometry's settings, for experiments.
void apply_settings(const std::string& text, pl::maps::LoamConfig& c) {
  std::size_t pos = 0;
  while (pos < text.size()) {
    std::size_t end = text.find(',', pos);
    if (end == std::string::npos) end = text.size();
    const std::string item = text.substr(pos, end - pos);
    pos = end + 1;
    const std::size_t eq = item.find('=');
    if (eq == std::string::npos) throw pl::Error("--set: expected name=value, found " + item);
    const std::string name = item.substr(0, eq);
    const double v = std::stod(item.substr(eq + 1));
    const int iv = static_cast<int>(v);
    if (name == "min_range_m") c.min_range_m = v;
    else if (name == "max_range_m") c.max_range_m = v;
    else if (name == "threads") c.threads = iv;
    else if (name == "curvature_neighbours") c.curvature_neighbours = iv;
    else if (name == "sectors") c.sectors = iv;
    else if (name == "edge_curvature") c.edge_curvature = v;
    else if (name == "plane_curvature") c.plane_curvature = v;
    else if (name == "max_edges_per_sector") c.max_edges_per_sector = iv;
    else if (name == "max_planes_per_sector") c.max_planes_per_sector = iv;
    else if (name == "occlusion_ratio") c.occlusion_ratio = v;
    else if (name == "grazing_ratio") c.grazing_ratio = v;
    else if (name == "edge_voxel_m") c.edge_voxel_m = v;
    else if (name == "plane_voxel_m") c.plane_voxel_m = v;
    else if (name == "map_cell_m") c.map_cell_m = v;
    else if (name == "map_points_per_cell") c.map_points_per_cell = iv;
    else if (name == "map_radius_m") c.map_radius_m = v;
    else if (name == "keyframe_m") c.keyframe_m = v;
    else if (name == "keyframe_deg") c.keyframe_deg = v;
    else if (name == "max_rematches") c.max_rematches = iv;
    else if (name == "rematch_m") c.rematch_m = v;
    else if (name == "rematch_rad") c.rematch_rad = v;
    else if (name == "converged_m") c.converged_m = v;
    else if (name == "converged_rad") c.converged_rad = v;
    else if (name == "iterations_per_match") c.iterations_per_match = iv;
    else if (name == "max_neighbour_m") c.max_neighbour_m = v;
    else if (name == "plane_fit_m") c.plane_fit_m = v;
    else if (name == "line_ratio") c.line_ratio = v;
    else if (name == "kernel_m") c.kernel_m = v;
    else if (name == "max_residual_m") c.max_residual_m = v;
    else if (name == "min_correspondences") c.min_correspondences = iv;
    else if (name == "max_correction_m") c.max_correction_m = v;
    else if (name == "max_correction_deg") c.max_correction_deg = v;
    else if (name == "degenerate_ratio") c.degenerate_ratio = v;
    else if (name == "scan_period_s") c.scan_period_s = v;
    else throw pl::Error("--set: no setting " + name + " (see pl/maps/loam.hpp)");
  }
}

struct Options {
  std::string dir, deskew = "auto", set, traj_out, timing_out;
  long long frames = 0;
  std::size_t every = 1;
};

int run(const Options& o) {
  pl::Dataset ds = pl::open_dataset(o.dir);
  const long long frames = o.frames > 0 ? o.frames : static_cast<long long>(ds.size());
  const std::size_t every = o.every;
  pl::maps::LoamConfig cfg;
  // As pl-map build: on for real recordings (no meta.json), off for pl-sim's undistorted scans.
  cfg.deskew = o.deskew == "on" || (o.deskew == "auto" && !ds.has_meta_file);
  if (ds.meta.sensor.rate_hz > 0) cfg.scan_period_s = 1.0 / ds.meta.sensor.rate_hz;
  if (!o.set.empty()) apply_settings(o.set, cfg);
  const std::size_t n_all = std::min<std::size_t>(ds.size(), static_cast<std::size_t>(std::max(0LL, frames)));
  if (n_all == 0) throw pl::Error(ds.dir + ": no scans");
  // The scans run: every `every`-th of the first n_all (a lower scan rate, for experiments).
  std::vector<std::size_t> idx;
  for (std::size_t i = 0; i < n_all; i += every) idx.push_back(i);
  const std::size_t n = idx.size();

  pl::maps::LoamOdometry odo(cfg);
  const bool gt = ds.has_ground_truth();
  if (gt) odo.start(ds.ground_truth.poses[0]);
  pl::Trajectory est;
  std::vector<double> ms, feat_edges, feat_planes, iters;
  std::size_t degenerate = 0, keyframes = 0, points = 0;
  for (std::size_t i = 0; i < n; ++i) {
    pl::Frame frame = ds.load_frame(idx[i]);
    pl::Scan& scan = frame.scan;
    auto& rings = frame.rings;
    points += scan.size();
    pl::maps::LoamFrame f = odo.add(scan, rings, ds.times[idx[i]]);
    est.poses.push_back(f.pose);
    ms.push_back(f.ms);
    feat_edges.push_back(f.edges);
    feat_planes.push_back(f.planes);
    iters.push_back(f.iterations);
    degenerate += f.degenerate;
    keyframes += f.keyframe;
    if ((i + 1) % 100 == 0) std::fprintf(stderr, "  %zu/%zu scans, median %.1f ms so far\r", i + 1, n, pl::median(ms));
  }
  std::fprintf(stderr, "%60s\r", "");
  std::printf("%s: %zu scans, %zu points a scan (mean), deskew %s\n", ds.dir.c_str(), n, points / n, cfg.deskew ? "on" : "off");
  std::printf("  time a scan      median %.1f ms, p90 %.1f ms, p99 %.1f ms, max %.1f ms (target: median <= 50 ms)\n", pl::median(ms),
              pl::percentile(ms, 90), pl::percentile(ms, 99), pl::percentile(ms, 100));
  std::printf("  matched features median %.0f edges, %.0f planes; Gauss-Newton steps median %.0f; %zu keyframes; %zu degenerate scans\n",
              pl::median(feat_edges), pl::median(feat_planes), pl::median(iters), keyframes, degenerate);
  std::printf("  local map at the end: %zu edge points, %zu plane points\n", odo.map_edges(), odo.map_planes());
  if (gt) {
    double path = 0, rel_t = 0, rel_r = 0, rel_t_max = 0;
    std::vector<double> rel;
    for (std::size_t i = 1; i < n; ++i) {
      const pl::Pose& g0 = ds.ground_truth.poses[idx[i - 1]];
      const pl::Pose& g1 = ds.ground_truth.poses[idx[i]];
      path += (g1.translation() - g0.translation()).norm();
      const pl::Pose dg = g0.inverse() * g1, de = est.poses[i - 1].inverse() * est.poses[i];
      const pl::Pose err = dg.inverse() * de;
      const double e = err.translation().norm();
      rel.push_back(e);
      rel_t += e;
      rel_t_max = std::max(rel_t_max, e);
      rel_r += pl::rotation_angle(err);
    }
    const double final_err = (est.poses[n - 1].translation() - ds.ground_truth.poses[idx[n - 1]].translation()).norm();
    std::printf("  drift            final position error %.2f m over %.1f m: %.2f %% of the path\n", final_err, path,
                path > 0 ? 100.0 * final_err / path : 0.0);
    if (n > 1)
      std::printf("  scan to scan     translation error mean %.1f mm, median %.1f mm, max %.1f mm; rotation error mean %.4f deg\n",
                  1e3 * rel_t / static_cast<double>(n - 1), 1e3 * pl::median(rel), 1e3 * rel_t_max,
                  rel_r / static_cast<double>(n - 1) * 180.0 / M_PI);
  }
  if (!o.traj_out.empty()) {
    pl::write_kitti_poses(o.traj_out, est);
    std::printf("  wrote %s (%zu poses, KITTI format)\n", o.traj_out.c_str(), est.size());
  }
  if (!o.timing_out.empty()) {
    std::ofstream csv(o.timing_out);
    csv << "scan,ms,edges,planes,iterations\n";
    for (std::size_t i = 0; i < n; ++i) csv << i << ',' << ms[i] << ',' << feat_edges[i] << ',' << feat_planes[i] << ',' << iters[i] << '\n';
    if (!csv) throw pl::Error(o.timing_out + ": cannot write");
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  pl::cli::Tool tool("bench_loam", "LOAM odometry alone over a drive: time a scan, and the drift against the ground truth.");
  CLI::App& app = tool.app();
  Options o;
  app.add_option("DATASET_DIR", o.dir, "the drive")->required();
  pl::cli::number(app, "--frames", o.frames, "the first N scans (0: all)", pl::cli::at_least(0));
  pl::cli::number(app, "--every", o.every, "run every K-th scan only (a lower scan rate)", pl::cli::at_least(1));
  pl::cli::choice(app, "--deskew", o.deskew, "auto: on for real recordings (no meta.json), off for pl-sim drives", {"auto", "on", "off"});
  app.add_option("--set", o.set, "overrides of LoamConfig fields (pl/maps/loam.hpp) by name")->type_name("NAME=VALUE,...");
  pl::cli::output_file(app, "--traj-out", o.traj_out, "one pose per scan run (KITTI format)");
  pl::cli::output_file(app, "--timing", o.timing_out, "a CSV of each scan's time and matched features");
  tool.body([&] { return run(o); });
  return tool.main(argc, argv);
}
