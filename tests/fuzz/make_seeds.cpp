// Writes the seed corpora of the fuzz targets (tests/fuzz/corpus/NAME/) with the project's own
// writers: make_fuzz_seeds OUT_DIR [TARGET...]. The seeds are small and committed; run this again
// when a format changes (see docs/fuzzing.md).
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "pl/common/error.hpp"
#include "pl/common/tile_codec.hpp"
#include "seeds.hpp"

namespace fs = std::filesystem;

namespace pl::fuzz {

std::map<std::string, SeedMaker>& registry() {
  static std::map<std::string, SeedMaker> makers;
  return makers;
}

bool register_seeds(const char* target, SeedMaker make) {
  registry()[target] = make;
  return true;
}

}  // namespace pl::fuzz

namespace {

// A small tile like the map builder's: points on a ground plane and a wall, normals, intensity.
pl::TileCloud small_tile(int n, bool normals, bool intensity, double x0 = 0, double y0 = 0) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  pl::TileCloud c;
  for (int i = 0; i < n; ++i) {
    bool wall = i % 3 == 0;
    Eigen::Vector3d p = wall ? Eigen::Vector3d(x0 + 19.5, y0 + 20 * u(rng), 3 * u(rng)) : Eigen::Vector3d(x0 + 20 * u(rng), y0 + 20 * u(rng), 0.02 * u(rng));
    c.points.push_back(p);
    if (normals) c.normals.push_back(wall ? Eigen::Vector3f(-1, 0, 0) : Eigen::Vector3f(0, 0, 1));
    if (intensity) c.intensity.push_back(static_cast<float>(u(rng)));
  }
  return c;
}

void tile_seeds(const pl::fuzz::PutSeed& put) {
  pl::TileCodecConfig fast;
  fast.speed = 10;  // the sequential coder only
  pl::TileCodecConfig kd;
  kd.speed = 0;  // both coders; the k-d tree one wins on positions alone
  put("positions-kd", pl::encode_tile(small_tile(40, false, false), kd));
  put("positions-seq", pl::encode_tile(small_tile(40, false, false), fast));
  put("normals-seq", pl::encode_tile(small_tile(40, true, false), fast));
  put("full-seq", pl::encode_tile(small_tile(30, true, true), fast));
  put("full-default", pl::encode_tile(small_tile(30, true, true, 1000, -2000)));
  put("empty", pl::encode_tile(pl::TileCloud{}));
  put("one-point", pl::encode_tile(small_tile(1, true, true)));
}

const bool registered = pl::fuzz::register_seeds("tile", tile_seeds);

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: make_fuzz_seeds OUT_DIR [TARGET...]\n");
    return 2;
  }
  const std::string out_dir = argv[1];
  std::set<std::string> want(argv + 2, argv + argc);
  try {
    for (auto& [target, make] : pl::fuzz::registry()) {
      if (!want.empty() && !want.count(target)) continue;
      const std::string dir = out_dir + "/" + target;
      fs::create_directories(dir);
      make([&](const std::string& name, const std::string& bytes) {
        std::ofstream out(dir + "/" + name, std::ios::binary);
        out << bytes;
        if (!out) throw pl::Error(dir + "/" + name + ": cannot write");
      });
      std::printf("%s: seeds written to %s\n", target.c_str(), dir.c_str());
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "make_fuzz_seeds: %s\n", e.what());
    return 1;
  }
  return 0;
}
