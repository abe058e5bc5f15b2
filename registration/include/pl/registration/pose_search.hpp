// Start-up from a rough pose (an initial pose off by metres and tens of degrees, the first GPS fix
// with no heading, a loop proposal by place): seeds on a grid of positions and headings round the
// guess, each registered against a coarse map, the best few refined on the fine one.
#pragma once

#include <Eigen/Geometry>

#include <vector>

#include "pl/registration/icp.hpp"
#include "pl/registration/point_map.hpp"

namespace pl::registration {

// The grid of seeds: positions within radius_m every position_step_m, headings within
// +-yaw_range_deg every yaw_step_deg of the guess.
struct PoseSearch {
  double radius_m = 6.0, position_step_m = 2.0;
  double yaw_range_deg = 45.0, yaw_step_deg = 15.0;
};

// Every seed against `coarse` (the same points in 2 m cells, pairs up to 2 m) with at most 400 of
// the scan's points, the best five refined on `fine` with the whole scan and `icp`; the accepted one
// pairing most points with the smallest residual is written to pose_out. Returns false when no seed
// gives an accepted registration.
bool search_pose(const PointMap& coarse, const PointMap& fine, const std::vector<Eigen::Vector3f>& scan,
                 const Eigen::Isometry3d& guess, const PoseSearch& search, const IcpConfig& icp, Eigen::Isometry3d& pose_out);

}  // namespace pl::registration
