// Draco encoding of one map tile: positions, and normals and intensity when asked for. Positions
// are stored relative to the tile's own box and quantized explicitly on it, so the error bound holds
// for any map; points are sorted first, so equal tiles give equal bytes.
#pragma once

#include <Eigen/Core>
#include <string>
#include <string_view>
#include <vector>

namespace pl {

// A tile's points in the map's ENU frame (double: maps may be far from their origin's axes).
struct TileCloud {
  std::vector<Eigen::Vector3d> points;
  std::vector<Eigen::Vector3f> normals;  // unit length, one per point (may be empty)
  std::vector<float> intensity;          // in [0, 1], one per point (may be empty)
  std::size_t size() const { return points.size(); }
};

struct TileCodecConfig {
  double max_error_m = 0.02;  // largest position error after decoding, per axis: a tenth of a 0.2 m
                              // voxel, which ICP averages out over a scan's thousands of pairs
  int normal_bits = 6;        // octahedral quantization of the normals: ~2 deg, about what normals
                              // estimated from 0.2 m voxels are good to; 0: not stored
  int intensity_bits = 4;     // intensity only colours the viewer (the localizer never reads it); 0: not stored
  int speed = 5;              // Draco's encoding speed, 0 (best compression) .. 10 (fastest)
};

// Encodes the cloud's positions, and its normals and intensity unless their bits are 0. Throws
// pl::Error for mismatched attribute counts or non-finite values.
std::string encode_tile(const TileCloud& cloud, const TileCodecConfig& cfg = {});

// Decodes bytes written by encode_tile (or any Draco point cloud with a position attribute; the
// origin is 0 without "pl.origin" metadata, intensity is a GENERIC attribute named "intensity").
// Points may come back in another order. Throws pl::Error("not a valid Draco point cloud: ...")
// when the bytes are not one, and also for Draco meshes, for bitstreams older than 2.2 (2.3 for the
// k-d tree coder), and for streams whose declared counts would make Draco hold more than
// min(256 MiB, max(8 MiB, 64 x their size)) while decoding (memory bombs; encode_tile never writes one).
TileCloud decode_tile(std::string_view bytes);

// Number of points and attributes. Draco cannot check a payload without decoding it, so this
// decodes (about as fast as decode_tile) and accepts exactly what decode_tile accepts: the upload check.
struct TileSummary {
  std::size_t points = 0;
  bool has_normals = false, has_intensity = false;
};
TileSummary inspect_tile(std::string_view bytes);  // throws like decode_tile

}  // namespace pl
