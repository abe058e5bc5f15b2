// A change report: what one vehicle saw of a map version's age over one drive, per tile and map
// voxel, sent to the map service (POST /v1/maps/{map}/reports) to be aggregated over many drives.
// The vehicle writes it (pl/client/change_evidence.hpp), the service parses it; both agree here.
//
// JSON, compact: {"format": "pl-change-report", "format_version": 1, "map": NAME, "version": N,
//   "vehicle": ID, "drive": ID, "start": UNIX_S, "end": UNIX_S, "voxel_m": V, "tile_m": S,
//   "tiles": [{"tx": I, "ty": I, "scans": N, "cells": [x, y, z, added, free, seen, passed, ...],
//              "points": [x, y, z, ...]}]}
// A cell's x, y, z index the voxel_m grid of the map frame (floor(coordinate / voxel_m)). A tile's
// "points" (optional) sample the added structure: one point per small voxel the vehicle found added
// in two scans or more (the mean of its returns), in centimetres of the map frame, each in a voxel
// of the tile's cells with `added` > 0; the map service builds the new structure of a tile from them.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "pl/common/tile_key.hpp"

namespace pl::schema {

// One voxel's evidence, each count a number of scans.
struct ChangeCell {
  std::int32_t x = 0, y = 0, z = 0;
  std::uint32_t added = 0;   // a return here had no map surface within delta
  std::uint32_t free = 0;    // a ray passed through here (the voxel of an added return) on its way farther
  std::uint32_t seen = 0;    // a return lay on a map surface here (with `passed`: here or in a voxel next to it)
  std::uint32_t passed = 0;  // a ray passed through a map point here on its way farther
  bool operator==(const ChangeCell& o) const {
    return x == o.x && y == o.y && z == o.z && added == o.added && free == o.free && seen == o.seen && passed == o.passed;
  }
};

struct TileChangeEvidence {
  TileKey key;
  std::uint32_t scans = 0;        // scans whose returns fell in the tile
  std::vector<ChangeCell> cells;  // sorted by (x, y, z), each voxel once
  // The added structure's sample: centimetres of the map frame, sorted, each once, each in a cell
  // with added > 0.
  std::vector<std::array<std::int32_t, 3>> points;
};

struct ChangeReport {
  std::string map;
  std::int64_t version = 0;  // the map version the vehicle localized against
  std::string vehicle;       // who drove (a vehicle's id: drives of one vehicle are not independent)
  std::string drive;         // this drive's id: a report sent again is the same report (idempotent)
  double start = 0, end = 0;  // the drive's span, seconds since 1970
  double voxel_m = 0.5;
  double tile_m = 0;
  std::vector<TileChangeEvidence> tiles;  // in key order, each tile once
};

// The bounds a parser holds a report to (what a vehicle's report may be at most).
struct ChangeReportLimits {
  std::size_t max_bytes = 32u << 20;
  std::size_t max_tiles = 20000;
  std::size_t max_cells = 4u << 20;  // over all tiles
  std::size_t max_points = 4u << 20;  // of the added sample, over all tiles
};

std::string change_report_json(const ChangeReport& report);

// An id of a vehicle or a drive: 1 to 128 of [A-Za-z0-9_.:-] (reports, vehicle positions, file names).
bool valid_id(std::string_view s);

// The voxel (of `voxel_m`) a sample point in centimetres lies in.
std::array<std::int32_t, 3> voxel_of_cm(const std::array<std::int32_t, 3>& p, double voxel_m);

// Parses and checks a report (names, ids, finite times, positive grid sizes, tiles in key order
// without repeats, cells inside their tile and in order, sample points in order and in added cells). Throws pl::Error naming what is wrong.
ChangeReport parse_change_report(std::string_view text, const ChangeReportLimits& limits = {});
// The report files, parsed in order (within the default limits). Throws pl::Error naming the file
// that cannot be read or does not parse: "PATH: change report: ...".
std::vector<ChangeReport> read_change_reports(const std::vector<std::string>& paths);

}  // namespace pl::schema
