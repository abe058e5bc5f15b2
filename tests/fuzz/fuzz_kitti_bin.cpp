// Fuzz target: a KITTI .bin scan as the localizer and the map builder load it, and the scan
// operations every loaded scan goes through (rings, beam choice, crops, voxel grid); the same bytes
// as a point_times/ file. Refusing with pl::Error is fine; a scan that comes back must hold exactly
// the input's points, all finite, and times that come back the input's times, each within a second.
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <string_view>
#include <vector>

#include "pl/common/error.hpp"
#include "pl/common/meta.hpp"
#include "pl/common/scan.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  for (std::size_t points : {size / 4, size / 16, size / 4 + 1}) {
    try {
      const std::vector<float> times = pl::parse_point_times(bytes, "fuzz.times", points);
      if (times.size() != points || times.size() * sizeof(float) != size) std::abort();
      if (size > 0 && std::memcmp(times.data(), data, size) != 0) std::abort();
      for (float t : times)
        if (!(std::abs(t) < 1.0f)) std::abort();
    } catch (const pl::Error&) {
    }
  }
  pl::Scan scan;
  try {
    scan = pl::parse_kitti_bin(bytes, "fuzz.bin");
  } catch (const pl::Error&) {
    return 0;
  }
  if (scan.size() * sizeof(pl::PointXYZI) != size) std::abort();
  if (size > 0 && std::memcmp(scan.data(), data, size) != 0) std::abort();
  for (const auto& p : scan)
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z) || !std::isfinite(p.intensity)) std::abort();

  const auto rings = pl::rings_from_azimuth(scan);
  const auto by_elevation = pl::rings_from_elevation(scan, pl::hdl64_vertical_angles_deg());
  if (rings.size() != scan.size() || by_elevation.size() != scan.size()) std::abort();
  for (auto r : by_elevation)
    if (r >= 64) std::abort();
  pl::ScanPrepConfig cfg;
  cfg.beams = 16;
  cfg.fov_deg = 180;
  cfg.voxel_m = 0.2;
  try {
    const pl::Scan prepared = pl::prepare_scan(scan, rings, cfg);
    if (prepared.size() > scan.size()) std::abort();
  } catch (const pl::Error&) {
    // the voxel grid refuses coordinates beyond its index range, with a message
  }
  return 0;
}
