// pl-dataset: what a drive folder holds, its ground-truth poses and GPS, and a copy of a drive with
// a degraded (consumer-grade) GPS.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <random>
#include <string>

#include "pl/common/cli.hpp"
#include "pl/common/dataset.hpp"
#include "pl/common/error.hpp"
#include "pl/common/geo.hpp"
#include "pl/common/output_path.hpp"
#include "pl/common/progress.hpp"
#include "pl/common/voxel.hpp"

namespace {

const char* kUsage =
    "usage: pl-dataset info DIR [--json] [--sample N]\n"
    "       pl-dataset poses DIR --out FILE [--format kitti|tum]\n"
    "       pl-dataset scans DIR [--beams 16] [--fov 360] [--min-range 2] [--max-range 100] [--voxel 0.2]\n"
    "                           [--timing FILE.csv]\n"
    "       pl-dataset gps DIR --out FILE.tum [--truth FILE.tum] [--status rtk-fixed|rtk-float|dgps|single]\n"
    "       pl-dataset degrade-gps DIR --out OUT_DIR [--rate 1] [--sigma 1.5] [--seed 1]\n"
    "\n"
    "info   the layout found, scans, duration, points per scan, beams, ground-truth path length,\n"
    "       GPS fixes and their status mix, and the sidecar files present (or what is wrong).\n"
    "       --sample N: read at most N scans, evenly spaced, for the per-scan figures (default 20).\n"
    "poses  the ground-truth LiDAR poses, one per scan (KITTI: 12 numbers a line; TUM: t x y z qx qy qz qw).\n"
    "scans  prepares every scan as the localizer does (beam choice, field-of-view and range crops, voxel\n"
    "       grid) and reports points in and out; --timing writes frame,points_in,points_out,prepare_ms.\n"
    "gps    the GPS fixes as positions in the dataset's world frame (TUM, identity rotations);\n"
    "       --truth writes where the antenna really was at each fix (ground truth + lever arm), so that\n"
    "       pl-eval ape --est FILE --gt TRUTH measures the receiver; --status keeps the fixes of one status.\n"
    "degrade-gps  writes OUT_DIR: the same drive (every file of DIR reached through a symlink, nothing\n"
    "       copied) with a consumer-grade gps.csv: DIR's GPS fixes thinned to --rate Hz, each moved by\n"
    "       zero-mean Gaussian noise of --sigma metres per horizontal axis (east, north) and 1.5 x sigma\n"
    "       vertically (white: independent from fix to fix), status single, std_m = sigma. Same seed, same\n"
    "       file. OUT_DIR must either not exist, be empty, or be an earlier degrade-gps output (marked by\n"
    "       .pl-degrade-gps; it is replaced).\n";

double median_of(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  std::size_t m = v.size() / 2;
  return v.size() % 2 ? v[m] : 0.5 * (v[m - 1] + v[m]);
}

int cmd_info(const pl::Args& args) {
  if (args.positional().size() != 2) throw pl::Error("info takes one folder: pl-dataset info DIR");
  bool as_json = args.has("--json");
  long long sample = args.get_int("--sample", 20);
  args.finish();
  if (sample < 1) throw pl::Error("--sample must be at least 1");
  pl::Dataset ds = pl::open_dataset(args.positional()[1]);
  nlohmann::json j;
  j["dir"] = ds.dir;
  j["layout"] = ds.layout_name();
  j["scans"] = ds.size();
  j["first_frame"] = ds.frame_ids.front();
  j["last_frame"] = ds.frame_ids.back();
  double duration = ds.times.back() - ds.times.front();
  j["duration_s"] = duration;
  // Frames may be a sample of a longer drive (e.g. KITTI 00 frames 0-9, 94, 95, ...): rate from frame numbers.
  j["rate_hz"] = ds.size() > 1 && duration > 0 ? static_cast<double>(ds.frame_ids.back() - ds.frame_ids.front()) / duration : 0.0;

  // Per-scan figures from evenly spaced scans.
  std::size_t count = std::min<std::size_t>(ds.size(), static_cast<std::size_t>(sample));
  std::vector<double> points, rings, kept16, voxel02;
  pl::Progress progress("reading scans", count);
  for (std::size_t k = 0; k < count; ++k) {
    std::size_t i = count == 1 ? 0 : k * (ds.size() - 1) / (count - 1);
    pl::Scan scan = ds.load_scan(i);
    auto r = ds.rings(scan);
    points.push_back(static_cast<double>(scan.size()));
    rings.push_back(r.empty() ? 0.0 : 1.0 + *std::max_element(r.begin(), r.end()));
    int every = std::max(1, ds.meta.sensor.beams / 16);
    if (!scan.empty()) {
      kept16.push_back(static_cast<double>(pl::keep_every_kth_ring(scan, r, every).size()) / static_cast<double>(scan.size()));
      voxel02.push_back(static_cast<double>(pl::voxel_downsample(scan, 0.2).size()));
    }
    progress.update(k + 1);
  }
  progress.finish();
  j["sampled_scans"] = count;
  j["points_per_scan"] = {{"min", *std::min_element(points.begin(), points.end())},
                          {"median", median_of(points)},
                          {"max", *std::max_element(points.begin(), points.end())}};
  j["beams"] = {{"sensor", ds.meta.sensor.model},
                {"table", ds.meta.sensor.beams},
                {"rings_found_median", median_of(rings)},
                {"rings_found_min", *std::min_element(rings.begin(), rings.end())},
                {"rings_found_max", *std::max_element(rings.begin(), rings.end())},
                {"ring_method", ds.meta.sensor.point_order == "laser-by-laser" ? "azimuth wrap" : "vertical angle table"},
                {"sixteen_beam_share_median", median_of(kept16)},
                {"voxel_0.2m_points_median", median_of(voxel02)}};

  if (ds.has_ground_truth()) {
    double length = 0;
    for (std::size_t i = 1; i < ds.ground_truth.size(); ++i)
      length += (ds.ground_truth.poses[i].translation() - ds.ground_truth.poses[i - 1].translation()).norm();
    j["ground_truth"] = {{"poses", ds.ground_truth.size()}, {"path_length_m", length}};
  } else {
    j["ground_truth"] = nullptr;
  }
  if (!ds.gps.empty()) {
    std::map<std::string, std::size_t> mix;
    std::vector<double> stds;
    for (const auto& f : ds.gps) {
      ++mix[pl::gps_status_name(f.status)];
      stds.push_back(f.std_m);
    }
    j["gps"] = {{"fixes", ds.gps.size()}, {"status", mix}, {"std_m_median", median_of(stds)}};
  } else {
    j["gps"] = nullptr;
  }
  j["encoder_samples"] = ds.encoder.size();
  j["odometry_samples"] = ds.odometry.size();
  j["sidecars"] = ds.sidecars;
  if (ds.meta.origin) j["origin"] = {{"lat", ds.meta.origin->lat_deg}, {"lon", ds.meta.origin->lon_deg}, {"alt", ds.meta.origin->alt_m}};

  if (as_json) {
    std::printf("%s\n", j.dump(2).c_str());
    return 0;
  }
  std::printf("dataset        %s\n", ds.dir.c_str());
  std::printf("layout         %s\n", ds.layout_name());
  std::printf("scans          %zu (frames %ld..%ld), %.1f s at %.2f Hz\n", ds.size(), ds.frame_ids.front(),
              ds.frame_ids.back(), duration, j["rate_hz"].get<double>());
  std::printf("points/scan    min %.0f, median %.0f, max %.0f (%zu scans read)\n", j["points_per_scan"]["min"].get<double>(),
              median_of(points), j["points_per_scan"]["max"].get<double>(), count);
  std::printf("beams          %s, %d in the table; rings found per scan: median %.0f (min %.0f, max %.0f) by %s\n",
              ds.meta.sensor.model.c_str(), ds.meta.sensor.beams, median_of(rings), j["beams"]["rings_found_min"].get<double>(),
              j["beams"]["rings_found_max"].get<double>(), j["beams"]["ring_method"].get<std::string>().c_str());
  std::printf("16 beams       keep %.1f %% of the points; 0.2 m voxels leave %.0f points a scan (medians)\n",
              100.0 * median_of(kept16), median_of(voxel02));
  if (ds.has_ground_truth())
    std::printf("ground truth   %zu poses, path length %.1f m\n", ds.ground_truth.size(), j["ground_truth"]["path_length_m"].get<double>());
  else
    std::printf("ground truth   none (no poses.txt)\n");
  if (!ds.gps.empty()) {
    std::printf("gps            %zu fixes, median std %.3f m:", ds.gps.size(), j["gps"]["std_m_median"].get<double>());
    for (const auto& [name, n] : j["gps"]["status"].items())
      std::printf(" %s %.1f %%", name.c_str(), 100.0 * n.get<double>() / static_cast<double>(ds.gps.size()));
    std::printf("\n");
  } else {
    std::printf("gps            none\n");
  }
  if (!ds.encoder.empty()) std::printf("encoder        %zu samples\n", ds.encoder.size());
  if (!ds.odometry.empty()) std::printf("odometry       %zu samples\n", ds.odometry.size());
  std::string side;
  for (const auto& s : ds.sidecars) side += (side.empty() ? "" : ", ") + s;
  std::printf("sidecars       %s\n", side.empty() ? "none" : side.c_str());
  if (ds.meta.origin)
    std::printf("origin         lat %.9f, lon %.9f, alt %.3f m\n", ds.meta.origin->lat_deg, ds.meta.origin->lon_deg,
                ds.meta.origin->alt_m);
  return 0;
}

int cmd_poses(const pl::Args& args) {
  if (args.positional().size() != 2) throw pl::Error("poses takes one folder: pl-dataset poses DIR --out FILE");
  std::string out = args.require("--out", "FILE (where to write the poses)");
  std::string fmt_name = args.get_or("--format", "kitti");
  args.finish();
  auto fmt = pl::parse_pose_format(fmt_name);
  if (!fmt) throw pl::Error("--format takes kitti or tum, got \"" + fmt_name + "\"");
  pl::Dataset ds = pl::open_dataset(args.positional()[1]);
  if (!ds.has_ground_truth())
    throw pl::Error(ds.dir + ": no ground truth (a KITTI odometry folder needs poses.txt; a raw drive needs oxts/)");
  pl::write_trajectory(out, ds.ground_truth, *fmt);
  std::printf("wrote %zu ground-truth LiDAR poses to %s (%s)\n", ds.ground_truth.size(), out.c_str(), fmt_name.c_str());
  return 0;
}

int cmd_scans(const pl::Args& args) {
  if (args.positional().size() != 2) throw pl::Error("scans takes one folder: pl-dataset scans DIR");
  pl::ScanPrepConfig cfg;
  cfg.beams = static_cast<int>(args.get_int("--beams", 0));
  cfg.fov_deg = args.get_double("--fov", cfg.fov_deg);
  cfg.min_range_m = args.get_double("--min-range", cfg.min_range_m);
  cfg.max_range_m = args.get_double("--max-range", cfg.max_range_m);
  cfg.voxel_m = args.get_double("--voxel", 0.2);
  auto timing_path = args.get("--timing");
  args.finish();
  if (cfg.fov_deg <= 0 || cfg.fov_deg > 360) throw pl::Error("--fov takes degrees in (0, 360]");
  if (timing_path) pl::check_output_file(*timing_path);  // before the work, not after it
  pl::Dataset ds = pl::open_dataset(args.positional()[1]);
  cfg.sensor_beams = ds.meta.sensor.beams;
  std::FILE* timing = nullptr;
  if (timing_path) {
    timing = std::fopen(timing_path->c_str(), "w");
    if (!timing) throw pl::Error(*timing_path + ": cannot write");
    std::fprintf(timing, "frame,points_in,points_out,prepare_ms\n");
  }
  std::vector<double> in, out, ms;
  pl::Progress progress("preparing scans", ds.size());
  for (std::size_t i = 0; i < ds.size(); ++i) {
    pl::Scan scan = ds.load_scan(i);
    auto t0 = std::chrono::steady_clock::now();
    std::vector<std::uint16_t> rings;
    if (cfg.beams > 0 && cfg.beams < cfg.sensor_beams) rings = ds.rings(scan);
    pl::Scan prepared = pl::prepare_scan(scan, rings, cfg);
    double elapsed = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    in.push_back(static_cast<double>(scan.size()));
    out.push_back(static_cast<double>(prepared.size()));
    ms.push_back(elapsed);
    if (timing) std::fprintf(timing, "%ld,%zu,%zu,%.4f\n", ds.frame_ids[i], scan.size(), prepared.size(), elapsed);
    progress.update(i + 1);
  }
  progress.finish();
  if (timing && std::fclose(timing) != 0) throw pl::Error(*timing_path + ": write failed");
  std::printf("prepared %zu scans: %s beams, %.0f deg field of view, %.1f-%.1f m, %.2f m voxels\n", ds.size(),
              cfg.beams > 0 ? std::to_string(cfg.beams).c_str() : "all", cfg.fov_deg, cfg.min_range_m, cfg.max_range_m, cfg.voxel_m);
  std::printf("points a scan: median %.0f in, %.0f out; median %.2f ms a scan (ring + beams + crops + voxels)\n",
              median_of(in), median_of(out), median_of(ms));
  if (timing_path) std::printf("per-scan figures in %s\n", timing_path->c_str());
  return 0;
}

int cmd_gps(const pl::Args& args) {
  if (args.positional().size() != 2) throw pl::Error("gps takes one folder: pl-dataset gps DIR --out FILE.tum");
  std::string out = args.require("--out", "FILE.tum (where to write the GPS positions)");
  auto truth_path = args.get("--truth");
  auto status_name = args.get("--status");
  args.finish();
  int status = -1;
  if (status_name) {
    for (int k = pl::kGpsSingle; k <= pl::kGpsFixed; ++k)
      if (*status_name == pl::gps_status_name(k)) status = k;
    if (status < 0) throw pl::Error("--status takes rtk-fixed, rtk-float, dgps or single, got \"" + *status_name + "\"");
  }
  pl::Dataset ds = pl::open_dataset(args.positional()[1]);
  if (ds.gps.empty()) throw pl::Error(ds.dir + ": no GPS (a raw drive's oxts/ or a gps.csv)");
  if (truth_path && !ds.has_ground_truth()) throw pl::Error(ds.dir + ": --truth needs ground-truth poses");
  pl::Trajectory fixes, truth;
  fixes.format = truth.format = pl::PoseFormat::Tum;
  const auto& gt = ds.ground_truth;
  std::size_t skipped = 0;
  for (const auto& f : ds.gps) {
    if (status >= 0 && f.status != status) continue;
    pl::Pose p = pl::Pose::Identity();
    p.translation() = ds.to_world(f.position);
    if (truth_path) {
      // Ground truth at the fix time (interpolated between scans); fixes outside the drive are left out.
      if (f.t < gt.times.front() || f.t > gt.times.back()) {
        ++skipped;
        continue;
      }
      std::size_t i = static_cast<std::size_t>(std::upper_bound(gt.times.begin(), gt.times.end(), f.t) - gt.times.begin());
      i = std::min(std::max<std::size_t>(i, 1), gt.size() - 1);
      double s = (f.t - gt.times[i - 1]) / std::max(1e-9, gt.times[i] - gt.times[i - 1]);
      pl::Pose a = pl::Pose::Identity();
      a.translation() = pl::interpolate(gt.poses[i - 1], gt.poses[i], s) * ds.meta.vehicle.gps_lever_arm;
      truth.poses.push_back(a);
      truth.times.push_back(f.t);
    }
    fixes.poses.push_back(p);
    fixes.times.push_back(f.t);
  }
  if (fixes.poses.empty()) throw pl::Error(ds.dir + ": no GPS fixes" + (status_name ? " with status " + *status_name : std::string()));
  pl::write_tum_poses(out, fixes);
  std::printf("wrote %zu GPS positions to %s", fixes.size(), out.c_str());
  if (truth_path) {
    pl::write_tum_poses(*truth_path, truth);
    std::printf(" and the true antenna positions to %s", truth_path->c_str());
  }
  std::printf("%s\n", skipped ? (" (" + std::to_string(skipped) + " fixes outside the drive left out)").c_str() : "");
  return 0;
}

// Standard normal deviates from a 64-bit Mersenne Twister by the Box-Muller transform: the same
// numbers on every platform for a seed (std::normal_distribution is implementation-defined).
class Gaussian {
 public:
  explicit Gaussian(std::uint64_t seed) : rng_(seed) {}
  double operator()() {
    if (has_spare_) {
      has_spare_ = false;
      return spare_;
    }
    const double u1 = 1.0 - static_cast<double>(rng_() >> 11) * 0x1.0p-53;  // (0, 1]
    const double u2 = static_cast<double>(rng_() >> 11) * 0x1.0p-53;        // [0, 1)
    const double r = std::sqrt(-2.0 * std::log(u1));
    spare_ = r * std::sin(2.0 * M_PI * u2);
    has_spare_ = true;
    return r * std::cos(2.0 * M_PI * u2);
  }

 private:
  std::mt19937_64 rng_;
  double spare_ = 0.0;
  bool has_spare_ = false;
};

double rms(const std::vector<double>& v) {
  double s = 0.0;
  for (double x : v) s += x * x;
  return v.empty() ? 0.0 : std::sqrt(s / static_cast<double>(v.size()));
}

// Makes `out` an empty folder for degrade-gps: it may not exist yet, be empty, or hold an earlier
// output (marked by kMarker; only symlinks, the marker and gps.csv), which is cleared. It must not be
// the source or inside it.
const char* kMarker = ".pl-degrade-gps";
void prepare_output_folder(const std::string& source, const std::string& out) {
  namespace fs = std::filesystem;
  const fs::path src = fs::canonical(source);
  const fs::path dst = fs::weakly_canonical(out);
  auto [s_end, d_it] = std::mismatch(src.begin(), src.end(), dst.begin(), dst.end());
  if (s_end == src.end())
    throw pl::Error("--out " + out + " is " + (d_it == dst.end() ? "the source folder itself" : "inside the source folder " + source) +
                    "; choose a folder outside it, e.g. " + (src.parent_path() / (src.filename().string() + "-consumer")).string());
  if (!fs::exists(fs::symlink_status(out))) {
    fs::create_directories(out);
    return;
  }
  if (!fs::is_directory(fs::symlink_status(out)))
    throw pl::Error("--out " + out + " exists and is not a folder; remove it or choose another path");
  std::vector<fs::path> entries;
  for (const auto& e : fs::directory_iterator(out)) entries.push_back(e.path());
  if (entries.empty()) return;
  // Only a folder this command made is cleared: it carries the marker, and nothing but symlinks,
  // the marker and gps.csv.
  if (!fs::is_regular_file(fs::symlink_status(fs::path(out) / kMarker)))
    throw pl::Error("--out " + out + " is not empty and is not an earlier degrade-gps output (no " + kMarker +
                    " in it); nothing was changed: remove the folder yourself or choose another one");
  for (const auto& e : entries) {
    const std::string name = e.filename().string();
    const bool ours = fs::is_symlink(fs::symlink_status(e)) || name == kMarker || (name == "gps.csv" && fs::is_regular_file(e));
    if (!ours)
      throw pl::Error("--out " + out + " holds " + name + ", which degrade-gps does not write; nothing was changed: remove the "
                      "folder yourself or choose another one");
  }
  for (const auto& e : entries) fs::remove(e);
}

int cmd_degrade_gps(const pl::Args& args) {
  namespace fs = std::filesystem;
  if (args.positional().size() != 2)
    throw pl::Error("degrade-gps takes one folder: pl-dataset degrade-gps DIR --out OUT_DIR [--rate 1] [--sigma 1.5] [--seed 1]");
  const std::string out = args.require("--out", "OUT_DIR (the folder of the drive with the degraded GPS)");
  const double rate = args.get_double("--rate", 1.0);
  const double sigma = args.get_double("--sigma", 1.5);
  const long long seed = args.get_int("--seed", 1);
  args.finish();
  if (!(rate > 0.0) || !std::isfinite(rate)) throw pl::Error("--rate takes fixes per second above 0, e.g. --rate 1");
  if (!(sigma >= 0.0) || !std::isfinite(sigma)) throw pl::Error("--sigma takes metres (>= 0), e.g. --sigma 1.5");
  if (seed < 0) throw pl::Error("--seed takes a whole number >= 0");

  const pl::Dataset ds = pl::open_dataset(args.positional()[1]);
  std::vector<pl::GpsFix> source;
  for (const auto& f : ds.gps)
    if (f.status != pl::kGpsNone) source.push_back(f);
  if (source.empty())
    throw pl::Error(ds.dir + ": no GPS fixes with a position to degrade (a raw drive's oxts/ or a gps.csv with status 1-4)");
  // The source rate from its span, so that --rate cannot ask for more fixes than there are.
  const double span = source.back().t - source.front().t;
  if (source.size() > 1 && span > 0.0) {
    const double source_rate = static_cast<double>(source.size() - 1) / span;
    if (rate > source_rate * 1.05) {
      char buf[160];
      std::snprintf(buf, sizeof buf, "--rate %g Hz is above the rate of the source GPS (%.2f Hz, %zu fixes over %.1f s)",
                    rate, source_rate, source.size(), span);
      throw pl::Error(ds.dir + ": " + buf + "; pick --rate at most that");
    }
  }

  // Thinning: the first fix at or after each multiple of 1/rate since the first fix.
  std::vector<pl::GpsFix> kept;
  long long last_slot = -1;
  for (const auto& f : source) {
    const auto slot = static_cast<long long>(std::floor((f.t - source.front().t) * rate + 1e-6));
    if (slot <= last_slot) continue;
    last_slot = slot;
    kept.push_back(f);
  }

  // Noise in the local East-North-Up frame of each fix.
  Gaussian normal(static_cast<std::uint64_t>(seed));
  std::vector<pl::GpsFix> noisy;
  std::vector<double> de, dn, du, dh;
  for (const auto& f : kept) {
    const pl::EnuFrame enu(f.position);
    // Drawn in a fixed order (constructor arguments are evaluated in an unspecified order).
    const double east = normal(), north = normal(), up = normal();
    const Eigen::Vector3d offset(sigma * east, sigma * north, 1.5 * sigma * up);
    noisy.push_back({f.t, enu.to_geodetic(offset), sigma, pl::kGpsSingle});
  }

  prepare_output_folder(ds.dir, out);
  const fs::path src = fs::canonical(ds.dir);
  std::size_t links = 0;
  for (const auto& e : fs::directory_iterator(src)) {
    if (e.path().filename() == "gps.csv") continue;  // replaced below
    fs::create_symlink(fs::canonical(e.path()), fs::path(out) / e.path().filename());
    ++links;
  }
  {
    std::FILE* marker = std::fopen((fs::path(out) / kMarker).c_str(), "w");
    if (!marker) throw pl::Error(out + ": cannot write " + kMarker);
    std::fprintf(marker, "made by pl-dataset degrade-gps from %s; pl-dataset degrade-gps may replace this folder\n", src.string().c_str());
    std::fclose(marker);
  }
  const std::string csv_path = (fs::path(out) / "gps.csv").string();
  std::FILE* csv = std::fopen(csv_path.c_str(), "w");
  if (!csv) throw pl::Error(csv_path + ": cannot write");
  std::fprintf(csv, "# consumer-grade GPS made by pl-dataset degrade-gps from %s: %zu of %zu fixes (%g Hz), noise sigma %g m "
                    "east and north, %g m up, seed %lld\n",
               src.string().c_str(), noisy.size(), source.size(), rate, sigma, 1.5 * sigma, seed);
  std::fprintf(csv, "t,lat,lon,alt,std_m,status\n");
  for (const auto& f : noisy)
    std::fprintf(csv, "%.6f,%.10f,%.10f,%.4f,%.3f,%d\n", f.t, f.position.lat_deg, f.position.lon_deg, f.position.alt_m,
                 f.std_m, f.status);
  if (std::fclose(csv) != 0) throw pl::Error(csv_path + ": write failed (disk full?)");

  // Read the new drive back and measure its fixes against the source's, as written (rounded).
  const pl::Dataset check = pl::open_dataset(out);
  if (check.gps.size() != kept.size()) throw pl::Error(csv_path + ": read back " + std::to_string(check.gps.size()) + " fixes, wrote " + std::to_string(kept.size()));
  for (std::size_t i = 0; i < kept.size(); ++i) {
    const Eigen::Vector3d d = pl::EnuFrame(kept[i].position).to_enu(check.gps[i].position);
    de.push_back(d.x());
    dn.push_back(d.y());
    du.push_back(d.z());
    dh.push_back(d.head<2>().norm());
  }
  double mean_h = 0.0;
  for (double h : dh) mean_h += h / static_cast<double>(dh.size());
  std::printf("wrote %s: %zu scans through %zu symlinks to %s, and gps.csv\n", out.c_str(), check.size(), links,
              src.string().c_str());
  std::printf("gps.csv        %zu fixes at %g Hz (of %zu source fixes over %.1f s), status single, std_m %.3f, seed %lld\n",
              noisy.size(), rate, source.size(), span, sigma, seed);
  std::printf("noise added    rms east %.3f m, north %.3f m, up %.3f m; horizontal mean %.3f m, max %.3f m\n", rms(de),
              rms(dn), rms(du), mean_h, dh.empty() ? 0.0 : *std::max_element(dh.begin(), dh.end()));
  return 0;
}

int body(int argc, char** argv) {
  if (argc < 2 || std::string(argv[1]) == "--help" || std::string(argv[1]) == "-h") {
    std::fputs(kUsage, argc < 2 ? stderr : stdout);
    return argc < 2 ? 2 : 0;
  }
  pl::Args args(argc, argv, 1, {"--json"});
  std::string cmd = argv[1];
  if (cmd == "info") return cmd_info(args);
  if (cmd == "poses") return cmd_poses(args);
  if (cmd == "scans") return cmd_scans(args);
  if (cmd == "gps") return cmd_gps(args);
  if (cmd == "degrade-gps") return cmd_degrade_gps(args);
  throw pl::Error("unknown command \"" + cmd + "\" (info, poses, scans, gps or degrade-gps; see --help)");
}

}  // namespace

int main(int argc, char** argv) { return pl::run_cli("pl-dataset", body, argc, argv); }
