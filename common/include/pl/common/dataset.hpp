// One reader for real and simulated drives: KITTI odometry and KITTI raw layouts, plus this
// project's sidecar files (encoder.csv, gps.csv, odometry.csv, meta.json). docs/dataset-layout.md
// describes every file.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "pl/common/geo.hpp"
#include "pl/common/meta.hpp"
#include "pl/common/pose.hpp"
#include "pl/common/scan.hpp"

namespace pl {

enum class DatasetLayout { KittiOdometry, KittiRaw };

// GPS status, from worst to best. OXTS position modes map onto it (see docs/dataset-layout.md).
enum GpsStatus : int { kGpsNone = 0, kGpsSingle = 1, kGpsDgps = 2, kGpsFloat = 3, kGpsFixed = 4 };
const char* gps_status_name(int status);
// The status of an OXTS record's position mode (its 28th value).
int gps_status_from_oxts(int posmode);

struct GpsFix {
  double t = 0.0;  // seconds, the dataset's clock
  GeoPoint position;
  double std_m = 0.0;  // reported horizontal standard deviation
  int status = kGpsNone;
};

struct EncoderSample {
  double t, left_m, right_m;  // cumulative travel of each wheel
};

struct OdometrySample {
  double t;
  Pose pose;
  EIGEN_MAKE_ALIGNED_OPERATOR_NEW
};

// How GPS positions map into the dataset's world frame (the frame of its ground-truth poses).
struct WorldProjection {
  enum class Kind { None, Enu, KittiMercator } kind = Kind::None;
  GeoPoint origin;       // ENU origin (Enu), or the first OXTS fix (KittiMercator)
  double mercator_scale = 1.0;
  Pose world_from_projected = Pose::Identity();  // applied after the projection
};

struct Dataset {
  std::string dir;
  DatasetLayout layout = DatasetLayout::KittiOdometry;
  std::vector<std::string> scan_paths;  // one per scan, in frame order
  std::vector<long> frame_ids;          // the number in each scan's file name
  std::vector<double> times;            // seconds, one per scan
  Trajectory ground_truth;              // LiDAR-frame poses, one per scan (empty when none), times attached
  std::vector<GpsFix> gps;
  std::vector<EncoderSample> encoder;
  std::vector<OdometrySample, Eigen::aligned_allocator<OdometrySample>> odometry;
  DatasetMeta meta;                   // from meta.json, or the layout's defaults
  bool has_meta_file = false;
  std::vector<std::string> sidecars;  // sidecar files found
  std::string point_times_dir;        // point_times/ when the drive has per-point times, else empty
  WorldProjection projection;

  std::size_t size() const { return scan_paths.size(); }
  bool has_ground_truth() const { return !ground_truth.poses.empty(); }
  bool has_point_times() const { return !point_times_dir.empty(); }  // the sensor says it sweeps
  const char* layout_name() const;
  Scan load_scan(std::size_t i) const;
  // Seconds from the scan's time of each point of scan i (`points` of them), from point_times/;
  // empty when the dataset has none.
  std::vector<float> load_point_times(std::size_t i, std::size_t points) const;
  // Ring of every point of a scan of this dataset (from the meta's point order / beam table).
  std::vector<std::uint16_t> rings(const Scan& scan) const;
  // A GPS position in the world frame; throws when the dataset has no geographic reference.
  Eigen::Vector3d to_world(const GeoPoint& p) const;
};

// Reads the layout found in `dir`. Throws pl::Error naming the file, the line and what was expected.
Dataset open_dataset(const std::string& dir);

// Parses a KITTI raw timestamp ("2011-09-26 13:04:32.349659964") to seconds since 1970 (UTC).
bool parse_kitti_timestamp(const std::string& text, double& seconds);

}  // namespace pl
