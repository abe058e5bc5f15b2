// PointLocalization, one scan at a time: predict the pose at the scan's time (odometry applied to the
// last fused pose, or momentum), bring the ROI map up to date from the tiles around the prediction,
// prepare the scan (beams, field of view, range, voxels), register it point-to-plane, check the
// result, fuse it at the scan's time, and say how healthy the estimate is.
#pragma once

#include <Eigen/Geometry>

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "pl/client/fusion.hpp"
#include "pl/client/odometry.hpp"
#include "pl/client/roi_map.hpp"
#include "pl/common/scan.hpp"
#include "pl/registration/icp.hpp"
#include "pl/registration/pose_search.hpp"

namespace pl::client {

struct LocalizerConfig {
  ScanPrepConfig scan = [] {
    ScanPrepConfig c;
    c.voxel_m = 1.0;  // registration points: a 16-beam KITTI scan keeps ~2,700; coarser than the map's
                      // 0.2 m so the ground does not outweigh the few surfaces that fix the position along
                      // the road (drive 0005: 0.057 m mean APE at 1.0 m, 0.067 m at 0.4 m)
    c.max_range_m = 80.0;
    return c;
  }();
  double roi_radius_m = 90.0;  // tiles kept around the prediction: the scan's range plus margin
  RoiMapConfig map = [] {
    RoiMapConfig c;
    c.cell_m = 0.5;  // pairs within 0.25 m found exactly, up to 0.5 m approximately
    return c;
  }();
  registration::IcpConfig icp = [] {
    registration::IcpConfig c;
    c.kernel_m = 0.3;
    c.max_iterations = 50;
    return c;
  }();
  FusionConfig fusion;
  // Health.
  double max_correction_m = 1.5;    // a registration moving the prediction further is not fused
  double max_correction_deg = 8.0;  // (unless the estimate is already lost)
  int lost_after = 10;              // consecutive unfused scans before "lost"
  double outdated_share = 0.45;     // share of scan points without a map pair that suggests an outdated map
};

enum class Health { Ok, Degraded, Lost };
const char* health_name(Health h);

struct ScanReport {
  double t = 0;
  Eigen::Isometry3d predicted = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d fused = Eigen::Isometry3d::Identity();  // the pose reported for the scan
  registration::IcpResult icp;
  bool fused_lidar = false;  // the registration was accepted and fused
  Health health = Health::Ok;
  std::string note;          // why degraded or lost
  bool map_outdated = false;
  bool diverging = false;
  std::size_t scan_points = 0;  // after preparation: the points registered
  std::size_t map_tiles = 0, map_points = 0;
  double prepare_ms = 0, map_ms = 0, register_ms = 0;
  Eigen::Vector3d position_sigma = Eigen::Vector3d::Zero();  // sqrt of the covariance proxy's diagonal
};

// Tiles around a point: the ROI map's source (the tile client over HTTP, or a store in benchmarks).
using TileProvider = std::function<std::vector<MapTile>(const Eigen::Vector2d& center, double radius)>;

class Localizer {
 public:
  Localizer(const LocalizerConfig& cfg, double tile_size, TileProvider tiles);
  ~Localizer();

  // Starts at `pose` (map frame) at time t; `odometry` (may be nullptr) must outlive the localizer.
  void start(const Eigen::Isometry3d& pose, double t, const OdometryBuffer* odometry);
  // One scan (sensor frame) taken at t, with its rings (needed when fewer beams are kept).
  ScanReport process(double t, const Scan& scan, const std::vector<std::uint16_t>& rings);
  // Registers an already prepared scan: register_at(t, points, pose_at(t)), then fuse().
  ScanReport process_prepared(double t, const std::vector<Eigen::Vector3f>& points);

  // The two halves of process_prepared, for callers that run registration on another thread than
  // the one reading poses: register_at touches only the ROI map (not the filter), fuse() only the
  // filter and the health state.
  ScanReport register_at(double t, const std::vector<Eigen::Vector3f>& points, const Eigen::Isometry3d& predicted);
  void fuse(ScanReport& report);

  // The fused pose at any time (odometry rate where there is odometry).
  Eigen::Isometry3d pose_at(double t) const { return fusion_.predict(t); }
  const RoiMap* map() const { return map_.get(); }
  const LocalizerConfig& config() const { return cfg_; }
  // Brings the ROI map to the tiles around `center` (done by process(); public for start-up).
  void update_map(const Eigen::Vector2d& center);
  // Start-up from a rough pose: search_pose over the tiles around it with the first scan, then start.
  // Returns false (and starts at the guess) when the search finds nothing.
  bool start_near(const Eigen::Isometry3d& guess, double t, const OdometryBuffer* odometry, const Scan& scan,
                  const std::vector<std::uint16_t>& rings, const registration::PoseSearch& search = {});

 private:
  LocalizerConfig cfg_;
  double tile_size_;
  TileProvider tiles_;
  std::unique_ptr<RoiMap> map_;
  Fusion fusion_;
  int unfused_streak_ = 0;
  bool lost_ = false;
  std::vector<double> recent_share_, recent_rms_;  // for the divergence detector
};

// The scan's points as registration input (float, sensor frame).
std::vector<Eigen::Vector3f> to_points(const Scan& scan);

}  // namespace pl::client
