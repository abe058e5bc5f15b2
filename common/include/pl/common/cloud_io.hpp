// Point-cloud files: PCD (the Point Cloud Library's format; ascii, binary or binary_compressed, as PCL
// and Open3D write them), PLY (ascii or binary little-endian) and KITTI .bin, read into
// double-precision points with an optional intensity.
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
  std::optional<GeoPoint> origin;  // the geodetic origin of the cloud's ENU frame, when the file records it (see read_pcd)
  std::size_t size() const { return points.size(); }
};

// By extension: .pcd, .ply or .bin. Throws pl::Error naming the file and what is wrong (missing x/y/z
// fields, an unsupported encoding, a truncated body, ...).
Cloud read_cloud(const std::string& path);
// A PCD's points, and its geodetic origin from the origin file beside it, PATH + ".origin.json"
// ("map.pcd.origin.json", as write_pcd writes it), or else from the header comment
// "# origin LAT LON ALT". When both are there they must agree to 1e-9 degrees and 1 mm, or a
// pl::Error names both files: a cloud saved again next to another map's origin file must not pass
// for that map. A missing origin file is no error; a malformed one is.
Cloud read_pcd(const std::string& path);
Cloud read_ply(const std::string& path);

// The same readers on bytes already in memory (a bag record, a fuzzer's input); `name` stands for the
// file in messages and, for parse_cloud, gives the format by its extension. Every count and length
// in a header is checked against the bytes present before anything is allocated, so a damaged or
// hostile file is refused with a pl::Error, never read out of bounds. A cloud that comes back has
// finite points, and finite intensities, one per point, when it has any.
//
// PCD points without a finite position (organised clouds keep NaN where the beam saw nothing) are
// left out, with their intensity, in every encoding; a kept point's intensity must be finite. PLY
// and KITTI .bin refuse a non-finite coordinate. A PCD whose POINTS is not WIDTH x HEIGHT is refused.
// binary_compressed data may unpack to at most 88 times its size (LZF's limit), so a few bytes
// cannot make the reader allocate gigabytes.
Cloud parse_cloud(std::string_view bytes, const std::string& name);
// Bytes have no file beside them: the origin comes from the header comment only.
Cloud parse_pcd(std::string_view bytes, const std::string& name);
Cloud parse_ply(std::string_view bytes, const std::string& name);

// Binary PCD with fields x y z intensity (float32). Coordinates must be in a local frame (float32
// keeps ~0.1 mm within a few kilometres): throws pl::Error for coordinates beyond 100 km. With an
// origin (lat in [-90, 90], lon in [-180, 180]), it is recorded twice: in the header comment
// "# origin LAT LON ALT", and in PATH + ".origin.json", {"lat": DEG, "lon": DEG, "alt": M,
// "frame": "ENU"}, which survives PCL and Open3D saving the cloud again (they drop comments). Without
// an origin, an origin file left at PATH + ".origin.json" by an earlier cloud is removed.
void write_pcd(const std::string& path, const Points3d& points, const std::vector<float>& intensity,
               const std::optional<GeoPoint>& origin = std::nullopt);

}  // namespace pl
