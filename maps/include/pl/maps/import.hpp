// Importing a cloud into the map store as a new staged version: voxelized, cut into tiles, each
// Draco-encoded (positions only by default: vehicles estimate the normals, only the viewer reads
// intensity); the map is created on first use, and tiles whose bytes did not change share their
// stored blobs. pl-map tile runs it.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>

#include "pl/common/cloud_io.hpp"
#include "pl/common/geo.hpp"
#include "pl/common/tile_codec.hpp"
#include "pl/schema/store.hpp"

namespace pl::maps {

struct ImportConfig {
  double voxel_m = 0.2;
  double tile_size_m = 20.0;
  double normal_radius_m = 0.0;    // of the stored normals (codec.normal_bits > 0); 0: 3 x voxel_m
  TileCodecConfig codec{0.02, 0, 0, 5};  // positions to 2 cm; no normals, no intensity
  std::optional<GeoPoint> origin;  // of the cloud's ENU frame, when the cloud does not record it
  std::string note;                // of the version; default "tiled from SOURCE"
  std::string who = "pl-map";      // in the store's upload log
  // The places (for relocalization) stored with the version: this file, as pl-map build writes it
  // beside its map; empty: none (the version keeps no places, a parent's would describe other tiles).
  std::string places;
};

// Where pl-map build writes the places of a map it writes to `cloud`: the same name with the
// extension .places ("drive.pcd" -> "drive.places").
std::string places_path(const std::string& cloud);

struct ImportResult {
  store::VersionInfo version;  // the new staged version
  bool created_store = false, created_map = false;
  std::size_t tiles = 0, changed = 0, unchanged = 0, removed = 0;  // against the parent version
  std::size_t points = 0;                                           // after voxelizing
  double bytes = 0;                                                 // Draco bytes of all tiles
  std::size_t places = 0;                                           // stored with the version
};

// Throws pl::Error naming the fix for a bad config (voxel, tile size, normal radius, max error).
void check_import_config(const ImportConfig& cfg);

// Imports `cloud` (read from `source`, which names it in messages) into map `map` of the store at
// `db` (created when missing). Everything that can fail is checked or done before the store is
// touched, and the write is one transaction: a failed import leaves no new store file, map or
// version behind. progress(done, total) counts the tiles encoded.
ImportResult import_cloud(const std::string& db, const std::string& map, const Cloud& cloud, const std::string& source,
                          const ImportConfig& cfg, const std::function<void(std::size_t, std::size_t)>& progress = {});

}  // namespace pl::maps
