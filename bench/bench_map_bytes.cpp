// Where a map's tile bytes go: the stored bytes of a map's current version, split into positions,
// normals and intensity by re-encoding each decoded tile one attribute at a time (Draco's coders
// give no per-attribute count). header: a one-point tile's bytes (Draco header, metadata, attribute
// descriptors); rest: stored bytes minus the re-encoded tile (0 when the settings are the tiles' own).
// The codec settings are those the tiles were written with; other ones show what re-encoding at them
// would give (an estimate: the tiles were quantized once already).
//   bench_map_bytes DB MAP [--max-error M] [--normal-bits N] [--intensity-bits N] [--speed S]
// Also what the tiles cost a vehicle: decoding them, and estimating the normals of tiles stored
// without (as the tile client does, pl::registration::estimate_normals within 3 x the map's voxel),
// in ms over all tiles and for the slowest tile.
// Prints one line of key=value pairs (bytes, km2 of tiles, points, ms) for bench/map_bytes.sh.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>

#include "pl/common/tile_codec.hpp"
#include "pl/registration/normals.hpp"
#include "pl/schema/store.hpp"

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: bench_map_bytes DB MAP [--max-error M] [--normal-bits N] [--intensity-bits N] [--speed S]\n");
    return 2;
  }
  pl::TileCodecConfig cfg;
  for (int i = 3; i + 1 < argc; i += 2) {
    const std::string flag = argv[i];
    const char* value = argv[i + 1];
    if (flag == "--max-error") cfg.max_error_m = std::atof(value);
    else if (flag == "--normal-bits") cfg.normal_bits = std::atoi(value);
    else if (flag == "--intensity-bits") cfg.intensity_bits = std::atoi(value);
    else if (flag == "--speed") cfg.speed = std::atoi(value);
    else {
      std::fprintf(stderr, "bench_map_bytes: unknown option %s\n", flag.c_str());
      return 2;
    }
  }
  auto store = pl::store::Store::open(argv[1], false);
  auto map = store.find_map(argv[2]);
  if (!map || !map->current) {
    std::fprintf(stderr, "no published map %s in %s\n", argv[2], argv[1]);
    return 2;
  }
  const auto tiles = store.list_tiles(map->name, *map->current);
  std::size_t points = 0, stored = 0, header = 0, pos = 0, with_normals = 0, all = 0;
  double decode_ms = 0, normals_ms = 0, decode_max = 0, normals_max = 0;
  using Clock = std::chrono::steady_clock;
  const auto ms_since = [](Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); };
  for (const auto& t : tiles) {
    const std::string blob = *store.blob(t.hash);
    stored += blob.size();
    auto t0 = Clock::now();
    pl::TileCloud c = pl::decode_tile(blob);
    const double d = ms_since(t0);
    decode_ms += d, decode_max = std::max(decode_max, d);
    if (c.normals.empty()) {
      t0 = Clock::now();
      const auto normals = pl::registration::estimate_normals(c.points, pl::registration::map_normal_radius(map->voxel_size > 0 ? map->voxel_size : 0.2));
      const double n = ms_since(t0);
      normals_ms += n, normals_max = std::max(normals_max, n);
    }
    points += c.size();
    pl::TileCloud one;
    one.points.assign(c.points.begin(), c.points.begin() + (c.size() ? 1 : 0));
    if (!c.normals.empty()) one.normals.assign(c.normals.begin(), c.normals.begin() + 1);
    if (!c.intensity.empty()) one.intensity.assign(c.intensity.begin(), c.intensity.begin() + 1);
    header += pl::encode_tile(one, cfg).size();
    all += pl::encode_tile(c, cfg).size();
    c.intensity.clear();
    with_normals += pl::encode_tile(c, cfg).size();
    c.normals.clear();
    pos += pl::encode_tile(c, cfg).size();
  }
  const double km2 = static_cast<double>(tiles.size()) * map->tile_size * map->tile_size / 1e6;
  std::printf("tiles=%zu points=%zu km2=%.4f stored=%zu header=%zu positions=%zu normals=%zu intensity=%zu rest=%lld "
              "decode_ms=%.1f decode_max_ms=%.2f normals_ms=%.1f normals_max_ms=%.2f\n",
              tiles.size(), points, km2, stored, header, pos - header, with_normals - pos, all - with_normals,
              static_cast<long long>(stored) - static_cast<long long>(all), decode_ms, decode_max, normals_ms, normals_max);
  return 0;
}
