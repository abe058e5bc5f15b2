// Things that moved during the mapping drives, found in a merged map by free-space evidence: a map
// point that rays of other scans passed through was not there all the time, so it is not structure
// the vehicle will find tomorrow.
//
// The rule: a merged point is removed when the rays of at least min_passes scans crossed it
// (pl/registration/ray_crossing.hpp: through its tangent plane, near it, at |cos incidence| >= 0.2,
// at least 1 m short of the ray's own return) and those scans are at least pass_share of the scans
// that returned from its voxel. A scan's crossing does not count when that scan itself returned from
// within confirm_voxels of the point (glass, leaves, an edge, a pose a little off: the surface is
// still there), nor when a later scan returned from its voxel again (it was there before and after).
// A parked car seen by every scan of a drive is crossed by few rays, at its edges: it stays.
// Rays are the scans' returns and, with the drive's beam table, the sky rays: where an upward beam
// returned nothing, it looked through free space (what stood above the sensor is crossed only so).
// Also removed: what lies in the vehicle's own corridor (a lead vehicle in the lane is never seen
// through, but the mapping vehicle drove where it was).
#pragma once

#include <Eigen/Core>

#include <cstdint>
#include <memory>
#include <vector>

#include "pl/common/pose.hpp"
#include "pl/common/voxel.hpp"
#include "pl/registration/ray_crossing.hpp"

namespace pl::maps {

// The change reports' ray test, with probes from 1.5 m and crossings down to |cos| 0.2: on the
// town's three drives with traffic these took the ghosts left from 30 % to 19 % of a plain merge's
// for 0.07 percentage points of static structure.
inline registration::RayCrossingConfig free_space_rays() {
  registration::RayCrossingConfig r;
  r.start_m = 1.5;
  r.min_incidence = 0.2;
  return r;
}

struct FreeSpaceConfig {
  double min_range_m = 2.0, max_range_m = 40.0;  // returns whose rays are walked (sensor frame range)
  double ray_voxel_m = 0.5;    // a scan thinned to one return per voxel for its rays
  double min_travel_m = 0.5;   // a scan's rays walked once the sensor moved this far since the last
  registration::RayCrossingConfig ray = free_space_rays();  // its start_m is where a ray's probes begin
  std::uint32_t min_passes = 2;  // a map point is removed when at least this many scans' rays crossed it
  double pass_share = 1.0;       // ... and at least this share of the scans that returned from its voxel
  int confirm_voxels = 2;        // a scan's crossing does not count when it returned this near (voxels)
  // The vehicle's own corridor: map points within corridor_m (horizontally) of the sensor's path
  // between consecutive scans of a drive, from corridor_below_m below the sensor to corridor_above_m
  // above it, are removed: the vehicle drove there. corridor_m = 0: no corridor.
  double corridor_m = 1.0, corridor_below_m = 1.4, corridor_above_m = 0.3;
  double max_corridor_step_m = 10.0;  // consecutive scans farther apart than this are not joined (a gap)
  // Sky rays: a beam at or above sky_min_elevation_deg that returned nothing in an azimuth bin of
  // sky_bin_deg, nor in the bins beside it, nor did the beam below (a clearance over the skyline),
  // looked through free space out to sky_range_m (the sky, or beyond the merge's range). Walked from
  // sky_start_m: nearer, an upward beam passes what is below 2.2 m (glass, leaves, a dark car) and
  // returns nothing as it would from the sky. They need the drive's beam table (begin_drive);
  // sky_range_m = 0: none.
  double sky_range_m = 80.0, sky_min_elevation_deg = 0.0, sky_bin_deg = 1.0, sky_start_m = 15.0;
  double sky_near_deg = 0.1;  // a sky ray also crosses, whatever its normal, a map point within this angle
  // Throws pl::Error naming the field and its allowed range.
  void validate() const;
};

struct FreeSpaceReport {
  std::size_t points = 0;               // merged map points
  std::size_t scans = 0;                // scans added
  std::size_t walked = 0;               // scans whose rays were walked (min_travel_m)
  std::size_t rays = 0;                 // rays walked
  std::size_t sky_rays = 0;             // of them, sky rays
  std::size_t passed = 0;               // map points some scan's rays crossed
  std::size_t removed_by_rays = 0;      // removed by the rule
  std::size_t removed_by_corridor = 0;  // removed by the corridor and not by the rule
  double ms = 0;                        // time in add_scan, all scans (steady clock)
};

class FreeSpaceFilter {
 public:
  // The merged map: voxel centroids (world frame, voxel_m voxels, one point per voxel), one unit
  // normal each, and per point the number of scans that returned from its voxel (`seen`). Throws
  // pl::Error when the sizes differ, voxel_m is not within 0.02..5 m or the config is invalid.
  FreeSpaceFilter(const Points3d& points, const std::vector<Eigen::Vector3f>& normals, const std::vector<std::uint32_t>& seen,
                  double voxel_m, const FreeSpaceConfig& cfg);
  ~FreeSpaceFilter();
  FreeSpaceFilter(const FreeSpaceFilter&) = delete;
  FreeSpaceFilter& operator=(const FreeSpaceFilter&) = delete;

  // A new drive: the corridor is not drawn from the last drive's last scan. `beams_deg`: its sensor's
  // beam elevations (the sky rays'); empty: no sky rays for this drive.
  void begin_drive(const std::vector<double>& beams_deg = {});
  // One scan: points in the sensor frame, the sensor pose in the world frame; `origins`, empty or
  // one per point (sensor frame): where the sensor fired each point (a deskewed sweep). Throws
  // pl::Error when origins has another size.
  void add_scan(const Pose& sensor, const std::vector<Eigen::Vector3f>& points, const std::vector<Eigen::Vector3f>& origins = {});

  const std::vector<std::uint32_t>& passes() const;  // per map point: scans whose rays crossed it
  std::vector<bool> moving() const;                  // per map point: removed (rays or corridor)
  FreeSpaceReport report() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace pl::maps
