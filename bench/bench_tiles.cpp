// Tile figures of a real map store: Draco bytes against raw float32 (xyz + normal + intensity =
// 28 bytes a point), position error, decode and encode speed, and megabytes per km^2.
//   bench_tiles DB MAP
#include <cstdio>

#include <draco/compression/decode.h>

#include "bench_util.hpp"
#include "pl/common/tile_codec.hpp"
#include "pl/schema/store.hpp"

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: bench_tiles DB MAP\n");
    return 2;
  }
  auto store = pl::store::Store::open(argv[1], false);
  auto map = store.find_map(argv[2]);
  if (!map || !map->current) {
    std::fprintf(stderr, "no published map %s in %s\n", argv[2], argv[1]);
    return 2;
  }
  auto tiles = store.list_tiles(map->name, *map->current);
  std::vector<std::string> blobs;
  std::size_t points = 0, bytes = 0;
  for (const auto& t : tiles) {
    blobs.push_back(*store.blob(t.hash));
    points += static_cast<std::size_t>(t.points);
    bytes += blobs.back().size();
  }
  // Decode every tile several times; re-encode the decoded clouds and compare positions.
  std::vector<pl::TileCloud> clouds;
  for (const auto& b : blobs) clouds.push_back(pl::decode_tile(b));
  // Ours (to double ENU points, unit normals, intensity) against Draco's own decoder producing its
  // float32 attributes, alternately, so the wrapper's share shows even when the machine drifts.
  std::vector<double> decode_ms, draco_ms;  // per round over all tiles; medians are quoted
  std::size_t n_ours = 0, n_draco = 0;
  pl::bench::interleave(
      15,
      [&] {
        n_ours = 0;
        for (const auto& b : blobs) n_ours += pl::decode_tile(b).size();
      },
      [&] {
        n_draco = 0;
        for (const auto& b : blobs) {
          draco::DecoderBuffer buffer;
          buffer.Init(b.data(), b.size());
          draco::Decoder decoder;
          n_draco += decoder.DecodePointCloudFromBuffer(&buffer).value()->num_points();
        }
      },
      decode_ms, draco_ms);
  if (n_ours != points || n_draco != points)
    std::fprintf(stderr, "decoded %zu (Draco: %zu) points, the store says %zu\n", n_ours, n_draco, points);
  double t0 = pl::bench::now_ms();
  std::size_t re_bytes = 0;
  double max_err = 0;
  for (const auto& c : clouds) {
    std::string enc = pl::encode_tile(c);
    re_bytes += enc.size();
    auto d = pl::decode_tile(enc);
    // The order after decoding may differ (k-d tree): compare sorted copies.
    auto sorted = [](std::vector<Eigen::Vector3d> v) {
      std::sort(v.begin(), v.end(), [](const auto& a, const auto& b) { return std::lexicographical_compare(a.data(), a.data() + 3, b.data(), b.data() + 3); });
      return v;
    };
    auto a = sorted(c.points), b = sorted(d.points);
    for (std::size_t i = 0; i < a.size() && i < b.size(); ++i) max_err = std::max(max_err, (a[i] - b[i]).cwiseAbs().maxCoeff());
  }
  double encode_ms = pl::bench::now_ms() - t0;
  double raw = 28.0 * static_cast<double>(points);
  double km2 = static_cast<double>(tiles.size()) * map->tile_size * map->tile_size / 1e6;
  std::printf("map %s v%lld: %zu tiles, %zu points, %.2f MB of Draco tiles\n", map->name.c_str(), static_cast<long long>(*map->current),
              tiles.size(), points, bytes / 1e6);
  std::printf("  bytes: %.2f a point; raw float32 xyz+normal+intensity / Draco = %.1fx (target >= 6x)\n",
              static_cast<double>(bytes) / points, raw / static_cast<double>(bytes));
  std::printf("  re-encoding the decoded tiles: max position change %.4f m (bound 0.005 m)\n", max_err);
  std::printf("  decode %.1f M points/s (median of 15 rounds over all tiles; target >= 10; Draco's decoder alone %.1f M), encode %.1f M points/s, one thread\n",
              points / pl::median(decode_ms) / 1000.0, points / pl::median(draco_ms) / 1000.0,
              points / encode_ms / 1000.0);
  std::printf("  %.2f MB per km2 of occupied %.0f m tiles (%.3f km2) at %.2f m voxels (paper: 8 MB per 0.25 km2 = 32 MB/km2)\n",
              bytes / 1e6 / km2, map->tile_size, km2, map->voxel_size);
  return 0;
}
