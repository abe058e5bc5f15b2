// The drives a map was built from, written beside it (MAP.drives.json) by pl-map build: each drive's
// dataset, scan times and pose per scan in the map's frame, and the merge settings. pl-map build
// --base-map MAP reads it to add drives with these held where they are: merged again first, at the
// same poses with the same settings, the voxels the new drives do not reach keep their points to the
// bit, and so do the tiles cut from them.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "pl/common/geo.hpp"
#include "pl/common/pose.hpp"
#include "pl/maps/map_builder.hpp"

namespace pl::maps {

struct RecordedDrive {
  std::string dataset;  // its path when the map was built (absolute)
  Trajectory poses;     // one per scan, map frame, with the scan times
  bool deskew = false;  // the merge corrected its sweeps (PlacedDrive::deskew)
  double sweep_s = 0.1;
};

struct DriveRecord {
  std::vector<RecordedDrive> drives;
  std::optional<GeoPoint> origin;  // the map frame's geodetic origin, as in the map's PCD
  // The merge settings a later build must repeat: voxel, scans taken, crops (its places settings are
  // the defaults'; deskew is per drive).
  MapBuildConfig merge;
};

// "town.pcd" -> "town.drives.json".
std::string drive_record_path(const std::string& map);

// JSON, written atomically (a partial file renamed). Throws pl::Error when it cannot be written.
void write_drive_record(const std::string& path, const DriveRecord& record);
std::string encode_drive_record(const DriveRecord& record);
// Throws pl::Error naming `source` and what is wrong: not JSON, another format, a drive without poses,
// a pose or time that is not finite, a merge setting out of range.
DriveRecord decode_drive_record(const std::string& bytes, const std::string& source);
// pl::Error naming the file and the fix when it is missing.
DriveRecord read_drive_record(const std::string& path);

// pl::Error naming the option and the base map's value when `merge` differs from the record's in
// what decides the merged points (voxel, first/last/every, range and field-of-view crops, beams).
void check_same_merge(const DriveRecord& record, const MapBuildConfig& merge, const std::string& source);

}  // namespace pl::maps
