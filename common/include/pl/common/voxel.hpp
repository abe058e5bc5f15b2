// Deterministic voxel-grid downsampling: one point per occupied voxel, at the centroid of the points
// in it (intensity averaged too), voxels in the order of their first point. Voxel indices are
// computed in double precision and keyed relative to the cloud's own lowest voxel, so clouds hundreds
// of kilometres from their origin downsample exactly like clouds near it.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "pl/common/scan.hpp"

namespace pl {

using Points3d = std::vector<Eigen::Vector3d>;

Scan voxel_downsample(const Scan& scan, double voxel_m);
Points3d voxel_downsample(const Points3d& points, double voxel_m);
// Same, with a per-point scalar (e.g. intensity) averaged per voxel into `values_out`.
Points3d voxel_downsample(const Points3d& points, const std::vector<float>& values, double voxel_m,
                          std::vector<float>& values_out);

}  // namespace pl
