// Deterministic voxel-grid downsampling: one point per occupied voxel, at the centroid of the points
// in it (intensity averaged too), voxels in the order of their first point. Voxel indices are
// computed in double precision and keyed relative to the cloud's own lowest voxel, so clouds hundreds
// of kilometres from their origin downsample exactly like clouds near it.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cmath>
#include <cstdint>
#include <vector>

#include "pl/common/scan.hpp"

namespace pl {

using Points3d = std::vector<Eigen::Vector3d>;

// The integer index of a voxel (floor of the coordinates over the voxel size), and its hash, for
// hash maps over voxels or grid cells.
using VoxelIndex = std::array<std::int64_t, 3>;
struct VoxelIndexHash {
  std::size_t operator()(const VoxelIndex& k) const {
    std::uint64_t h = static_cast<std::uint64_t>(k[0]) * 0x9E3779B97F4A7C15ull;
    h ^= static_cast<std::uint64_t>(k[1]) * 0xC2B2AE3D27D4EB4Full + (h << 6) + (h >> 2);
    h ^= static_cast<std::uint64_t>(k[2]) * 0x165667B19E3779F9ull + (h << 6) + (h >> 2);
    return static_cast<std::size_t>(h);
  }
};
inline VoxelIndex voxel_index(const Eigen::Vector3d& p, double inv_voxel) {
  return {static_cast<std::int64_t>(std::floor(p.x() * inv_voxel)), static_cast<std::int64_t>(std::floor(p.y() * inv_voxel)),
          static_cast<std::int64_t>(std::floor(p.z() * inv_voxel))};
}

Scan voxel_downsample(const Scan& scan, double voxel_m);
Points3d voxel_downsample(const Points3d& points, double voxel_m);
// Same, with a per-point scalar (e.g. intensity) averaged per voxel into `values_out`.
Points3d voxel_downsample(const Points3d& points, const std::vector<float>& values, double voxel_m,
                          std::vector<float>& values_out);

}  // namespace pl
