// Point-cloud files: PCD (the Point Cloud Library's format; ascii or binary), PLY (ascii or binary
// little-endian) and KITTI .bin, read into double-precision points with an optional intensity.
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "pl/common/geo.hpp"
#include "pl/common/voxel.hpp"

namespace pl {

struct Cloud {
  Points3d points;
  std::vector<float> intensity;  // empty when the file has none
  std::optional<GeoPoint> origin;  // the geodetic origin of the cloud's ENU frame, when the file records it
  std::size_t size() const { return points.size(); }
};

// By extension: .pcd, .ply or .bin. Throws pl::Error naming the file and what is wrong (missing x/y/z
// fields, an unsupported encoding, a truncated body, ...).
Cloud read_cloud(const std::string& path);
Cloud read_pcd(const std::string& path);
Cloud read_ply(const std::string& path);

// The same readers on bytes already in memory (a bag record, a fuzzer's input); `name` stands for the
// file in messages and, for parse_cloud, gives the format by its extension. Every count and length
// in a header is checked against the bytes present before anything is allocated, so a damaged or
// hostile file is refused with a pl::Error, never read out of bounds. A cloud that comes back has
// finite points, and finite intensities, one per point, when it has any.
Cloud parse_cloud(std::string_view bytes, const std::string& name);
Cloud parse_pcd(std::string_view bytes, const std::string& name);
Cloud parse_ply(std::string_view bytes, const std::string& name);

// Binary PCD with fields x y z intensity (float32). Coordinates must be in a local frame (float32
// keeps ~0.1 mm within a few kilometres): throws pl::Error for coordinates beyond 100 km. With an
// origin, a header comment "# origin LAT LON ALT" records it (read_pcd reads it back).
void write_pcd(const std::string& path, const Points3d& points, const std::vector<float>& intensity,
               const std::optional<GeoPoint>& origin = std::nullopt);

}  // namespace pl
