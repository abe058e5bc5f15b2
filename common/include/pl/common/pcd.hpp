// PCD files (the Point Cloud Library's format): x y z intensity as float32.
#pragma once

#include <string>
#include <vector>

#include "pl/common/voxel.hpp"

namespace pl {

// Binary PCD with fields x y z intensity (float32). Coordinates must be in a local frame (float32
// keeps ~0.1 mm within a few kilometres): throws pl::Error for coordinates beyond 100 km.
void write_pcd(const std::string& path, const Points3d& points, const std::vector<float>& intensity);

}  // namespace pl
