// PointLocalization, one scan at a time, never wrong without saying so:
//  1. predict the pose at the scan's time (external odometry applied to the last fused pose, else
//     momentum), with an uncertainty that grows with time and distance since the last accepted fix;
//  2. without external odometry, LiDAR odometry measures the motion since the previous scans;
//  3. register the scan to the tiles around the prediction over a basin as wide as the uncertainty
//     (plain ICP, coarse-to-fine, or a search of the whole uncertainty region);
//  4. check the result for integrity (points on a map surface, residual, against the recent past,
//     and whether a distinctly different pose explains the scan about as well), gate it by the
//     prediction's uncertainty, fuse it, and report a health and a protection level (a bound on the
//     position error).
#pragma once

#include <Eigen/Geometry>

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "pl/client/fusion.hpp"
#include "pl/client/lidar_odometry.hpp"
#include "pl/client/odometry.hpp"
#include "pl/client/roi_map.hpp"
#include "pl/common/scan.hpp"
#include "pl/registration/icp.hpp"
#include "pl/registration/place_index.hpp"
#include "pl/registration/pose_search.hpp"

namespace pl::client {

// How far the prediction may be off, 1 sigma, in the frame of the vehicle's heading.
struct Uncertainty {
  double along = 0, across = 0;  // metres
  double yaw = 0;                // radians
  double horizontal() const { return along > across ? along : across; }
};

// How the prediction's uncertainty grows, and which basin it asks of the registration.
struct MotionConfig {
  double max_speed_mps = 30.0;      // a start with no velocity may be moving this fast, forward or back
  double max_yaw_rate_dps = 30.0;   // ... and turning this fast
  // With motion compensation and no velocity yet (a start, a search after a jump): the grids the
  // sweep's motion is sought on from its own distortion, and the scan points registered for it.
  double sweep_speed_step_mps = 2.5;
  double sweep_yaw_rate_step_dps = 3.0;
  int sweep_points = 4000;  // (0: no search, such a scan is registered as it is; (drive 0005: 1,000 of its 16-beam scans' ~2,700 points gave 0.063 m at 4x, all 0.060)
  double speed_sigma_mps = 0.3;     // momentum: the velocity measured from the last scans (1 sigma)
  double yaw_rate_sigma_dps = 1.5;
  double accel_sigma_mps2 = 1.0;    // ... and how fast it changes since (1 sigma)
  double yaw_accel_sigma_dps2 = 10.0;  // a bend's turn rate builds up within a second or two (drive 0005
                                       // at 4x: at 5, momentum was 12 deg off at a bend's start, beyond
                                       // 3 sigma, and the right result was gated: 0.095 m mean, 0.99 max)
  double odometry_sigma_m = 0.03;   // LiDAR odometry: per scan, plus a share of the distance
  double odometry_share = 0.01;
  double odometry_sigma_deg = 0.15;
  double odometry_gate_m = 1.0;     // from the fine basin an increment this far (or 3 sigma + gate floor) off is a slide
  double fix_floor_m = 0.03;        // a fix is never taken as better than this (1 sigma)
  double fix_floor_deg = 0.1;
  double fine_basin_m = 0.45;       // 3 sigma within this: plain ICP on the fine map
  double fine_basin_deg = 3.0;
  double coarse_basin_m = 3.0;      // within this: coarse map first; beyond: a search of the region
  double coarse_basin_deg = 10.0;
  double search_along_m = 40.0;     // a search covers at most this far along the heading
  double search_across_m = 12.0;    // ... and across it
  double gate_floor_m = 0.3;        // a correction beyond 3 sigma of the prediction plus this is not
  double gate_floor_deg = 2.0;      // fused
  double lost_m = 2.0;              // an unfused scan with a 3-sigma uncertainty beyond this is lost
  // A scan that fits neither the map round the prediction nor the recent scans: the vehicle may have
  // been moved (a kidnapping, a long outage). The next scans search this far round the last pose,
  // every heading within relocalize_deg, until a verified pose is found.
  double relocalize_m = 40.0;
  double relocalize_deg = 30.0;
  int max_seeds = 2500;             // a search's seeds at most (its position step grows to fit)
};

// The checks a fused result must pass to be `ok`.
struct IntegrityConfig {
  double min_share = 0.6;     // absolute: share of the scan's points on a map surface within delta;
  double max_rms_m = 0.15;    //   residual RMS. Failing either, the result is not fused.
  double share_drop = 0.06;   // relative to the recent verified scans: the share fell by more than this,
  double rms_rise = 1.3;      //   or the residual rose this many times
  int reference_scans = 20;   // the recent verified scans the relative checks compare with
  // Re-registrations from perturbed seeds: a distinctly different pose (farther than distinct_m or
  // turned more than distinct_deg)
  // scoring at least ambiguity_ratio of the solution's makes the scan ambiguous (degraded); scoring
  // better by that ratio, it replaces the solution (a wrong minimum escaped).
  int seeds = 6;  // +-1 and +-1.7 seed_offset_m along the direction held least, +-seed_yaw_deg
  double seed_offset_m = 1.0;
  double seed_yaw_deg = 5.0;
  double distinct_m = 0.5;
  double distinct_deg = 3.0;  // ... or turned more than this
  double ambiguity_ratio = 0.85;
  // After an ambiguous scan the next ambiguity_hold scans are not ok (degraded, the alternative's
  // distance kept in their protection level) even when their seeds find no alternative.
  int ambiguity_hold = 3;
  // Probes of the minimum's flatness: the fine registration started probe_m either way along the
  // direction held least (probe_points of the scan, probe_iterations); how far from the solution
  // they end is added to the protection level (a flat basin holds the position less than the
  // covariance says).
  double probe_m = 0.4;
  int probe_points = 800;
  int probe_iterations = 10;
  // The protection level: map_error_m + sigmas x the registration's position sigma (inflated for
  // the correlation of neighbouring residuals, as if only `independent_pairs` were independent),
  // plus the spread of near-equal alternatives; unfused, the prediction's 3 sigma is added.
  double map_error_m = 0.2;  // drive 0005: fits 0.24 m off its OXTS truth on a verified stretch (docs/pl-localize.md)
  double sigmas = 3.0;
  double independent_pairs = 50.0;
  // The alert limit: a scan whose protection level exceeds it is not ok (degraded, "protection level
  // above the alert limit"), however its checks went: its own bound then says the error may be more
  // than the vehicle tolerates. Drive 0005 driven backwards with a 180 deg field of view: a scan
  // sliding along a flat basin was ok 0.53 m off under a 0.57 m bound.
  double alert_limit_m = 0.5;
};

// Place recognition in a search for a lost or unknown pose: the map's places (pl-map build) whose
// descriptors look most like the scan's are searched round, every heading, not only round the
// prediction.
struct PlaceConfig {
  int proposals = 8;         // places searched round per scan
  double search_m = 4.0;     // this far round each (the places' spacing and the lane's offset)
  double search_deg = 12.0;  // and this far round the heading the descriptor gives (its sector is 6 deg)
};

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
  RoiMapConfig coarse_map = [] {
    RoiMapConfig c;
    c.cell_m = 2.0;  // for wide basins: pairs up to 2 m
    c.thin_m = 0.6;  // a few points per cell are enough to find the basin
    return c;
  }();
  registration::IcpConfig icp = [] {
    registration::IcpConfig c;
    // The kernel's final scale. With pairs already cut at delta (the map's 0.5 m cells), a wider kernel
    // keeps the pairs that pull a start 0.2-0.4 m off into the minimum; 0.3 m weighted 0.2 m residuals
    // by half and the registration stopped short. Drive 0005, LiDAR only, every 1st-4th odd scan (all
    // k phases; the odometry's kernel the same): APE mean 0.055 / 0.054 / 0.057 / 0.057 m at 0.5,
    // 0.057 / 0.061 / 0.077 / 0.075 m at 0.3. 0.7 and 1.0 did about as well as 0.5; moving traffic pulls
    // the other way (the demo's town loop, 12 movers: 0.032 m at 0.3, 0.033 at 0.5, 0.034 at 0.7).
    c.kernel_m = 0.5;
    c.max_iterations = 50;
    return c;
  }();
  FusionConfig fusion;
  MotionConfig motion;
  IntegrityConfig integrity;
  PlaceConfig places;
  // Motion compensation: each scan's points moved to where the sensor was at the scan's time, by the
  // predicted motion over a sweep of sweep_s (constant velocity), each point's time from its
  // azimuth (a counter-clockwise spin timed facing ahead: what fits KITTI's drive 0005). Off for scans taken at one
  // pose; skipped where the caller compensated already (Prediction::compensated) or the velocity is
  // not known yet.
  bool compensate_motion = false;  // off by default: on KITTI raw it did not help (docs/pl-localize.md)
  double sweep_s = 0.1;
  bool lidar_odometry = true;  // measure the motion with LiDAR odometry where no external odometry covers it
  LidarOdometryConfig odometry;
  int lost_after = 10;           // consecutive unfused scans before "lost"
  double outdated_share = 0.45;  // share of scan points without a map pair that suggests an outdated map
};

enum class Health { Ok, Degraded, Lost };
const char* health_name(Health h);

// How far from the prediction the registration looked: ICP from it, coarse map first, or a search
// of the whole uncertainty region.
enum class Basin { Fine, Coarse, Search };
const char* basin_name(Basin b);

// The prediction of a scan's pose, taken under the caller's lock (it reads the odometry buffer).
struct Prediction {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  bool odometry = false;  // external odometry covers the interval since the last scan
  bool compensated = false;  // the caller moved the points for the motion during the sweep (per-point times)
};

struct ScanReport {
  double t = 0;
  Eigen::Isometry3d predicted = Eigen::Isometry3d::Identity();  // after LiDAR odometry, when it ran
  Eigen::Isometry3d fused = Eigen::Isometry3d::Identity();      // the pose reported for the scan
  registration::IcpResult icp;
  Uncertainty uncertainty;             // the prediction's (1 sigma)
  Basin basin = Basin::Fine;
  int place_proposals = 0;             // places searched round (a search with the map's places)
  const char* motion = "momentum";     // odometry, lidar odometry, momentum, start
  bool odometry_ok = false;            // LiDAR odometry gave the increment
  bool compensated = false;            // the scan was corrected for the motion during its sweep
  double sweep_speed_mps = 0.0;        // with no velocity yet: the speed the sweep's distortion showed,
  double sweep_yaw_rate_dps = 0.0;     // the turn rate,
  double sweep_search_ms = 0.0;        // and the time that search took
  bool fused_lidar = false;            // the registration was accepted and fused
  bool vertical_from_map = false;      // not fused, but its height, roll and pitch were taken (plausible, within the gate)
  bool gated = false;                  // rejected by the gate on the prediction's uncertainty (a jump)
  bool plausible = false;              // the absolute checks passed (share on a map surface, residual)
  bool consistent = false;             // the relative checks passed (against the recent verified scans)
  bool verified = false;               // ... and the relative ones, and no alternative fits about as well
  bool integrity = false;              // verified, from the registration's own minimum: the scan may be ok
  bool ambiguous = false;              // a distinctly different pose explains the scan about as well
  bool after_ambiguity = false;        // within IntegrityConfig::ambiguity_hold scans of an ambiguous one
  bool resolved = false;               // a perturbed seed found a better minimum, which was taken
  double alternative_m = 0;            // distance to the best distinct alternative (0: none)
  Eigen::Isometry3d alternative = Eigen::Isometry3d::Identity();  // that alternative's pose (when alternative_m > 0)
  bool disambiguated = false;          // ambiguous, but the prediction's gate holds the solution and not the alternative
  double registration_sigma_m = 0;     // the registration's horizontal position sigma, inflated
  double basin_spread_m = 0;           // how far probes either side of the solution ended from it
  double protection_m = 0;             // bound on the horizontal position error
  Health health = Health::Ok;
  std::string note;                    // why degraded or lost
  bool map_outdated = false;
  std::size_t scan_points = 0;  // after preparation: the points registered
  std::size_t map_tiles = 0, map_points = 0;
  double prepare_ms = 0, map_ms = 0, register_ms = 0, odometry_ms = 0, integrity_ms = 0;
  Eigen::Vector3d position_sigma = Eigen::Vector3d::Zero();  // sqrt of the covariance proxy's diagonal
};

// Tiles around a point: the ROI map's source (the tile client over HTTP, or a store in benchmarks).
using TileProvider = std::function<std::vector<MapTile>(const Eigen::Vector2d& center, double radius)>;

class Localizer {
 public:
  Localizer(const LocalizerConfig& cfg, double tile_size, TileProvider tiles);
  ~Localizer();

  // Starts at `pose` (map frame) at time t; `odometry` (may be nullptr) must outlive the localizer.
  // The velocity is unknown: the next scan is searched as far as the vehicle could have gone.
  void start(const Eigen::Isometry3d& pose, double t, const OdometryBuffer* odometry);
  // One scan (sensor frame) taken at t, with its rings (needed when fewer beams are kept).
  ScanReport process(double t, const Scan& scan, const std::vector<std::uint16_t>& rings);
  // Registers an already prepared scan: register_at(t, points, predict(t)), then fuse().
  ScanReport process_prepared(double t, const std::vector<Eigen::Vector3f>& points);

  // The halves of process_prepared, for callers that run registration on another thread than the
  // one reading poses: predict() reads the odometry (under the caller's lock), register_at touches
  // only the maps and the LiDAR odometry, fuse() the filter and the health state.
  Prediction predict(double t) const;
  ScanReport register_at(double t, const std::vector<Eigen::Vector3f>& points, const Prediction& prediction);
  void fuse(ScanReport& report);

  // The fused pose at any time (odometry rate where there is odometry).
  Eigen::Isometry3d pose_at(double t) const { return fusion_.predict(t); }
  const RoiMap* map() const { return map_.get(); }
  const LocalizerConfig& config() const { return cfg_; }
  // Brings the ROI maps to the tiles around `center` (done by process(); public for start-up).
  void update_map(const Eigen::Vector2d& center);
  // The map's places: a search for a lost or unknown pose asks them where to look. `far_tiles`
  // (default: the tile provider) gives the tiles round a place far from the prediction, waiting for
  // them if it must.
  void set_places(std::shared_ptr<const registration::PlaceIndex> places, TileProvider far_tiles = {});
  bool has_places() const { return places_ && !places_->empty(); }
  // Starts from a rough pose: the scans search within radius_m and yaw_deg of it (with the places
  // there, when there are) and are not ok until a verified pose is found.
  void start_search(const Eigen::Isometry3d& guess, double t, const OdometryBuffer* odometry, double radius_m, double yaw_deg);
  // Starts with no pose at all: the scans search the whole map by its places until a verified pose
  // is found (reported lost until then). Throws pl::Error when there are no places.
  void start_global(double t, const OdometryBuffer* odometry);
  // Searching for a pose: after start_search or start_global, or when lost, until a verified one.
  bool searching() const { return relocalizing_; }

 private:
  LocalizerConfig cfg_;
  double tile_size_;
  TileProvider tiles_;
  std::unique_ptr<RoiMap> map_, coarse_;
  Eigen::Vector2d map_center_ = Eigen::Vector2d::Zero();
  std::shared_ptr<const registration::PlaceIndex> places_;
  TileProvider far_tiles_;
  bool global_ = false;  // no pose yet: searching the whole map
  Fusion fusion_;
  LidarOdometry odometry_;
  // The state between scans (written by fuse on the worker; register_at reads it on the same thread).
  Uncertainty posterior_;      // after the last scan
  bool velocity_known_ = false, previous_fused_ = false, previous_verified_ = false, relocalizing_ = false;
  // An ambiguity along a corridor does not end with the first scan whose seeds happen to find no
  // alternative: scans left before ok again, and the distance of the last alternative.
  int ambiguity_hold_left_ = 0;
  double held_alternative_m_ = 0.0;
  // The last scan whose position was measured, from which momentum's uncertainty grows.
  double anchor_t_ = 0, anchor_speed_ = 0, anchor_speed_sigma_ = 0, anchor_yaw_rate_sigma_ = 0;
  Uncertainty anchor_;
  double last_t_ = 0;
  Eigen::Isometry3d last_pose_ = Eigen::Isometry3d::Identity();
  int unfused_streak_ = 0, unverified_streak_ = 0;
  bool lost_ = false;
  // The last ok scan (or the start pose): where it put the vehicle, when, and its bound.
  bool have_fix_ = false;
  double fix_t_ = 0, fix_protection_m_ = 0;
  double last_protection_m_ = 0;  // the last scan's protection level
  Eigen::Isometry3d fix_pose_ = Eigen::Isometry3d::Identity();
  std::vector<double> recent_share_, recent_rms_;  // of verified scans, for the relative checks
  std::vector<Eigen::Vector3f> scan_;              // the scan between register_at and fuse

  // The prediction's uncertainty at t; `motion_only`: of the motion since the last measured scan alone,
  // without the pose's own uncertainty then (what a registration to the recent scans must reach).
  Uncertainty grow(double t, const Prediction& p, bool motion_only = false) const;
  // The ROI maps from `provider`'s tiles round `center`.
  void load_maps(const Eigen::Vector2d& center, const TileProvider& provider);
  void set_anchor(double t, const Uncertainty& u, bool velocity_known, double speed);
  // From the next scan on, search the relocalization reach round the last pose (at least u).
  void relocalize(double t, const Uncertainty& u);
  // With no velocity yet: the forward speed (m/s, sensor x) whose motion over the sweep, taken out
  // of the scan, lets it register best at `guess`.
  Eigen::Isometry3d sweep_motion(const std::vector<Eigen::Vector3f>& scan, const Eigen::Isometry3d& guess) const;
  // The candidates of a search of the uncertainty region round `guess` (and of the places the scan
  // looks like), best first; leaves the maps round the best.
  std::vector<registration::Candidate> search(const std::vector<Eigen::Vector3f>& points, const Eigen::Isometry3d& guess,
                                              const Uncertainty& u, ScanReport& r);
  void check_integrity(const std::vector<Eigen::Vector3f>& points, ScanReport& r,
                       std::vector<registration::Candidate> alternatives) const;
};

// The scan's points as registration input (float, sensor frame): pl/common/scan.hpp's.
using pl::to_points;

}  // namespace pl::client
