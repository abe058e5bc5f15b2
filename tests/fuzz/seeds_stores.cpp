// Seeds of the store and tile_cache fuzz targets: small real files written by the project's own
// code (Store, TileCache), with 512-byte pages so that the fuzzer's mutations land on every kind
// of page (schema, tables, indexes, the R*Tree, overflow chains of blobs) rather than on free space.
#include <sqlite3.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <optional>
#include <random>
#include <string>

#include "pl/client/tile_cache.hpp"
#include "pl/common/error.hpp"
#include "pl/common/tile_codec.hpp"
#include "pl/schema/store.hpp"
#include "seeds.hpp"

namespace fs = std::filesystem;
using pl::store::Store;

namespace {

// A folder for the files being made, removed when done.
class Scratch {
 public:
  Scratch() {
    std::string tmpl = (fs::temp_directory_path() / "pl-seeds-XXXXXX").string();
    if (!mkdtemp(tmpl.data())) throw pl::Error("make_fuzz_seeds: cannot make a temporary folder");
    dir_ = tmpl;
  }
  ~Scratch() {
    std::error_code ec;
    fs::remove_all(dir_, ec);
  }
  std::string operator/(const std::string& name) const { return dir_ + "/" + name; }

 private:
  std::string dir_;
};

void sql(const std::string& path, const std::string& text) {
  sqlite3* db = nullptr;
  int rc = sqlite3_open(path.c_str(), &db);
  char* err = nullptr;
  if (rc == SQLITE_OK) rc = sqlite3_exec(db, text.c_str(), nullptr, nullptr, &err);
  std::string msg = err ? err : (db ? sqlite3_errmsg(db) : "out of memory");
  sqlite3_free(err);
  sqlite3_close(db);
  if (rc != SQLITE_OK) throw pl::Error(path + ": " + text + ": " + msg);
}

// An empty database file with 512-byte pages, for Store::open / TileCache to fill (the page size
// is only set while a database is empty).
void empty_small_pages(const std::string& path) { sql(path, "PRAGMA page_size = 512; VACUUM;"); }

// Rewrites the file compactly, in the journal mode given (the product's files are WAL).
std::string compact(const std::string& path, const char* journal_mode) {
  sql(path, std::string("PRAGMA journal_mode = DELETE; VACUUM; PRAGMA journal_mode = ") + journal_mode + ";");
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

std::string copy_to(const std::string& bytes, const std::string& path) {
  std::ofstream(path, std::ios::binary) << bytes;
  return path;
}

// A tile of ground and a wall in cell (tx, ty) of a 20 m grid.
pl::TileCloud tile(int tx, int ty, int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  pl::TileCloud c;
  for (int i = 0; i < n; ++i) {
    bool wall = i % 4 == 0;
    c.points.emplace_back(20.0 * tx + (wall ? 19.0 : 20 * u(rng)), 20.0 * ty + 20 * u(rng), wall ? 3 * u(rng) : 0.05 * u(rng));
    c.normals.push_back(wall ? Eigen::Vector3f(-1, 0, 0) : Eigen::Vector3f(0, 0, 1));
    c.intensity.push_back(static_cast<float>(u(rng)));
  }
  return c;
}

void put(Store& s, std::int64_t version, int tx, int ty, unsigned seed) {
  pl::TileCodecConfig fast;
  fast.speed = 10;
  const pl::TileCloud c = tile(tx, ty, 12, seed);
  Eigen::Vector3d lo = c.points[0], hi = lo;
  for (const auto& p : c.points) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
  s.put_tile("town", version, {tx, ty}, pl::encode_tile(c, fast), static_cast<std::int64_t>(c.size()), lo.x(), lo.y(), lo.z(),
             hi.x(), hi.y(), hi.z());
}

// One map, version 1 published with three tiles, version 2 staged (one tile changed, one removed),
// three tokens, two upload log entries.
void fill_store(const std::string& path) {
  Store s = Store::open(path, true);
  s.create_map("town", {49.0, 8.4, 110.0}, 20.0, 0.2);
  s.create_version("town", std::nullopt, "first drive");
  put(s, 1, 0, 0, 1);
  put(s, 1, 1, 0, 2);
  put(s, 1, -1, 2, 3);
  s.publish("town", 1);
  s.create_version("town", std::nullopt, "second drive");
  put(s, 2, 0, 0, 4);
  s.delete_tile("town", 2, {1, 0});
  s.add_token("fuzz-read", pl::store::Role::Read, "seed");
  s.add_token("fuzz-upload", pl::store::Role::Upload, "seed");
  s.add_token("fuzz-admin", pl::store::Role::Admin, "seed");
  s.log_upload("town", 1, "publish", "version 1", "seed");
  s.log_upload("town", 2, "put_tile", "0/0", "seed");
}

// fill_store's store and two more versions with places (schema version 2): version 3 published
// with places, version 4 staged from it, its copy of them replaced.
void fill_store_with_places(const std::string& path) {
  fill_store(path);
  Store s = Store::open(path, false);
  s.create_version("town", std::nullopt, "third drive");
  s.put_places("town", 3, std::string("places of version 3\0with a NUL", 30));
  s.publish("town", 3);
  s.create_version("town", std::nullopt, "fourth drive");
  s.put_places("town", 4, "places of version 4");
}

// The seed opens and reads as a store (a check of this maker, on a copy: opening may switch it to WAL).
void check_store(const std::string& bytes, const std::string& path, std::size_t maps) {
  Store s = Store::open(copy_to(bytes, path), false);
  if (s.list_maps().size() != maps || !s.integrity_ok()) throw pl::Error(path + ": the seed store does not read back");
  for (const auto& m : s.list_maps())
    for (const auto& v : s.list_versions(m.name))
      for (const auto& t : s.list_tiles(m.name, v.number))
        if (!s.blob(t.hash)) throw pl::Error(path + ": the seed store lost a blob");
}

std::size_t versions_with_places(const std::string& bytes, const std::string& path) {
  Store s = Store::open(copy_to(bytes, path), false);
  std::size_t n = 0;
  for (const auto& v : s.list_versions("town")) n += s.places("town", v.number).has_value();
  return n;
}

void store_seeds(const pl::fuzz::PutSeed& put_seed) {
  Scratch dir;
  const std::string full = dir / "full.sqlite";
  empty_small_pages(full);
  fill_store(full);
  const std::string wal = compact(full, "WAL");
  check_store(wal, dir / "check-wal.sqlite", 1);
  put_seed("two-versions-wal", wal);
  const std::string rollback = compact(full, "DELETE");
  check_store(rollback, dir / "check-delete.sqlite", 1);
  put_seed("two-versions-rollback-journal", rollback);

  const std::string with_places = dir / "places.sqlite";
  empty_small_pages(with_places);
  fill_store_with_places(with_places);
  const std::string places_wal = compact(with_places, "WAL");
  check_store(places_wal, dir / "check-places.sqlite", 1);
  if (versions_with_places(places_wal, dir / "check-places-2.sqlite") != 2)
    throw pl::Error(with_places + ": the seed store lost its places");
  put_seed("four-versions-places-wal", places_wal);

  const std::string empty = dir / "empty.sqlite";
  empty_small_pages(empty);
  { Store s = Store::open(empty, true); }
  const std::string no_maps = compact(empty, "WAL");
  check_store(no_maps, dir / "check-empty.sqlite", 0);
  put_seed("no-maps", no_maps);
  put_seed("empty-file", "");
}

void cache_seeds(const pl::fuzz::PutSeed& put_seed) {
  Scratch dir;
  const std::string path = dir / "cache.sqlite";
  empty_small_pages(path);
  {
    pl::client::TileCache cache(path);
    pl::TileCodecConfig fast;
    fast.speed = 10;
    const std::string tile00 = pl::encode_tile(tile(0, 0, 12, 1), fast);
    const std::string known = "cached tile 0/0 of town v1";  // the blob fuzz_tile_cache.cpp asks for by hash
    const std::string h00 = pl::store::content_hash(tile00), hk = pl::store::content_hash(known);
    cache.put_blob(h00, tile00);
    cache.put_blob(hk, known);
    cache.put_manifest({"town", 1, 20.0, 0.2, pl::GeoPoint{49.0, 8.4, 110.0}});
    cache.put_manifest({"town", 2, 20.0, 0.2, pl::GeoPoint{49.0, 8.4, 110.0}});
    cache.put_manifest({"depot", 7, 25.0, 0.25, pl::GeoPoint{-33.9, 151.2, 3.0}});
    cache.put_tiles("town", 1, {{{0, 0}, h00, 12}, {{1, 0}, hk, 3}, {{-1, 3}, "", 0}});
    cache.put_tiles("town", 2, {{{0, 0}, h00, 12}});
  }
  const std::string wal = compact(path, "WAL");
  {
    pl::client::TileCache check(copy_to(wal, dir / "check.sqlite"));
    if (check.blob_count() != 2 || check.tiles("town", 1).size() != 3 || !check.last_used("town"))
      throw pl::Error(path + ": the seed cache does not read back");
  }
  put_seed("cache-wal", wal);
  put_seed("cache-rollback-journal", compact(path, "DELETE"));
  put_seed("empty-file", "");
}

const bool registered_store = pl::fuzz::register_seeds("store", store_seeds);
const bool registered_cache = pl::fuzz::register_seeds("tile_cache", cache_seeds);

}  // namespace
