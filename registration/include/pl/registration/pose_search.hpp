// Registration from a pose known only roughly: coarse-to-fine when the guess is off by a metre or
// two, and a search over seeds when it is off by more (an initial pose off by metres and tens of
// degrees, the first GPS fix with no heading, a start with no velocity, a loop proposal by place,
// the candidates of a relocalization). Seeds are registered against a coarse map (the same points in
// 2 m cells), the best few refined on the fine one.
#pragma once

#include <Eigen/Geometry>

#include <vector>

#include "pl/registration/icp.hpp"
#include "pl/registration/point_map.hpp"

namespace pl::registration {

// The region searched round a guess: positions within an ellipse of half-axes along_m (the guess's
// heading) and across_m, or the disc of radius_m when they are not set, every position_step_m;
// headings within +-yaw_range_deg every yaw_step_deg.
struct PoseSearch {
  double radius_m = 6.0, position_step_m = 2.0;
  double along_m = 0, across_m = 0;  // both > 0: the ellipse instead of the disc
  double yaw_range_deg = 45.0, yaw_step_deg = 15.0;
  int refine = 5;  // the best seeds refined on the fine map
};

// The score registrations are ranked by: the share of points paired over the residual.
double registration_score(const IcpResult& r);

struct Candidate {
  IcpResult icp;  // on the fine map
  double score = 0;
};

// Every seed of the region against `coarse` with at most 400 of the scan's points, the best
// `search.refine` refined on `fine` with the whole scan and `icp`. Returns the accepted refinements,
// best first, with refinements that ended within 0.3 m and 1 deg of a better one dropped.
std::vector<Candidate> search_poses(const PointMap& coarse, const PointMap& fine, const std::vector<Eigen::Vector3f>& scan,
                                    const Eigen::Isometry3d& guess, const PoseSearch& search, const IcpConfig& icp);

// The best of search_poses in pose_out; false when no seed gives an accepted registration.
bool search_pose(const PointMap& coarse, const PointMap& fine, const std::vector<Eigen::Vector3f>& scan,
                 const Eigen::Isometry3d& guess, const PoseSearch& search, const IcpConfig& icp, Eigen::Isometry3d& pose_out);

// The wide settings the seeds use on a coarse map: pairs up to 2 m, a kernel from 2 m down to 0.5 m.
IcpConfig coarse_icp(const IcpConfig& fine, int iterations = 12);

// At most `count` of the points, evenly taken.
std::vector<Eigen::Vector3f> subsample(const std::vector<Eigen::Vector3f>& points, std::size_t count);

// A guess off by up to about 2 m: the coarse map first (with `coarse_points` of the scan), then the
// fine one from where that ended.
IcpResult register_coarse_to_fine(const PointMap& coarse, const PointMap& fine, const std::vector<Eigen::Vector3f>& scan,
                                  const Eigen::Isometry3d& guess, const IcpConfig& icp, std::size_t coarse_points = 800);

}  // namespace pl::registration
