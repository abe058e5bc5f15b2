// Tile codec: equal tiles give equal bytes (in any order of their points, with negative zeros), and
// different tiles different bytes, since a tile's hash names its content.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <string>
#include <vector>

#include "pl/common/tile_codec.hpp"
#include "tile_clouds.hpp"

namespace {

using pl::TileCloud;
using pl::TileCodecConfig;
using pl::test::realistic_tile;

TEST(TileCodec, EqualTilesGiveEqualBytes) {
  const TileCloud tile = realistic_tile({4000.0, -2500.0, 0.0}, 5);
  std::mt19937 rng(42);
  for (int speed : {0, 5, 10}) {
    SCOPED_TRACE("speed " + std::to_string(speed));
    TileCodecConfig cfg;
    cfg.speed = speed;
    const std::string bytes = pl::encode_tile(tile, cfg);
    EXPECT_EQ(pl::encode_tile(tile, cfg), bytes);
    for (int trial = 0; trial < 3; ++trial) {
      std::vector<std::size_t> perm(tile.size());
      for (std::size_t i = 0; i < perm.size(); ++i) perm[i] = i;
      std::shuffle(perm.begin(), perm.end(), rng);
      TileCloud shuffled;
      for (std::size_t i : perm) {
        shuffled.points.push_back(tile.points[i]);
        shuffled.normals.push_back(tile.normals[i]);
        shuffled.intensity.push_back(tile.intensity[i]);
      }
      EXPECT_EQ(pl::encode_tile(shuffled, cfg), bytes);
    }
  }
  // Negative zeros are zeros.
  TileCloud zeros;
  zeros.points = {{0.0, 0.0, 0.0}, {1.5, -0.0, 2.0}, {-0.0, 3.0, -0.0}};
  zeros.normals = {{0.f, 0.f, 1.f}, {-0.f, 1.f, 0.f}, {1.f, 0.f, -0.f}};
  zeros.intensity = {0.f, 0.5f, -0.f};
  TileCloud signed_zeros = zeros;
  for (auto& p : signed_zeros.points) p = -(-p);
  signed_zeros.points[0] = {-0.0, -0.0, -0.0};
  signed_zeros.normals[0] = {-0.f, -0.f, 1.f};
  signed_zeros.intensity[0] = -0.f;
  zeros.points[2] = {0.0, 3.0, 0.0};
  EXPECT_EQ(pl::encode_tile(signed_zeros), pl::encode_tile(zeros));
  // Positions only (the k-d tree coder's case), with repeated points.
  TileCloud positions;
  positions.points = tile.points;
  positions.points.insert(positions.points.end(), tile.points.begin(), tile.points.begin() + 50);
  const std::string bytes = pl::encode_tile(positions);
  std::reverse(positions.points.begin(), positions.points.end());
  EXPECT_EQ(pl::encode_tile(positions), bytes);
}

TEST(TileCodec, DifferentTilesGiveDifferentBytes) {
  const TileCloud tile = realistic_tile({4000.0, -2500.0, 0.0}, 6);
  const std::string bytes = pl::encode_tile(tile);
  TileCloud moved = tile;
  moved.points[100].x() += 0.1;
  EXPECT_NE(pl::encode_tile(moved), bytes);
  TileCloud brighter = tile;
  brighter.intensity[100] = brighter.intensity[100] > 0.5f ? 0.0f : 1.0f;
  EXPECT_NE(pl::encode_tile(brighter), bytes);
  TileCloud turned = tile;
  turned.normals[100] = -turned.normals[100];
  EXPECT_NE(pl::encode_tile(turned), bytes);
  TileCloud fewer = tile;
  fewer.points.pop_back();
  fewer.normals.pop_back();
  fewer.intensity.pop_back();
  EXPECT_NE(pl::encode_tile(fewer), bytes);
  TileCloud shifted = tile;  // same shape one metre east: another origin
  for (auto& p : shifted.points) p.x() += 1.0;
  EXPECT_NE(pl::encode_tile(shifted), bytes);
}

}  // namespace
