#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <unordered_map>
#include <unordered_set>

#include "pl/common/error.hpp"
#include "pl/common/tile_key.hpp"

TEST(TileKey, HalfOpenBounds) {
  pl::TileGrid g(20.0);
  EXPECT_EQ(g.key_of(0.0, 0.0), (pl::TileKey{0, 0}));
  EXPECT_EQ(g.key_of(19.999, 19.999), (pl::TileKey{0, 0}));
  EXPECT_EQ(g.key_of(20.0, 0.0), (pl::TileKey{1, 0}));
  EXPECT_EQ(g.key_of(-0.001, -20.0), (pl::TileKey{-1, -1}));
  EXPECT_EQ(g.key_of(-20.001, 0), (pl::TileKey{-2, 0}));
  pl::TileBounds b = g.bounds_of({-2, 3});
  EXPECT_DOUBLE_EQ(b.min_x, -40.0);
  EXPECT_DOUBLE_EQ(b.max_x, -20.0);
  EXPECT_DOUBLE_EQ(b.min_y, 60.0);
  EXPECT_DOUBLE_EQ(b.max_y, 80.0);
  EXPECT_TRUE(b.contains(-40.0, 60.0));
  EXPECT_FALSE(b.contains(-20.0, 70.0));
  EXPECT_THROW(pl::TileGrid(0.0), pl::Error);
  EXPECT_THROW(g.key_of(1e300, 0), pl::Error);
}

TEST(TileKey, KeyAndBoundsAgreeEverywhere) {
  pl::TileGrid g(12.5);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-5000.0, 5000.0);
  for (int i = 0; i < 10000; ++i) {
    double x = u(rng), y = u(rng);
    EXPECT_TRUE(g.bounds_of(g.key_of(x, y)).contains(x, y));
  }
}

TEST(TileKey, DiscMatchesBruteForce) {
  pl::TileGrid g(20.0);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-100.0, 100.0), ur(0.0, 90.0);
  for (int trial = 0; trial < 200; ++trial) {
    double cx = u(rng), cy = u(rng), r = ur(rng);
    auto keys = g.keys_in_disc(cx, cy, r);
    ASSERT_TRUE(std::is_sorted(keys.begin(), keys.end()));
    // Brute force: a tile intersects the disc when a dense sample of its area lies within r.
    for (int tx = -12; tx <= 11; ++tx) {
      for (int ty = -12; ty <= 11; ++ty) {
        pl::TileBounds b = g.bounds_of({tx, ty});
        bool hit = false;
        for (int a = 0; a <= 40 && !hit; ++a)
          for (int c = 0; c <= 40 && !hit; ++c) {
            double x = b.min_x + (b.max_x - b.min_x) * a / 40.0, y = b.min_y + (b.max_y - b.min_y) * c / 40.0;
            hit = std::hypot(x - cx, y - cy) <= r - 1e-9;
          }
        bool listed = std::binary_search(keys.begin(), keys.end(), pl::TileKey{tx, ty});
        if (hit) {
          EXPECT_TRUE(listed) << tx << "," << ty << " r=" << r;
        }
        // A listed tile is within r of the centre (its closest point, up to the sampling step).
        if (listed) {
          double dx = std::max({b.min_x - cx, 0.0, cx - b.max_x}), dy = std::max({b.min_y - cy, 0.0, cy - b.max_y});
          EXPECT_LE(std::hypot(dx, dy), r + 1e-9);
        }
      }
    }
  }
  EXPECT_EQ(g.keys_in_disc(10, 10, 0).size(), 1u);
  EXPECT_EQ(g.keys_in_disc(20, 20, 0.5).size(), 4u);  // a corner touches four tiles
}

// TileKeyHash: a map's neighbouring tiles (either sign, both axes, the two coordinates swapped) get
// distinct hashes that fill an unordered map's buckets evenly, and equal keys hash alike.
TEST(TileKey, HashSpreadsNeighbouringKeys) {
  pl::TileKeyHash hash;
  std::unordered_set<std::size_t> values;
  std::unordered_map<pl::TileKey, int, pl::TileKeyHash> map;
  for (int tx = -150; tx < 150; ++tx)
    for (int ty = -150; ty < 150; ++ty) {
      values.insert(hash({tx, ty}));
      map[{tx, ty}] = tx * 1000 + ty;
    }
  EXPECT_EQ(values.size(), 300u * 300u);
  EXPECT_NE(hash({3, 7}), hash({7, 3}));
  EXPECT_EQ(hash({-5, 12}), hash(pl::TileKey{-5, 12}));
  EXPECT_EQ(map.at({-150, 149}), -150 * 1000 + 149);
  std::size_t longest = 0;
  for (std::size_t b = 0; b < map.bucket_count(); ++b) longest = std::max(longest, map.bucket_size(b));
  // 90,000 keys in at least as many buckets: a sound hash leaves no bucket longer than a handful
  // (the key packed without mixing, with the buckets a power of two apart, would stack whole rows).
  EXPECT_LE(longest, 10u);
}
