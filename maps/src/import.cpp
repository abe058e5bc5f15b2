#include "pl/maps/import.hpp"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <system_error>
#include <vector>

#include "pl/common/error.hpp"
#include "pl/common/output_path.hpp"
#include "pl/common/tile_key.hpp"
#include "pl/common/voxel.hpp"
#include "pl/maps/map_builder.hpp"
#include "pl/registration/normals.hpp"
#include "pl/registration/place_index.hpp"

namespace pl::maps {

namespace {

namespace fs = std::filesystem;

struct EncodedTile {
  TileKey key;
  std::string bytes;
  std::int64_t points = 0;
  Eigen::Vector3d lo, hi;
};

// The file at `db` as it was before the import: missing, empty (SQLite takes a 0-byte file for a new
// database) or a store.
enum class DbFile { Missing, Empty, Store };

DbFile db_file(const std::string& db) {
  if (store::is_postgres_url(db)) return DbFile::Store;  // a database exists before it is named; an empty one is migrated at open
  std::error_code ec;
  if (!fs::exists(db, ec)) return DbFile::Missing;
  return fs::is_regular_file(db, ec) && fs::file_size(db, ec) == 0 ? DbFile::Empty : DbFile::Store;
}

// Puts the file back as it was when the import created the store in it: removed, or emptied.
void undo_new_store(const std::string& db, DbFile before) {
  std::error_code ec;
  for (const char* side : {"-wal", "-shm", "-journal"}) fs::remove(db + side, ec);
  if (before == DbFile::Missing)
    fs::remove(db, ec);
  else
    fs::resize_file(db, 0, ec);
}

}  // namespace

void check_import_config(const ImportConfig& cfg) {
  if (!(cfg.voxel_m > 0) || !(cfg.tile_size_m >= 1.0)) throw Error("--voxel must be positive and --tile-size at least 1 m");
  if (!(cfg.normal_radius_m >= 0) || !std::isfinite(cfg.normal_radius_m))
    throw Error("--normal-radius takes metres above 0 (or leave it out: 3 x --voxel)");
  if (!(cfg.codec.max_error_m > 0 && cfg.codec.max_error_m <= 0.1)) throw Error("--max-error takes metres in (0, 0.1]");
  if (cfg.normal_radius_m > 0 && cfg.codec.normal_bits == 0)
    throw Error("--normal-radius sets the normals stored in the tiles, and none are stored: give --normal-bits 6 too, or leave "
                "--normal-radius out (the vehicle estimates the normals within 3 x the map's voxel)");
  if (cfg.codec.normal_bits == 1) throw Error("--normal-bits takes 0 (no normals) or 2 to 30");
}

ImportResult import_cloud(const std::string& db, const std::string& name, const Cloud& cloud, const std::string& source,
                          const ImportConfig& cfg, const std::function<void(std::size_t, std::size_t)>& progress) {
  check_import_config(cfg);
  const std::optional<GeoPoint> origin = cfg.origin ? cfg.origin : cloud.origin;
  const DbFile before = db_file(db);
  std::optional<store::Store> store;
  std::optional<store::MapInfo> existing;
  if (before == DbFile::Store) {
    store.emplace(store::Store::open(db, store::is_postgres_url(db)));
    existing = store->find_map(name);
  } else {
    check_output_file(db);  // the store is created at the end, when everything else is done
  }
  if (!origin && !existing)
    throw Error(source + ": no origin recorded: give --origin LAT,LON,ALT (the geodetic origin of the cloud's ENU frame)");
  if (existing) {
    if (std::abs(existing->tile_size - cfg.tile_size_m) > 1e-9 || std::abs(existing->voxel_size - cfg.voxel_m) > 1e-9)
      throw Error("map " + name + " has " + std::to_string(existing->tile_size) + " m tiles and " +
                  std::to_string(existing->voxel_size) + " m voxels: use --tile-size " + std::to_string(existing->tile_size) +
                  " --voxel " + std::to_string(existing->voxel_size) + ", or another --map");
    if (origin && (std::abs(origin->lat_deg - existing->origin.lat_deg) > 1e-9 ||
                   std::abs(origin->lon_deg - existing->origin.lon_deg) > 1e-9))
      throw Error(source + ": its origin differs from map " + name + "'s: the cloud is in another frame (use another --map)");
  }
  if (cloud.points.empty()) throw Error(source + ": no points");

  ImportResult r;
  // The places are read and checked before the store is touched.
  std::string places;
  if (!cfg.places.empty()) {
    std::ifstream f(cfg.places, std::ios::binary);
    if (!f) throw Error(cfg.places + ": cannot read the places (pl-map build writes them beside its map; give --places none to store none)");
    places.assign(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
    r.places = registration::PlaceIndex::decode(places, cfg.places).places().size();
    if (r.places == 0) places.clear();
  }
  std::vector<float> intensity;
  const Points3d pts = voxel_downsample(cloud.points, cloud.intensity, cfg.voxel_m, intensity);
  r.points = pts.size();
  const double radius = cfg.normal_radius_m > 0 ? cfg.normal_radius_m : registration::map_normal_radius(cfg.voxel_m);
  const auto normals = cfg.codec.normal_bits > 0 ? registration::estimate_normals(pts, radius) : std::vector<Eigen::Vector3f>{};
  const auto tiles = cut_into_tiles(pts, normals, intensity, TileGrid(cfg.tile_size_m));
  std::vector<EncodedTile> encoded;
  for (const auto& [key, tile] : tiles) {
    EncodedTile e{key, encode_tile(tile, cfg.codec), static_cast<std::int64_t>(tile.size()), tile.points.front(), tile.points.front()};
    for (const auto& p : tile.points) e.lo = e.lo.cwiseMin(p), e.hi = e.hi.cwiseMax(p);
    r.bytes += static_cast<double>(e.bytes.size());
    encoded.push_back(std::move(e));
    if (progress) progress(encoded.size(), tiles.size());
  }
  r.tiles = encoded.size();

  // Everything in one transaction: an interrupted import leaves no version behind; a store this
  // import created is removed again when the write fails.
  r.created_store = !store;
  try {
    if (!store) store.emplace(store::Store::open(db, true));
    store::Store::Transaction tx(*store);
    if (!existing) store->create_map(name, *origin, cfg.tile_size_m, cfg.voxel_m);
    r.created_map = !existing;
    const std::string note = cfg.note.empty() ? "tiled from " + source : cfg.note;
    r.version = store->create_version(name, std::nullopt, note);
    std::map<TileKey, std::string> parent_hash;  // the new version starts as a copy of its parent
    for (const auto& t : store->list_tiles(name, r.version.number)) parent_hash[t.key] = t.hash;
    for (const EncodedTile& e : encoded) {
      const auto rec = store->put_tile(name, r.version.number, e.key, e.bytes, e.points, e.lo.x(), e.lo.y(), e.lo.z(), e.hi.x(),
                                       e.hi.y(), e.hi.z());
      const auto it = parent_hash.find(e.key);
      if (it != parent_hash.end() && it->second == rec.hash)
        ++r.unchanged;
      else
        ++r.changed;
    }
    for (const auto& [key, hash] : parent_hash)
      if (!tiles.count(key)) r.removed += store->delete_tile(name, r.version.number, key);
    if (!places.empty()) store->put_places(name, r.version.number, places);
    else store->delete_places(name, r.version.number);
    store->log_upload(name, r.version.number, "tile", note, cfg.who);
    tx.commit();
  } catch (...) {
    if (r.created_store) {
      store.reset();  // closes the connection before its files go
      undo_new_store(db, before);
    }
    throw;
  }
  return r;
}

std::string places_path(const std::string& cloud) { return beside(cloud, ".places"); }

}  // namespace pl::maps
