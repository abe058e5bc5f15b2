// PointLocalization inside a vehicle program (a ROS node, a driver process): one object owns the
// tile client and the localizer, keeps the tile focus and look-ahead itself, takes live inputs from
// any thread and answers the fused pose at any time.
//
//   VehicleLocalizerConfig cfg;                      // map source, extrinsics, localizer settings
//   cfg.tiles.server = "http://maps:8080"; cfg.tiles.map = "town";
//   VehicleLocalizer loc(cfg);
//   loc.start(initial_pose, t0);                     // or start_near(rough, t0), or GPS (see below)
//   driver threads:  loc.add_wheel_travel(t, left_m, right_m);  loc.add_scan(t, points);
//   control loop:    PoseEstimate p = loc.pose_at(now);
//
// - Registration runs on the object's own worker thread. A scan that arrives while the previous one
//   is still being registered replaces the waiting one (the newest scan is the useful one);
//   wait_idle() waits for the worker, for replays that must not drop scans.
// - Odometry is one source at a time, in the base frame: cumulative poses, pose increments, twists or
//   wheel travel / ticks. Its buffer is bounded (max_odometry_samples).
// - Frames: the map frame of the tiles (ENU about the map's origin); the base frame of the vehicle;
//   scans in the LiDAR frame, placed by base_from_lidar; GPS antenna positions in the map frame,
//   placed by the lever arm base_from_antenna.
// - Start: start() at a known pose, start_near() from a rough one (the next scan searches round it),
//   or, with start_from_gps, the first scan searches every heading round the newest GPS fix.
#pragma once

#include <Eigen/Geometry>

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "pl/client/change_evidence.hpp"
#include "pl/client/localizer.hpp"
#include "pl/client/tile_client.hpp"
#include "pl/common/scan.hpp"

namespace pl::client {

struct VehicleLocalizerConfig {
  LocalizerConfig localizer;
  // The map: from pl-server through the tile client (tiles.server, tiles.map, ...), or, with
  // store_path set, straight from a local map store file (tiles.map and tiles.version name the map).
  TileClientConfig tiles;
  std::string store_path;
  double ready_timeout_s = 30.0;  // the constructor waits this long for the map's version and tile size
  // Called while the constructor waits for the map, after 1 s and then at doubling intervals, with
  // what it waits for and why not yet (the server and the tile client's last problem).
  std::function<void(const std::string&)> on_wait;
  double start_wait_s = 30.0;     // a start waits this long for the tiles round the start pose
  double lookahead_s = 3.0;       // tiles are also kept round where the vehicle will be this far ahead
  // Extrinsics.
  Eigen::Isometry3d base_from_lidar = Eigen::Isometry3d::Identity();
  Eigen::Vector3d base_from_antenna = Eigen::Vector3d::Zero();  // the GPS antenna in the base frame
  // Odometry.
  double wheel_base_m = 0;                   // for wheel travel and ticks
  double metres_per_tick = 1.0;              // for add_wheel_ticks
  std::size_t max_odometry_samples = 20000;  // the buffer's bound (200 s at 100 Hz)
  bool start_from_gps = false;               // start at the first scan that has a GPS fix within 0.5 s
  registration::PoseSearch search;           // the reach of start_near(): radius_m and yaw_range_deg
  // Change evidence for the map service (enabled: kept from the ok scans; read it with
  // change_evidence()). Never from a scan that is not ok, and never in the way of the next scan:
  // it is kept after the scan's pose is out, and not at all when the next scan is already waiting.
  ChangeEvidenceConfig changes;
  registration::PoseSearch gps_search = [] {
    registration::PoseSearch s;
    s.yaw_range_deg = 180.0;  // a fix has no heading
    return s;
  }();
};

// The fused pose of the base at a time.
struct PoseEstimate {
  bool valid = false;  // false until started
  double t = 0;
  Eigen::Isometry3d base_in_map = Eigen::Isometry3d::Identity();
  // Covariance proxy of (x, y, z, roll, pitch, yaw) in the base frame: the last fused registration's,
  // grown by the odometry's process noise for every scan interval since.
  Eigen::Matrix<double, 6, 6> covariance = Eigen::Matrix<double, 6, 6>::Identity();
  Health health = Health::Lost;
  std::string note;  // why degraded or lost
};

class VehicleLocalizer {
 public:
  // Opens the map source (throws pl::Error naming the problem: no such store or map, or no answer
  // from the server and no disk cache within ready_timeout_s) and starts the worker.
  explicit VehicleLocalizer(const VehicleLocalizerConfig& cfg);
  ~VehicleLocalizer();  // stops and joins the worker
  VehicleLocalizer(const VehicleLocalizer&) = delete;
  VehicleLocalizer& operator=(const VehicleLocalizer&) = delete;

  // Start (any thread). The tiles round the pose are loaded on the worker, then the filter starts.
  void start(const Eigen::Isometry3d& base_in_map, double t);
  void start_near(const Eigen::Isometry3d& rough_base_in_map, double t);
  // No pose at all: the scans search the whole map by its places (reported lost until a verified
  // pose is found). Throws pl::Error when the map version has no places.
  void start_global(double t);

  // Odometry (any thread; times must increase). Base frame, cumulative in the odometry's own frame.
  void add_odometry_pose(double t, const Eigen::Isometry3d& base_in_odom);
  void add_odometry_increment(double t, const Eigen::Isometry3d& delta);  // since the previous sample
  void add_twist(double t, const Eigen::Vector3d& linear_mps, const Eigen::Vector3d& angular_radps);
  void add_wheel_travel(double t, double left_m, double right_m);         // cumulative metres
  void add_wheel_ticks(double t, std::int64_t left, std::int64_t right);  // cumulative ticks

  // A scan (LiDAR frame) taken at t. rings: one per point, needed when localizer.scan.beams keeps
  // fewer beams than the sensor has; point_times: seconds from t per point, to undo the motion during
  // the sweep with the odometry (either may be empty).
  void add_scan(double t, const Scan& points, const std::vector<std::uint16_t>& rings = {},
                const std::vector<float>& point_times = {});
  // A GPS antenna position in the map frame (used to start with start_from_gps).
  void add_gps(double t, const Eigen::Vector3d& antenna_in_map);

  // The fused pose at t (odometry rate where there is odometry, momentum beyond it).
  PoseEstimate pose_at(double t) const;
  // Until no scan waits or is being registered, or the timeout. Returns whether idle.
  bool wait_idle(double timeout_s = 60.0) const;
  // The report of the last scan registered (empty before the first).
  ScanReport last_report() const;
  // Called on the worker after every scan (keep it short).
  void on_scan(std::function<void(const ScanReport&)> callback);
  // Errors of the worker (a failed start, a start search that found nothing); empty when fine.
  std::string last_error() const;
  // The tiles of the ROI map the scans are registered against (empty before the start), for logs
  // and displays (pl-localize --log). Waits while a scan is being registered (the worker changes the
  // map then); the clouds are shared, not copied.
  std::vector<MapTile> map_tiles() const;
  // The change evidence kept so far (config.changes.enabled), per tile; waits for the scan being
  // registered. Empty when not enabled.
  std::vector<schema::TileChangeEvidence> change_evidence() const;
  struct ChangeStats {
    std::size_t scans = 0;    // ok scans the evidence came from
    std::size_t skipped = 0;  // ok scans passed over because the next scan was already waiting
    std::vector<double> ms;   // each one's time
  };
  ChangeStats change_stats() const;
  double tile_size() const;
  // The geodetic origin of the map's ENU frame: GPS fixes (latitude, longitude) go into the map frame
  // with EnuFrame(map_origin()).to_enu().
  GeoPoint map_origin() const;
  // The map version in use: with tiles.follow_s, a newer published version moves in mid-drive at a
  // safe moment (an ok scan, its tiles round the vehicle loaded), without a jump in the pose.
  long long map_version() const;
  std::size_t version_moves() const;     // how many times it moved
  TileClientStatus tile_status() const;  // default-constructed with a local store
  // The x, y extent of the map version's tiles (ENU, m), when the server's manifest or the local
  // store gives it.
  std::optional<MapExtent> map_extent() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace pl::client
