// A large map for the fleet benchmarks: one published map's tiles repeated side by side until the
// copies cover the area asked for. Each copy is moved by whole blocks of tiles (the source map's
// tile box), its points decoded, moved and encoded again, so that every tile of the large map has
// bytes (and a content hash) of its own, as tiles of a real map of that size would: a store that
// kept one blob for many tiles would be smaller and faster than any real one.
//
//   bench_bigmap --from STORE --map NAME --to STORE --name BIG [--km2 25] [--threads 2] [--signing-key KEY]
//
// Writes map BIG (the source map's origin, tile and voxel size) as one version, published at the
// end (signed with the key, as pl-map publish --signing-key signs); tiles are written in one
// transaction per copy. Prints the copies, tiles, bytes and the time
// it took; a progress bar on a terminal.
#include <algorithm>
#include <atomic>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <deque>
#include <mutex>
#include <optional>
#include <thread>
#include <vector>

#include "bench_util.hpp"
#include "pl/common/cli.hpp"
#include "pl/common/error.hpp"
#include "pl/common/progress.hpp"
#include "pl/common/tile_codec.hpp"
#include "pl/schema/signed_manifest.hpp"
#include "pl/schema/store.hpp"

namespace {

struct Options {
  std::string from, map, to, name, signing_key;
  double km2 = 25;
  int threads = 2;
};

// One tile of a copy, encoded by a worker, waiting for the writer.
struct Encoded {
  pl::TileKey key;
  std::string bytes;
  std::int64_t points = 0;
  double box[6] = {};
};

int run(const Options& o) {
  auto src = pl::store::Store::open(o.from, false);
  const auto m = src.find_map(o.map);
  if (!m || !m->current) throw pl::Error(pl::store::display_name(o.from) + ": no published map named \"" + o.map + "\"");
  const auto tiles = src.list_tiles(o.map, *m->current);
  if (tiles.empty()) throw pl::Error(o.map + ": its current version has no tiles");
  int lx = tiles[0].key.tx, hx = lx, ly = tiles[0].key.ty, hy = ly;
  for (const auto& t : tiles) lx = std::min(lx, t.key.tx), hx = std::max(hx, t.key.tx), ly = std::min(ly, t.key.ty), hy = std::max(hy, t.key.ty);
  const int bw = hx - lx + 1, bh = hy - ly + 1;  // the block: the source's tile box
  const double block_km2 = bw * m->tile_size * bh * m->tile_size / 1e6;
  const int side = static_cast<int>(std::ceil(std::sqrt(o.km2 / block_km2)));  // copies a side, a square of them
  const std::size_t copies = static_cast<std::size_t>(side) * side, total = copies * tiles.size();
  std::printf("source %s: %zu tiles in a %d x %d tile box (%.3f km2); %d x %d copies = %.2f km2, %zu tiles\n", o.map.c_str(),
              tiles.size(), bw, bh, block_km2, side, side, copies * block_km2, total);
  std::vector<pl::TileCloud> clouds;  // the source tiles, decoded once
  for (const auto& t : tiles) clouds.push_back(pl::decode_tile(*src.blob(t.hash)));

  auto dst = pl::store::Store::open(o.to, true);
  if (dst.find_map(o.name)) throw pl::Error(pl::store::display_name(o.to) + ": a map named \"" + o.name + "\" exists already: choose another --name");
  dst.create_map(o.name, m->origin, m->tile_size, m->voxel_size);
  const auto version = dst.create_version(o.name, std::nullopt, "bench_bigmap: " + std::to_string(copies) + " copies of " + o.map);

  // Workers encode the copies' tiles in order of copy; the writer stores each copy whole.
  std::mutex mu;
  std::condition_variable cv;
  std::deque<std::vector<Encoded>> ready;  // finished copies, in order
  std::size_t next_copy = 0, done_copies = 0;
  std::vector<std::optional<std::vector<Encoded>>> slots(copies);
  auto worker = [&] {
    for (;;) {
      std::size_t c;
      {
        std::unique_lock lock(mu);
        cv.wait(lock, [&] { return next_copy >= copies || next_copy < done_copies + 2 * static_cast<std::size_t>(o.threads) + 2; });
        if (next_copy >= copies) return;
        c = next_copy++;
      }
      const int bx = static_cast<int>(c) % side, by = static_cast<int>(c) / side;
      const double dx = bx * bw * m->tile_size, dy = by * bh * m->tile_size;
      std::vector<Encoded> out(tiles.size());
      for (std::size_t i = 0; i < tiles.size(); ++i) {
        pl::TileCloud moved = clouds[i];
        for (auto& p : moved.points) p.x() += dx, p.y() += dy;
        const auto& t = tiles[i];
        out[i] = {{t.key.tx + bx * bw, t.key.ty + by * bh}, pl::encode_tile(moved), t.points,
                  {t.min_x + dx, t.min_y + dy, t.min_z, t.max_x + dx, t.max_y + dy, t.max_z}};
      }
      std::lock_guard lock(mu);
      slots[c] = std::move(out);
      cv.notify_all();
    }
  };
  const double t0 = pl::bench::now_ms();
  std::vector<std::thread> pool;
  for (int i = 0; i < o.threads; ++i) pool.emplace_back(worker);
  pl::Progress bar("copies", copies);
  double bytes = 0, write_ms = 0;
  for (std::size_t c = 0; c < copies; ++c) {
    std::vector<Encoded> copy;
    {
      std::unique_lock lock(mu);
      cv.wait(lock, [&] { return slots[c].has_value(); });
      copy = std::move(*slots[c]);
      slots[c].reset();
    }
    const double w0 = pl::bench::now_ms();
    pl::store::Store::Transaction tx(dst);
    for (const auto& e : copy) {
      dst.put_tile(o.name, version.number, e.key, e.bytes, e.points, e.box[0], e.box[1], e.box[2], e.box[3], e.box[4], e.box[5]);
      bytes += static_cast<double>(e.bytes.size());
    }
    tx.commit();
    write_ms += pl::bench::now_ms() - w0;
    {
      std::lock_guard lock(mu);
      done_copies = c + 1;
      cv.notify_all();
    }
    bar.update(c + 1);
  }
  for (auto& t : pool) t.join();
  bar.finish();
  {
    pl::store::Store::Transaction tx(dst);
    if (!o.signing_key.empty()) {
      const auto key = pl::signing::SigningKey::load(o.signing_key);
      const std::string text = pl::signing::manifest_text(pl::signing::manifest_of(dst, o.name, version.number));
      pl::signing::sign_staged_version(dst, o.name, version.number, key.public_key(), key.sign(text));
    }
    dst.publish(o.name, version.number);
    tx.commit();
  }
  const double s = (pl::bench::now_ms() - t0) / 1000;
  std::printf("map %s version %lld in %s: %zu tiles, %.1f MB of tiles, %.2f km2, in %.1f s (%.1f s of it writing the store)\n",
              o.name.c_str(), static_cast<long long>(version.number), dst.path().c_str(), total, bytes / 1e6, copies * block_km2, s,
              write_ms / 1000);
  std::printf("store size %.1f MB\n", static_cast<double>(dst.database_bytes()) / 1e6);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  pl::cli::Tool tool("bench_bigmap", "a large map for the fleet benchmarks: a published map's tiles repeated side by side");
  Options o;
  auto& app = tool.app();
  app.add_option("--from", o.from, "the store holding the source map")->required();
  app.add_option("--map", o.map, "the source map (its current version)")->required();
  app.add_option("--to", o.to, "the store to write the large map to (a SQLite file or a postgresql:// URL)")->required();
  app.add_option("--name", o.name, "the large map's name")->required();
  app.add_option("--km2", o.km2, "the area the copies cover at least, km2")->check(CLI::Range(0.001, 10000.0));
  app.add_option("--threads", o.threads, "encoding threads")->check(CLI::Range(1, 64));
  app.add_option("--signing-key", o.signing_key, "sign the version with this Ed25519 key (pl-map key-gen) when publishing it")
      ->check(CLI::ExistingFile);
  tool.body([&] { return run(o); });
  return tool.main(argc, argv);
}
