// What the vehicle sees of a map's age: from scans localized `ok`, evidence per map voxel that the
// world changed since the map was made, kept per tile for a change report.
//
//  - added: a scan point with no map surface within delta (a thing that was not there). The voxel
//    also counts the scans whose rays later passed through it (`free`): a moving truck is seen
//    through once it has gone, a parked one is not.
//  - removed: a map point a ray passed through on its way to a farther return (a thing that is no
//    longer there), against the scans that returned from that voxel (`seen`).
//
// Evidence is counted once per scan and voxel, so a count is a number of scans that agree. Nothing
// here decides what changed: the map service does that over many drives (pl/maps/change_detect.hpp).
#pragma once

#include <Eigen/Geometry>

#include <cstdint>
#include <memory>
#include <vector>

#include "pl/common/tile_key.hpp"
#include "pl/registration/point_map.hpp"
#include "pl/schema/change_report.hpp"

namespace pl::client {

struct ChangeEvidenceConfig {
  bool enabled = false;          // the vehicle localizer keeps evidence only when asked
  double delta_m = 0.5;          // a scan point with no map point this near is new (ICP's pair limit)
  double voxel_m = 0.5;          // the evidence grid; a scan counts once per voxel
  double min_range_m = 3.0;      // nearer returns are skipped (the vehicle, its neighbours' mirrors)
  double max_range_m = 40.0;     // farther ones are sparse and their rays long through a tilted map
  double ray_step_m = 0.5;       // a ray's free space is probed this often
  double ray_margin_m = 1.0;     // ... up to this short of its own return
  double pass_radius_m = 0.35;   // a probe this near a map point asks whether the ray passed through it:
  double cross_radius_m = 0.15;  // whether it crossed the point's tangent plane this near the point
  double min_incidence = 0.4;    // ... at |cos| of the ray and the point's normal of at least this (a
                                 // ray grazing the ground on its way to a far return is no evidence)
  double min_travel_m = 2.0;     // evidence from an ok scan once the sensor moved this far since the last
                                 // one that gave some: a vehicle waiting at a light beside a truck
                                 // would otherwise count the truck a hundred times
  double corridor_m = 1.0;       // what was added within this of the sensor's own path (from 2.2 m below
                                 // it to 2.5 m above: a truck's height) is no evidence: the vehicle
                                 // drove there, so it was free (a truck in the lane that keeps its
                                 // distance is never seen through)
  std::size_t max_cells_per_tile = 4096;  // a report's bound: the voxels with most evidence are kept
  double sample_m = 0.2;                  // the added structure is sampled on this grid (the map's voxel)
  std::size_t max_points_per_tile = 20000;  // a report's bound on a tile's sample (the points most scans saw kept)
  // Throws pl::Error naming the field and its allowed range.
  void validate() const;
};

class ChangeEvidence {
 public:
  ChangeEvidence(const ChangeEvidenceConfig& cfg, double tile_size);
  ~ChangeEvidence();

  // One scan localized ok: its points in the sensor frame, the sensor's pose in the map frame, the
  // map it was registered against; `origins` (empty, or one per point, sensor frame): where the
  // sensor was when it fired each point (a scan corrected for the motion during its sweep).
  // Returns false when the scan was skipped (min_travel_m).
  bool add(const Eigen::Isometry3d& sensor_in_map, const std::vector<Eigen::Vector3f>& points,
           const registration::PointMap& map, const std::vector<Eigen::Vector3f>& origins = {});

  // The evidence so far, per tile in key order: the voxels two or more scans found added or passed
  // through, each tile's bounded by max_cells_per_tile (every tile seen is listed, with no voxels
  // when nothing changed there: a pass that saw no change counts too), and the sample of the added
  // structure in them: per sample_m voxel that two or more scans found added, the mean of its
  // returns (centimetres), bounded by max_points_per_tile.
  std::vector<schema::TileChangeEvidence> tiles() const;
  std::size_t scans_used() const { return used_; }
  const std::vector<double>& milliseconds() const { return ms_; }  // each used scan's time (steady clock)
  const ChangeEvidenceConfig& config() const { return cfg_; }

 private:
  struct Impl;
  void corridor(const Eigen::Vector3d& from, const Eigen::Vector3d& to);  // marks the voxels the vehicle drove through
  ChangeEvidenceConfig cfg_;
  TileGrid grid_;
  std::unique_ptr<Impl> impl_;
  std::size_t used_ = 0;
  std::vector<double> ms_;
};

}  // namespace pl::client
