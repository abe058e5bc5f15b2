// One reader for real and simulated drives: KITTI odometry and KITTI raw layouts, plus this
// project's sidecar files (encoder.csv, gps.csv, odometry.csv, meta.json), and recordings (ROS 1 and
// ROS 2 bags, MCAP files: pl/recordings/bag.hpp). docs/dataset-layout.md describes every file.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "pl/common/geo.hpp"
#include "pl/common/meta.hpp"
#include "pl/common/pose.hpp"
#include "pl/common/scan.hpp"

namespace pl {

enum class DatasetLayout { KittiOdometry, KittiRaw, Recording, Frames };

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

// A scan as the localizer and the map builder take it: its points, each point's ring (empty when not
// asked for) and each point's time in seconds from the scan's time (empty when the sensor gives none).
struct Frame {
  Scan scan;
  std::vector<std::uint16_t> rings;
  std::vector<float> times;
};

// The topics of a recording to use where it has several of a kind (empty: the only one).
struct DatasetOptions {
  std::string points_topic;  // sensor_msgs/PointCloud2
  std::string odom_topic;    // nav_msgs/Odometry
  std::string gps_topic;     // sensor_msgs/NavSatFix
  // A nav_msgs/Odometry topic holding the ground truth (a reference system's poses of its child frame
  // in a world frame), for evaluation and the paper's protocol; left out of the odometry's choice.
  std::string truth_topic;
  // Recordings of LiDAR packets (pl/lidar/decoder.hpp): the maker's calibration file, where the
  // recording does not carry it, and the model, where the packets do not name it.
  std::string lidar_calibration;
  std::string lidar_model;
};

class RecordingScans;  // a recording's scans, read on demand (recordings/src/dataset_recording.cpp)

// What a recording held and what was taken from it (pl-dataset info prints it).
struct RecordingInfo {
  std::string format;  // "ROS 1 bag", "ROS 2 bag", "MCAP"
  struct TopicUse {
    std::string name, type, encoding;
    std::size_t count = 0;
    double first_s = 0, last_s = 0;  // recorder's clock
    double rate_hz = 0, max_gap_s = 0;
    std::string frame_id;  // of its first message, when it has a header
    std::string use;       // "scans", "odometry", "gps", "extrinsics", or "" (unused)
  };
  std::vector<TopicUse> topics;
  std::string lidar_frame, base_frame, gps_frame;
  std::string point_times;         // the clouds' time field: its unit and sweep, or why it was set aside
  std::string lidar;               // packet recordings: the sensor, its rate, sweeps, packets and points
  std::vector<std::string> notes;  // choices made and what was missing
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
  std::string point_times_dir;        // point_times/ when the drive's folder has per-point times, else empty
  bool point_times_in_clouds = false;  // a recording whose clouds carry a per-point time field
  WorldProjection projection;
  std::shared_ptr<RecordingScans> recording;  // set when the scans come from a bag or MCAP file
  RecordingInfo recording_info;

  std::size_t size() const { return frame_ids.size(); }  // scans (a folder: one per file; a recording: one per cloud)
  bool has_ground_truth() const { return !ground_truth.poses.empty(); }
  // The sensor says it sweeps: the points carry their own times (point_times/, a cloud's time field).
  bool has_point_times() const { return !point_times_dir.empty() || point_times_in_clouds; }
  const char* layout_name() const;
  Scan load_scan(std::size_t i) const;
  // Scan i with its rings (when `with_rings`: from the cloud's ring field, else from the meta's point
  // order) and its points' times (from the cloud's time field, or point_times/).
  Frame load_frame(std::size_t i, bool with_rings = true) const;
  // Seconds from the scan's time of each point of scan i (`points` of them), from point_times/;
  // empty when the dataset has none.
  std::vector<float> load_point_times(std::size_t i, std::size_t points) const;
  // Ring of every point of a scan of this dataset (from the meta's point order / beam table).
  std::vector<std::uint16_t> rings(const Scan& scan) const;
  // A GPS position in the world frame; throws when the dataset has no geographic reference.
  Eigen::Vector3d to_world(const GeoPoint& p) const;
};

// Reads the layout found at `path`: a KITTI folder, a ROS 1 bag, a ROS 2 bag (folder or .db3) or an
// MCAP file (their scans point clouds or a LiDAR's packets), or a pcap capture of a LiDAR's packets. Throws pl::Error naming the file, the line or offset, and what was expected.
Dataset open_dataset(const std::string& path, const DatasetOptions& options = {});
// A recording's dataset (open_dataset calls it for bags and MCAP files).
Dataset open_recording(const std::string& path, const DatasetOptions& options = {});

// Parses a KITTI raw timestamp ("2011-09-26 13:04:32.349659964") to seconds since 1970 (UTC): exactly
// to nanoseconds, and in seconds as ns_to_seconds() gives them.
bool parse_kitti_timestamp_ns(const std::string& text, std::int64_t& ns);
bool parse_kitti_timestamp(const std::string& text, double& seconds);
// The one conversion of a time in nanoseconds (a recording's stamps, KITTI's timestamps) to seconds,
// so that the same instant gives the same double whichever way a drive was read.
inline double ns_to_seconds(std::int64_t ns) { return static_cast<double>(ns) * 1e-9; }

}  // namespace pl
