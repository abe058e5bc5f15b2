// Local shape from neighbouring points: the normal of every point of a map cloud, and the line or
// plane through a feature's few nearest map points.
#pragma once

#include <Eigen/Core>
#include <Eigen/Eigenvalues>

#include <vector>

#include "pl/registration/gauss_newton.hpp"

namespace pl::registration {

// The normal of each point: the direction of least spread of its neighbours within `radius` (at least
// 5 of them; otherwise straight up). Oriented deterministically: up when it is not near horizontal,
// else towards +x or +y. Optionally the planarity (1 - smallest/middle eigenvalue) of each.
// Throws pl::Error when the radius is not positive.
std::vector<Eigen::Vector3f> estimate_normals(const std::vector<Eigen::Vector3d>& points, double radius,
                                              std::vector<float>* planarity = nullptr);

// The neighbourhood of a map's normals: 3 voxels of the map. pl-map estimates the normals it
// stores in tiles with it, and a vehicle those of tiles stored without.
inline double map_normal_radius(double voxel_m) { return 3.0 * voxel_m; }

// Centroid and principal axes (eigenvalues ascending) of `count` points.
void principal_axes(const Eigen::Vector3f* points, int count, Eigen::Vector3d& centroid,
                    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>& axes);

// The line through the points when they spread `ratio` times more along one direction than across
// it; the target's two rows are the directions across it.
bool fit_line(const Eigen::Vector3f* points, int count, double ratio, FeatureTarget& out);
// The plane through the points when every one lies within `max_dist` of it (one row).
bool fit_plane(const Eigen::Vector3f* points, int count, double max_dist, FeatureTarget& out);

}  // namespace pl::registration
