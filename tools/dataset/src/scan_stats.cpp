#include "pl/dataset/scan_stats.hpp"

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <vector>

#include "median.hpp"
#include "pl/common/error.hpp"
#include "pl/common/output_path.hpp"

namespace pl::dataset {

ScanStats prepare_every_scan(const Dataset& ds, ScanPrepConfig cfg, const std::string& timing_path,
                             const std::function<void(std::size_t, std::size_t)>& progress) {
  if (cfg.fov_deg <= 0 || cfg.fov_deg > 360) throw Error("--fov takes degrees in (0, 360]");
  if (!timing_path.empty()) check_output_file(timing_path);
  cfg.sensor_beams = ds.meta.sensor.beams;
  std::FILE* timing = nullptr;
  if (!timing_path.empty()) {
    timing = std::fopen(timing_path.c_str(), "w");
    if (!timing) throw Error(timing_path + ": cannot write");
    std::fprintf(timing, "frame,points_in,points_out,prepare_ms\n");
  }
  std::vector<double> in, out, ms;
  for (std::size_t i = 0; i < ds.size(); ++i) {
    const Frame frame = ds.load_frame(i, cfg.beams > 0 && cfg.beams < cfg.sensor_beams);
    const Scan& scan = frame.scan;
    const auto t0 = std::chrono::steady_clock::now();
    const Scan prepared = prepare_scan(scan, frame.rings, cfg);
    const double elapsed = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    in.push_back(static_cast<double>(scan.size()));
    out.push_back(static_cast<double>(prepared.size()));
    ms.push_back(elapsed);
    if (timing) std::fprintf(timing, "%ld,%zu,%zu,%.4f\n", ds.frame_ids[i], scan.size(), prepared.size(), elapsed);
    if (progress) progress(i + 1, ds.size());
  }
  if (timing && std::fclose(timing) != 0) throw Error(timing_path + ": write failed");
  return {ds.size(), median_of(in), median_of(out), median_of(ms)};
}

std::string scan_stats_text(const ScanStats& s, const ScanPrepConfig& cfg) {
  char buf[512];
  std::snprintf(buf, sizeof buf, "prepared %zu scans: %s beams, %.0f deg field of view, %.1f-%.1f m, %.2f m voxels\n", s.scans,
                cfg.beams > 0 ? std::to_string(cfg.beams).c_str() : "all", cfg.fov_deg, cfg.min_range_m, cfg.max_range_m, cfg.voxel_m);
  std::string text = buf;
  std::snprintf(buf, sizeof buf, "points a scan: median %.0f in, %.0f out; median %.2f ms a scan (ring + beams + crops + voxels)\n",
                s.median_in, s.median_out, s.median_ms);
  return text + buf;
}

}  // namespace pl::dataset
