// Which tiles of a map changed, from the change reports of many drives (pl/schema/change_report.hpp):
// a voxel changed in a pass when that drive's own evidence says so, and a tile is a change
// candidate when independent passes agree on enough of its voxels. One truck parked for a minute
// is one pass; traffic differs from pass to pass; a change stays.
//
// The rule, per tile, over the last `window` passes that saw it (`min_scans` scans of it or more):
//  - a voxel is added in a pass when `added_min` of its scans or more found a return there with no
//    map surface near, and at least `added_free_ratio` times as many as saw through it later
//    (a moving thing is seen through once it has gone), or `added_stays` or more found it whatever
//    crossed it: a thing moving through fills a voxel for a few of a pass's scans, and rays cross
//    a voxel that new leaves fill only in part above or beside them;
//  - a voxel is removed in a pass when `removed_min` of its scans or more passed through its map
//    points, and at least `removed_seen_ratio` times as many as confirmed the map there or next to it
//    (glass, leaves and edges are passed and confirmed alike);
//  - a voxel is agreed when `min_drives` passes or more found it changed (within `tolerance_voxels`);
//  - the tile is a candidate when one pass's changed voxels hold `min_cells` agreed ones or more.
// Passes are independent drives: reports of one vehicle that start within `independent_s` of each
// other count as one pass (the later one), and only reports against the version asked for count.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "pl/common/tile_key.hpp"
#include "pl/schema/change_report.hpp"

namespace pl::maps {

struct ChangeRule {
  int min_drives = 2;
  int window = 3;
  double independent_s = 3600.0;
  std::uint32_t min_scans = 3;
  std::uint32_t added_min = 3;
  double added_free_ratio = 2.0;
  std::uint32_t added_stays = 12;  // with evidence one scan per 2.5 m of travel: 30 m of a pass
  std::uint32_t removed_min = 2;
  double removed_seen_ratio = 5.0;
  int tolerance_voxels = 1;
  std::size_t min_cells = 4;
  // Throws pl::Error naming the setting and its range.
  void validate() const;
};

struct Pass {
  std::string vehicle, drive;
  double start = 0;
};

struct TileChange {
  TileKey key;
  std::vector<Pass> passes;                 // the passes judged, oldest first (at most `window`)
  std::size_t agreed = 0;                   // agreed changed voxels (the most any one pass holds)
  bool candidate = false;
  std::vector<schema::ChangeCell> added, removed;  // the agreed voxels, in (x, y, z) order; counts summed over the passes
  // The added structure: the judged passes' sample points (centimetres, map frame) in their agreed
  // added voxels, sorted, each once.
  std::vector<std::array<std::int32_t, 3>> points;
};

struct ChangeSummary {
  std::int64_t version = 0;
  double voxel_m = 0, tile_m = 0;
  std::size_t reports = 0, used = 0;  // reports given, and those against `version` that counted as passes
  std::vector<TileChange> tiles;      // every tile some pass saw, in key order
};

// Throws pl::Error when reports against `version` disagree on the map, voxel or tile size.
ChangeSummary detect_changes(const std::vector<schema::ChangeReport>& reports, std::int64_t version, const ChangeRule& rule = {});

// The summary as CSV, a row per tile: tx,ty,passes,agreed,added,removed,candidate,drives.
std::string change_summary_csv(const ChangeSummary& summary);

}  // namespace pl::maps
