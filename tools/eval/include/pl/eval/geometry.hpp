// Trajectory geometry shared by the metrics: positions, distance travelled, the horizontal
// direction of travel and the choice of the vertical axis.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "pl/common/pose.hpp"

namespace pl::eval {

using Positions = std::vector<Eigen::Vector3d>;

Positions positions_of(const Trajectory& traj);

// Cumulative path length: out[0] = 0, out[i] = out[i-1] + |p[i] - p[i-1]|.
std::vector<double> path_distances(const Positions& p);

// The ground-truth axis that points up (0 = x, 1 = y, 2 = z). Map/LiDAR frames are z-up, but
// KITTI's cam0 frame is y-down (x right, z forward), so "auto" picks the axis along which the
// positions spread least (a ground vehicle moves far more horizontally than vertically); ties go
// to z, then y. A nearly straight drive up a slope can fool it: pass the axis explicitly then.
int auto_vertical_axis(const Positions& gt);
char axis_name(int axis);
// "x", "y", "z" -> 0, 1, 2; anything else -> -1.
int parse_axis(const std::string& name);

// Unit direction of travel in the horizontal plane (the plane normal to `vertical_axis`) at each
// position, from its neighbours: p[k+1] - p[k-1] (one-sided at the ends), widened symmetrically
// while the horizontal displacement is below 1 mm (stops). Positions where no movement is found
// take the direction of the nearest position that has one; a trajectory that never moves gets
// the first horizontal axis.
Positions travel_directions(const Positions& p, int vertical_axis);


}  // namespace pl::eval
