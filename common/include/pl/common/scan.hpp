// LiDAR scans in the sensor frame (x forward, y left, z up) and the per-scan operations the paper
// uses: ring (beam) index, keeping every k-th beam, field-of-view and range crops.
#pragma once

#include <Eigen/Core>

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace pl {

struct PointXYZI {
  float x, y, z, intensity;
};
using Scan = std::vector<PointXYZI>;

// The scan's points as registration input (float, sensor frame).
std::vector<Eigen::Vector3f> to_points(const Scan& scan);

// KITTI .bin: little-endian float32 x y z reflectance. Throws pl::Error naming the file: a size that
// is not a whole number of points, a non-finite coordinate or reflectance.
Scan read_kitti_bin(const std::string& path);
// The same on bytes in memory (a bag record, a fuzzer's input); `name` stands for the file in messages.
Scan parse_kitti_bin(std::string_view bytes, const std::string& name);
void write_kitti_bin(const std::string& path, const Scan& scan);

// Per-point times of a scan (a dataset's point_times/ sidecar): little-endian float32 seconds from
// the scan's time, one per point of the scan, in its order. Throws pl::Error naming the file when the
// count is not `points`, or a time is not finite or lies a second or more from the scan's time.
std::vector<float> read_point_times(const std::string& path, std::size_t points);
std::vector<float> parse_point_times(std::string_view bytes, const std::string& name, std::size_t points);
void write_point_times(const std::string& path, const std::vector<float>& times);

// Ring of every point of a scan stored laser by laser (KITTI: each laser one counter-clockwise turn
// from just left of straight ahead): a new ring starts where the azimuth falls back.
std::vector<std::uint16_t> rings_from_azimuth(const Scan& scan);
// Ring of every point from the nearest vertical angle of the sensor's beam table.
std::vector<std::uint16_t> rings_from_elevation(const Scan& scan, const std::vector<double>& vertical_angles_deg);
// A point's angle above the sensor's horizontal plane, radians.
double elevation_of(double x, double y, double z);
// The index of the angle in `sorted` (ascending, not empty) nearest `angle`.
std::size_t nearest_angle(const std::vector<double>& sorted, double angle);

// Keeps the points whose ring r satisfies r % every == offset (64 -> 16 beams: every = 4).
Scan keep_every_kth_ring(const Scan& scan, const std::vector<std::uint16_t>& rings, int every, int offset = 0,
                         std::vector<std::uint16_t>* kept_rings = nullptr);
// Keeps the points whose azimuth lies within fov/2 of `center_deg` (0 = straight ahead).
Scan crop_fov(const Scan& scan, double fov_deg, double center_deg = 0.0);
// Keeps the points with min <= range < max (range in the xy plane and z: the Euclidean norm).
Scan crop_range(const Scan& scan, double min_m, double max_m);

// The scan preparation the localizer and the map builder apply, as one config with defaults.
struct ScanPrepConfig {
  int beams = 0;             // keep this many of the sensor's beams (every k-th ring); 0 keeps all
  int sensor_beams = 64;     // the sensor's beam count (64 for KITTI's HDL-64E)
  double fov_deg = 360.0;    // horizontal field of view kept, centred straight ahead
  double min_range_m = 2.0;  // drops returns from the vehicle itself
  double max_range_m = 100.0;
  double voxel_m = 0.0;      // voxel-grid downsampling; 0 keeps every point
};

// Beam choice, field-of-view crop, range crop, then voxel downsampling. `rings` holds one ring per
// point (needed only when cfg.beams selects fewer beams than the sensor has).
Scan prepare_scan(const Scan& scan, const std::vector<std::uint16_t>& rings, const ScanPrepConfig& cfg);

}  // namespace pl
