#include "pl/common/scan.hpp"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>
#include <numeric>
#include <sys/stat.h>

#include "pl/common/error.hpp"
#include "pl/common/voxel.hpp"

namespace pl {

static_assert(sizeof(PointXYZI) == 16, "PointXYZI must match the KITTI .bin record");

namespace {

std::string not_whole_points(std::size_t size, const std::string& name) {
  return name + ": size " + std::to_string(size) +
         " bytes is not a whole number of points (expected float32 x y z reflectance, 16 bytes a point)";
}

// Every value of a scan must be a number: a NaN or inf would travel through the crops and the
// voxel grid into registration.
void check_finite(const Scan& scan, const std::string& name) {
  for (std::size_t i = 0; i < scan.size(); ++i) {
    const auto& p = scan[i];
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
      throw Error(name + ": point " + std::to_string(i) + " has a non-finite coordinate");
    if (!std::isfinite(p.intensity)) throw Error(name + ": point " + std::to_string(i) + " has a non-finite reflectance");
  }
}

using File = std::unique_ptr<std::FILE, int (*)(std::FILE*)>;

// A regular file opened for reading, and its size: the bytes present (a folder's "size" is not).
File open_regular(const std::string& path, std::size_t& size) {
  File f(std::fopen(path.c_str(), "rb"), &std::fclose);
  if (!f) throw Error(path + ": cannot open (" + std::strerror(errno) + ")");
  struct stat st {};
  if (::fstat(::fileno(f.get()), &st) != 0 || !S_ISREG(st.st_mode)) throw Error(path + ": not a regular file");
  size = static_cast<std::size_t>(st.st_size);
  return f;
}

// Reads `size` bytes straight into `dst` (no copy of every scan the localizer loads).
void read_exactly(const File& f, void* dst, std::size_t size, const std::string& path) {
  if (size > 0 && std::fread(dst, 1, size, f.get()) != size)
    throw Error(path + ": read failed (" + (std::ferror(f.get()) ? std::strerror(errno) : "the file got shorter") + ")");
}

Error times_size_error(std::size_t size, std::size_t points, const std::string& name) {
  return Error(name + ": " + std::to_string(size) + " bytes for the times of " + std::to_string(points) +
               " points (expected float32 seconds, 4 bytes a point, as many as the scan has points)");
}

// Every time within a second of the scan's (a NaN is not).
void check_times(const std::vector<float>& times, const std::string& name) {
  for (std::size_t i = 0; i < times.size(); ++i)
    if (!(std::abs(times[i]) < 1.0f))
      throw Error(name + ": point " + std::to_string(i) + "'s time " + std::to_string(times[i]) +
                  " is not within a second of the scan's time (seconds from the scan's time are expected)");
}

}  // namespace

std::vector<Eigen::Vector3f> to_points(const Scan& scan) {
  std::vector<Eigen::Vector3f> out;
  out.reserve(scan.size());
  for (const auto& p : scan) out.emplace_back(p.x, p.y, p.z);
  return out;
}

Scan parse_kitti_bin(std::string_view bytes, const std::string& name) {
  if (bytes.size() % sizeof(PointXYZI) != 0) throw Error(not_whole_points(bytes.size(), name));
  // The point count comes from the bytes present, so the allocation is exactly what they hold.
  Scan scan(bytes.size() / sizeof(PointXYZI));
  if (!scan.empty()) std::memcpy(scan.data(), bytes.data(), bytes.size());
  check_finite(scan, name);
  return scan;
}

Scan read_kitti_bin(const std::string& path) {
  std::size_t size = 0;
  const File f = open_regular(path, size);
  if (size % sizeof(PointXYZI) != 0) throw Error(not_whole_points(size, path));
  Scan scan(size / sizeof(PointXYZI));
  read_exactly(f, scan.data(), size, path);
  check_finite(scan, path);
  return scan;
}

void write_kitti_bin(const std::string& path, const Scan& scan) {
  std::unique_ptr<std::FILE, int (*)(std::FILE*)> f(std::fopen(path.c_str(), "wb"), &std::fclose);
  if (!f) throw Error(path + ": cannot write (" + std::strerror(errno) + ")");
  if (!scan.empty() && std::fwrite(scan.data(), 16, scan.size(), f.get()) != scan.size())
    throw Error(path + ": write failed (disk full?)");
  if (std::fclose(f.release()) != 0) throw Error(path + ": write failed (disk full?)");
}

std::vector<float> parse_point_times(std::string_view bytes, const std::string& name, std::size_t points) {
  if (bytes.size() != points * sizeof(float)) throw times_size_error(bytes.size(), points, name);
  std::vector<float> times(points);
  if (points) std::memcpy(times.data(), bytes.data(), bytes.size());
  check_times(times, name);
  return times;
}

std::vector<float> read_point_times(const std::string& path, std::size_t points) {
  std::size_t size = 0;
  const File f = open_regular(path, size);
  // A file of another size is refused by its size, not read.
  if (size != points * sizeof(float)) throw times_size_error(size, points, path);
  std::vector<float> times(points);
  read_exactly(f, times.data(), size, path);
  check_times(times, path);
  return times;
}

void write_point_times(const std::string& path, const std::vector<float>& times) {
  std::unique_ptr<std::FILE, int (*)(std::FILE*)> f(std::fopen(path.c_str(), "wb"), &std::fclose);
  if (!f) throw Error(path + ": cannot write (" + std::strerror(errno) + ")");
  if (!times.empty() && std::fwrite(times.data(), sizeof(float), times.size(), f.get()) != times.size())
    throw Error(path + ": write failed (disk full?)");
  if (std::fclose(f.release()) != 0) throw Error(path + ": write failed (disk full?)");
}

namespace {

// A monotonic stand-in for the azimuth, counter-clockwise from straight ahead: 0 ahead, 1 left,
// 2 behind, 3 right, up to 4 (one division, no atan2).
inline float pseudo_azimuth(float x, float y) {
  float s = std::abs(x) + std::abs(y);
  if (s == 0.0f) return 0.0f;
  if (y >= 0.0f) return x >= 0.0f ? y / s : 1.0f - x / s;
  return x < 0.0f ? 2.0f - y / s : 3.0f + x / s;
}

}  // namespace

std::vector<std::uint16_t> rings_from_azimuth(const Scan& scan) {
  // Within a ring the azimuth only grows (counter-clockwise, one turn from straight ahead); a new
  // ring starts where it falls back by more than ~20 degrees. Range noise near straight ahead or
  // behind moves the azimuth by far less, and rings with returns on one side only (open ground,
  // a 180-degree field of view) still start where the azimuth falls back.
  constexpr float kFallBack = 0.25f;  // in pseudo-azimuth units (90 deg = 1)
  std::vector<std::uint16_t> rings(scan.size());
  std::uint16_t ring = 0;
  float prev = 0.0f;
  for (std::size_t i = 0; i < scan.size(); ++i) {
    float a = pseudo_azimuth(scan[i].x, scan[i].y);
    if (i > 0 && prev - a > kFallBack && ring < 65535) ++ring;
    rings[i] = ring;
    prev = a;
  }
  // The last laser's final return can land just past straight ahead and open a ring of its own:
  // a last ring that is tiny next to the one before is that tail.
  if (ring > 0) {
    std::size_t last = 0, before = 0;
    for (auto r : rings) last += r == ring, before += r == ring - 1;
    if (last * 20 < before)
      for (auto& r : rings)
        if (r == ring) r = ring - 1;
  }
  return rings;
}

std::vector<std::uint16_t> rings_from_elevation(const Scan& scan, const std::vector<double>& angles_deg) {
  if (angles_deg.empty()) throw Error("rings from elevation need the sensor's vertical angles (meta.json sensor.vertical_angles_deg)");
  // Sort the table once and keep where each angle came from.
  std::vector<std::size_t> order(angles_deg.size());
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return angles_deg[a] < angles_deg[b]; });
  std::vector<double> sorted(order.size());
  for (std::size_t i = 0; i < order.size(); ++i) sorted[i] = angles_deg[order[i]] * M_PI / 180.0;
  std::vector<std::uint16_t> rings(scan.size());
  for (std::size_t i = 0; i < scan.size(); ++i)
    rings[i] = static_cast<std::uint16_t>(order[nearest_angle(sorted, elevation_of(scan[i].x, scan[i].y, scan[i].z))]);
  return rings;
}

double elevation_of(double x, double y, double z) { return std::atan2(z, std::hypot(x, y)); }

std::size_t nearest_angle(const std::vector<double>& sorted, double angle) {
  std::size_t k = static_cast<std::size_t>(std::lower_bound(sorted.begin(), sorted.end(), angle) - sorted.begin());
  if (k == sorted.size() || (k > 0 && angle - sorted[k - 1] < sorted[k] - angle)) --k;
  return k;
}

Scan keep_every_kth_ring(const Scan& scan, const std::vector<std::uint16_t>& rings, int every, int offset,
                         std::vector<std::uint16_t>* kept_rings) {
  if (rings.size() != scan.size()) throw Error("keep_every_kth_ring: one ring per point expected");
  if (every < 1 || offset < 0 || offset >= every) throw Error("keep every k-th beam: k must be >= 1 and 0 <= offset < k");
  Scan out;
  out.reserve(scan.size() / static_cast<std::size_t>(every) + 16);
  if (kept_rings) kept_rings->clear();
  for (std::size_t i = 0; i < scan.size(); ++i) {
    if (rings[i] % every != offset) continue;
    out.push_back(scan[i]);
    if (kept_rings) kept_rings->push_back(static_cast<std::uint16_t>(rings[i] / every));
  }
  return out;
}

Scan crop_fov(const Scan& scan, double fov_deg, double center_deg) {
  if (fov_deg >= 360.0) return scan;
  double half = 0.5 * fov_deg * M_PI / 180.0, center = center_deg * M_PI / 180.0;
  Scan out;
  out.reserve(scan.size());
  for (const auto& p : scan) {
    double d = std::remainder(std::atan2(static_cast<double>(p.y), static_cast<double>(p.x)) - center, 2.0 * M_PI);
    if (std::abs(d) <= half) out.push_back(p);
  }
  return out;
}

Scan crop_range(const Scan& scan, double min_m, double max_m) {
  double lo = min_m * min_m, hi = max_m * max_m;
  Scan out;
  out.reserve(scan.size());
  for (const auto& p : scan) {
    double r2 = static_cast<double>(p.x) * p.x + static_cast<double>(p.y) * p.y + static_cast<double>(p.z) * p.z;
    if (r2 >= lo && r2 < hi) out.push_back(p);
  }
  return out;
}

Scan prepare_scan(const Scan& scan, const std::vector<std::uint16_t>& rings, const ScanPrepConfig& cfg) {
  Scan out;
  if (cfg.beams > 0 && cfg.beams < cfg.sensor_beams) {
    if (cfg.sensor_beams % cfg.beams != 0)
      throw Error("cannot keep " + std::to_string(cfg.beams) + " of " + std::to_string(cfg.sensor_beams) +
                  " beams evenly: choose a divisor of " + std::to_string(cfg.sensor_beams));
    out = keep_every_kth_ring(scan, rings, cfg.sensor_beams / cfg.beams);
  } else {
    out = scan;
  }
  out = crop_fov(out, cfg.fov_deg);
  out = crop_range(out, cfg.min_range_m, cfg.max_range_m);
  if (cfg.voxel_m > 0.0) out = voxel_downsample(out, cfg.voxel_m);
  return out;
}

}  // namespace pl
