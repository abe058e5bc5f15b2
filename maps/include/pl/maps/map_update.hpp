// A map kept fresh by its fleet: the change candidates of the change reports
// (pl/maps/change_detect.hpp) become a staged version in which only the candidate tiles are rebuilt
// (their old points minus those in the voxels agreed removed, plus the agreed added structure the
// vehicles sampled) and every other tile keeps its stored bytes and hash. pl-map update runs it; the
// server's admin call runs the same.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "pl/common/tile_codec.hpp"
#include "pl/maps/change_detect.hpp"
#include "pl/schema/store.hpp"

namespace pl::maps {

struct MapUpdateConfig {
  ChangeRule rule;
  std::string note;            // of the new version; default: "update of vN from K change reports"
  std::string who = "pl-map";  // in the store's upload log
  TileCodecConfig codec;
  double normal_radius_m = 0;  // for the added points; 0: 3 x the map's voxel, as pl-map tile
  void validate() const;       // throws pl::Error naming the setting
};

// What the update did to one candidate tile.
struct TileUpdate {
  TileKey key;
  std::size_t before = 0, removed = 0, added = 0, after = 0;  // points
  std::size_t removed_voxels = 0, added_voxels = 0;           // agreed evidence voxels
  std::vector<Pass> passes;                                   // that judged it
  bool deleted = false;                                       // nothing left: the tile is gone
  // "-12 points in 3 voxels passed through, +40 points in 9 voxels added; 2 of 3 passes: v1/d1 v2/d2 v3/d3"
  std::string reason() const;
};

struct MapUpdateResult {
  std::int64_t parent = 0;                     // the version the reports were against (the current one)
  std::optional<store::VersionInfo> version;   // the staged version; empty when no tile is a candidate
  ChangeSummary summary;
  std::vector<TileUpdate> tiles;               // the rebuilt tiles, in key order
  std::size_t unchanged = 0;                   // tiles that keep their bytes
};

// The change reports the store holds against a version of the map (POST /v1/maps/{map}/reports
// stored them), parsed. Throws pl::Error for a report that no longer parses (damage: the service
// parsed each before storing it).
std::vector<schema::ChangeReport> stored_reports(const store::Store& store, const std::string& map, std::int64_t version);

// Stages the update of map `map`'s current version from `reports` (those against other versions
// are not counted). In one transaction: the version, its rebuilt tiles, and an upload-log entry
// "update" whose detail holds a line "TX TY: reason" per tile (pl-map diff prints them). Stages
// nothing when no tile is a candidate. Throws pl::Error for an unknown map, a map with no current
// version, or reports whose tile grid is not the map's.
MapUpdateResult update_map(store::Store& store, const std::string& map, const std::vector<schema::ChangeReport>& reports,
                           const MapUpdateConfig& cfg = {});

// The reasons an update logged for the tiles of `version` (empty when it was not made by an update):
// per tile, its reason line.
std::vector<std::pair<TileKey, std::string>> update_reasons(const store::Store& store, const std::string& map, std::int64_t version);

}  // namespace pl::maps
