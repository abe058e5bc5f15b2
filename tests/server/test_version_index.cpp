// The in-memory index of an immutable map version and the ROI answer written without a json tree:
// the tiles found are exactly those a brute-force test of every tile finds (both ways of looking:
// key by key, and every tile when the disc spans more keys than there are tiles), and the body is
// byte for byte what nlohmann::json writes for the same answer.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "version_index.hpp"
#include "pl/common/tile_key.hpp"

namespace {

using pl::server::VersionIndex;
using nlohmann::json;

std::string hex_hash(std::mt19937& rng) {
  static const char* digits = "0123456789abcdef";
  std::string h(64, '0');
  for (char& c : h) c = digits[rng() % 16];
  return h;
}

// Tiles at random keys of a block round the origin (negative keys included), each key once.
std::vector<pl::store::TileRecord> random_tiles(std::mt19937& rng, int count, int span) {
  std::set<std::pair<int, int>> keys;
  std::vector<pl::store::TileRecord> out;
  while (static_cast<int>(out.size()) < count) {
    const int tx = static_cast<int>(rng() % (2 * span + 1)) - span, ty = static_cast<int>(rng() % (2 * span + 1)) - span;
    if (!keys.insert({tx, ty}).second) continue;
    pl::store::TileRecord r;
    r.key = {tx, ty};
    r.hash = hex_hash(rng);
    r.points = static_cast<std::int64_t>(rng() % 100000);
    r.bytes = static_cast<std::int64_t>(rng() % 1000000);
    out.push_back(r);
  }
  std::shuffle(out.begin(), out.end(), rng);
  return out;
}

std::vector<pl::TileKey> brute_force(const std::vector<pl::store::TileRecord>& tiles, double size, double x, double y, double r) {
  std::vector<pl::TileKey> out;
  const pl::TileGrid grid(size);
  for (const auto& t : tiles) {
    const pl::TileBounds b = grid.bounds_of(t.key);
    const double dx = std::max({b.min_x - x, 0.0, x - b.max_x}), dy = std::max({b.min_y - y, 0.0, y - b.max_y});
    if (dx * dx + dy * dy <= r * r) out.push_back(t.key);
  }
  std::sort(out.begin(), out.end());
  return out;
}

TEST(VersionIndex, FindsExactlyTheTilesThatTouchTheDiscInKeyOrder) {
  std::mt19937 rng(7);
  for (const double size : {20.0, 1.0, 250.0}) {
    const auto tiles = random_tiles(rng, 300, 30);
    const VersionIndex index(size, tiles);
    ASSERT_EQ(index.size(), tiles.size());
    std::uniform_real_distribution<double> pos(-40.0 * size, 40.0 * size), rad(0.0, 12.0 * size);
    int both_ways[2] = {0, 0};
    for (int i = 0; i < 400; ++i) {
      // Some discs centred on tile edges, some spanning more keys than there are tiles.
      double x = pos(rng), y = pos(rng);
      double r = i % 7 == 0 ? 5000.0 : rad(rng);
      if (i % 5 == 0) x = std::round(x / size) * size;
      if (i % 3 == 0) {  // a disc whose edge lies exactly on tile edges, in x, in y or both
        r = std::round(r / size) * size;
        if (i % 2 == 0) x = std::round(x / size) * size;
        y = std::round(y / size) * size;
      }
      const double keys = (std::floor((x + r) / size) - std::floor((x - r) / size) + 1) *
                          (std::floor((y + r) / size) - std::floor((y - r) / size) + 1);
      ++both_ways[keys > static_cast<double>(tiles.size()) ? 1 : 0];
      std::vector<pl::TileKey> got;
      for (const VersionIndex::Tile* t : index.in_disc(x, y, r)) got.push_back(t->key);
      const std::vector<pl::TileKey> expected = brute_force(tiles, size, x, y, r);
      ASSERT_EQ(got.size(), expected.size()) << "size " << size << " x " << x << " y " << y << " r " << r;
      for (std::size_t k = 0; k < got.size(); ++k) ASSERT_EQ(got[k], expected[k]);  // (tx, ty) order
    }
    EXPECT_GT(both_ways[0], 50) << "key by key";
    EXPECT_GT(both_ways[1], 20) << "every tile";
  }
  // The records carried whole.
  const auto tiles = random_tiles(rng, 5, 2);
  const VersionIndex index(20.0, tiles);
  for (const VersionIndex::Tile* t : index.in_disc(0, 0, 200)) {
    const auto it = std::find_if(tiles.begin(), tiles.end(), [&](const auto& r) { return r.key == t->key; });
    ASSERT_NE(it, tiles.end());
    EXPECT_EQ(t->hash, it->hash);
    EXPECT_EQ(t->points, it->points);
    EXPECT_EQ(t->bytes, it->bytes);
  }
  EXPECT_EQ(index.in_disc(0, 0, 200).size(), 5u);
}

TEST(VersionIndex, NothingForABadDiscOrAnEmptyVersion) {
  std::mt19937 rng(3);
  const VersionIndex index(20.0, random_tiles(rng, 20, 3));
  EXPECT_TRUE(index.in_disc(0, 0, -1).empty());
  EXPECT_TRUE(index.in_disc(0, 0, NAN).empty());
  EXPECT_TRUE(index.in_disc(NAN, 0, 10).empty());
  EXPECT_TRUE(index.in_disc(0, INFINITY, 10).empty());
  EXPECT_TRUE(index.in_disc(1e300, 0, 10).empty());  // keys beyond int32: every tile tested, none near
  EXPECT_TRUE(VersionIndex(20.0, {}).in_disc(0, 0, 100).empty());
}

TEST(VersionIndex, RoiBodyIsWhatNlohmannJsonWrites) {
  std::mt19937 rng(11);
  for (const double size : {20.0, 12.5, 1.0, 0.1, 1000.0}) {
    const auto tiles = random_tiles(rng, 60, 9);
    const VersionIndex index(size, tiles);
    for (int round = 0; round < 20; ++round) {
      std::vector<const VersionIndex::Tile*> send = index.in_disc(0.0, 0.0, static_cast<double>(round) * size / 2.0);
      std::vector<std::string> drop_text;
      for (int d = 0; d < round % 4; ++d) drop_text.push_back(hex_hash(rng));
      std::sort(drop_text.begin(), drop_text.end());
      const std::vector<std::string_view> drop(drop_text.begin(), drop_text.end());
      const std::string map = round % 2 ? "town" : "A-map_2.v";
      const std::int64_t version = 1 + round * 997;
      json tiles_json = json::array();
      for (const auto* t : send)
        tiles_json.push_back({{"tx", t->key.tx}, {"ty", t->key.ty}, {"hash", t->hash},
                              {"url", "/v1/maps/" + map + "/versions/" + std::to_string(version) + "/tiles/" + std::to_string(t->key.tx) +
                                          "/" + std::to_string(t->key.ty)},
                              {"points", t->points}, {"bytes", t->bytes}});
      json drop_json = json::array();
      for (const auto& h : drop_text) drop_json.push_back(h);
      const std::string expected =
          json{{"version", version}, {"tile_size", size}, {"tiles", tiles_json}, {"drop", drop_json}}.dump(-1, ' ', false,
                                                                                                           json::error_handler_t::replace) +
          "\n";
      ASSERT_EQ(pl::server::roi_body(map, version, size, send, drop), expected);
    }
  }
}

TEST(VersionIndex, CacheKeepsTheNewestUpToItsCapacity) {
  std::mt19937 rng(5);
  pl::server::VersionIndexCache cache(2);
  auto a = std::make_shared<const VersionIndex>(20.0, random_tiles(rng, 3, 2));
  auto b = std::make_shared<const VersionIndex>(20.0, random_tiles(rng, 4, 2));
  auto c = std::make_shared<const VersionIndex>(20.0, random_tiles(rng, 5, 2));
  EXPECT_EQ(cache.find("town", 1), nullptr);
  cache.put("town", 1, a);
  cache.put("town", 2, b);
  EXPECT_EQ(cache.find("town", 1), a);
  EXPECT_EQ(cache.find("town", 2), b);
  EXPECT_EQ(cache.find("city", 1), nullptr);
  cache.put("town", 1, c);  // already there: kept as it was
  EXPECT_EQ(cache.find("town", 1), a);
  cache.put("city", 1, c);  // full: the first put goes
  EXPECT_EQ(cache.find("town", 1), nullptr);
  EXPECT_EQ(cache.find("town", 2), b);
  EXPECT_EQ(cache.find("city", 1), c);
  pl::server::VersionIndexCache none(0);
  none.put("town", 1, a);
  EXPECT_EQ(none.find("town", 1), nullptr);
}

}  // namespace
