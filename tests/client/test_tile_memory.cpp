// The tile client's memory budget (client/src/tile_memory.hpp): what is held with its size and last
// use, whether a tile fits, and which tiles go to make room for it given the plan and the rank of the
// tile being loaded. Plain logic: plans come from make_plan on a hand-made grid, sizes are chosen.
#include <gtest/gtest.h>

#include <optional>
#include <vector>

#include "fetch_plan.hpp"
#include "tile_memory.hpp"

using pl::TileGrid;
using pl::TileKey;
using pl::client::Disc;
using pl::client::FetchPlan;
using pl::client::make_plan;
using pl::client::MapTile;
using pl::client::TileIndex;
using pl::client::TileMemory;

namespace pl {
inline void PrintTo(const TileKey& k, std::ostream* os) { *os << k.tx << "/" << k.ty; }
}  // namespace pl

namespace {

using Keys = std::vector<TileKey>;

MapTile map_tile(TileKey k) { return MapTile{k, std::string(64, 'b'), nullptr, 0}; }

// 10 m tiles; the focus: 12 m around the middle of tile 0/0. Ranks (nearest first):
//   0: 0/0   1: -1/0   2: 0/-1   3: 0/1   4: 1/0   5: -1/-1   6: -1/1   7: 1/-1   8: 1/1
struct Fixture {
  TileGrid grid{10};
  TileIndex index;
  FetchPlan plan = make_plan(grid, {Disc{{5, 5}, 12}}, index);
  // Far from the focus: outside the plan.
  const TileKey out1{20, 20}, out2{30, 30}, out3{40, 40};
};

std::size_t rank(const FetchPlan& p, TileKey k) { return p.rank_of(k).value(); }

}  // namespace

TEST(TileMemory, FixtureRanksAreAsDocumented) {
  Fixture f;
  EXPECT_EQ(rank(f.plan, {0, 0}), 0u);
  EXPECT_EQ(rank(f.plan, {-1, 0}), 1u);
  EXPECT_EQ(rank(f.plan, {1, 0}), 4u);
  EXPECT_EQ(rank(f.plan, {-1, 1}), 6u);
  EXPECT_EQ(rank(f.plan, {1, 1}), 8u);
  EXPECT_FALSE(f.plan.wanted(f.out1));
}

TEST(TileMemory, CountsWhatItHolds) {
  TileMemory m(100);
  m.put(map_tile({0, 0}), 10);
  m.put(map_tile({1, 0}), 20);
  EXPECT_EQ(m.bytes(), 30u);
  EXPECT_EQ(m.count(), 2u);
  m.put(map_tile({0, 0}), 15);  // replaces the tile at its key
  EXPECT_EQ(m.bytes(), 35u);
  EXPECT_EQ(m.count(), 2u);
  EXPECT_TRUE(m.drop({1, 0}));
  EXPECT_FALSE(m.drop({1, 0}));
  EXPECT_EQ(m.bytes(), 15u);
  ASSERT_NE(m.find({0, 0}), nullptr);
  EXPECT_EQ(m.find({0, 0})->key, (TileKey{0, 0}));
  EXPECT_EQ(m.find({1, 0}), nullptr);
  m.clear();
  EXPECT_EQ(m.bytes(), 0u);
  EXPECT_EQ(m.count(), 0u);
}

TEST(TileMemory, UseNearReturnsTouchingTilesInKeyOrder) {
  Fixture f;
  TileMemory m(1000);
  m.put(map_tile({1, 0}), 1);
  m.put(map_tile({0, 0}), 1);
  m.put(map_tile({2, 0}), 1);
  m.put(map_tile(f.out1), 1);
  auto near = m.use_near(f.grid, {10, 5}, 0);  // on the edge between 0/0 and 1/0
  ASSERT_EQ(near.size(), 2u);
  EXPECT_EQ(near[0].key, (TileKey{0, 0}));
  EXPECT_EQ(near[1].key, (TileKey{1, 0}));
  EXPECT_EQ(m.use_near(f.grid, {0, 0}, 1000).size(), 4u);
}

TEST(TileMemory, WithinTheBudgetNothingGoes) {
  Fixture f;
  TileMemory m(100);
  m.put(map_tile(f.out1), 30);
  EXPECT_TRUE(m.fits(f.plan, 0, 70));
  auto v = m.victims(f.plan, 0, 70);
  ASSERT_TRUE(v.has_value());
  EXPECT_TRUE(v->empty());
}

TEST(TileMemory, LeastRecentlyUsedOutsideTheFocusGoFirst) {
  Fixture f;
  TileMemory m(100);
  m.put(map_tile(f.out1), 30);
  m.put(map_tile(f.out2), 30);
  m.put(map_tile({1, 1}), 30);  // in the focus, the farthest
  EXPECT_EQ(m.evictable(f.plan, 0), 90u);
  // Just enough: one tile, the least recently used one outside the focus.
  EXPECT_EQ(m.victims(f.plan, 0, 40), (Keys{f.out1}));
  // Using out1 makes out2 the older one.
  ASSERT_EQ(m.use_near(f.grid, {205, 205}, 1).size(), 1u);
  EXPECT_EQ(m.victims(f.plan, 0, 40), (Keys{f.out2}));
  // Both outside tiles go before any focus tile, however far.
  EXPECT_EQ(m.victims(f.plan, 0, 70), (Keys{f.out2, f.out1}));
  EXPECT_EQ(m.victims(f.plan, 0, 100), (Keys{f.out2, f.out1, TileKey{1, 1}}));
  // Deciding evicts nothing.
  EXPECT_EQ(m.count(), 3u);
  EXPECT_EQ(m.bytes(), 90u);
}

TEST(TileMemory, FartherFocusTilesGoOnlyForANearerTile) {
  Fixture f;
  TileMemory m(60);
  m.put(map_tile({-1, 0}), 30);  // rank 1
  m.put(map_tile({-1, 1}), 30);  // rank 6
  // Loading rank 4: only the rank-6 tile may go.
  EXPECT_EQ(m.evictable(f.plan, 4), 30u);
  EXPECT_TRUE(m.fits(f.plan, 4, 30));
  EXPECT_EQ(m.victims(f.plan, 4, 30), (Keys{{-1, 1}}));
  // Loading rank 4 with 60 bytes would need the nearer rank-1 tile too: refused, nothing evicted.
  EXPECT_FALSE(m.fits(f.plan, 4, 60));
  EXPECT_FALSE(m.victims(f.plan, 4, 60).has_value());
  EXPECT_FALSE(m.make_room(f.plan, 4, 60).has_value());
  EXPECT_EQ(m.bytes(), 60u);
  EXPECT_TRUE(m.holds({-1, 0}));
  EXPECT_TRUE(m.holds({-1, 1}));
  // Loading rank 0 (nearer than both): both may go, the farthest first.
  EXPECT_EQ(m.victims(f.plan, 0, 60), (Keys{{-1, 1}, {-1, 0}}));
  EXPECT_EQ(m.victims(f.plan, 0, 30), (Keys{{-1, 1}}));
}

TEST(TileMemory, RefusesWhenNothingMayGo) {
  Fixture f;
  TileMemory m(50);
  m.put(map_tile({0, 0}), 25);   // rank 0
  m.put(map_tile({0, -1}), 25);  // rank 2
  for (std::size_t r : {2u, 3u, 8u}) {
    EXPECT_EQ(m.evictable(f.plan, r), 0u) << r;
    EXPECT_FALSE(m.fits(f.plan, r, 1)) << r;
    EXPECT_FALSE(m.victims(f.plan, r, 1).has_value()) << r;
  }
  EXPECT_FALSE(m.make_room(f.plan, 3, 1).has_value());
  EXPECT_EQ(m.count(), 2u);
  EXPECT_EQ(m.bytes(), 50u);
  // Rank 1 is nearer than the rank-2 tile: that one may go.
  EXPECT_EQ(m.victims(f.plan, 1, 1), (Keys{{0, -1}}));
}

TEST(TileMemory, WhatMayGoDependsOnThePlan) {
  Fixture f;
  TileMemory m(30);
  m.put(map_tile({0, 0}), 30);
  EXPECT_FALSE(m.victims(f.plan, 3, 30).has_value());  // rank 0 of this plan: kept
  // The vehicle moved on: 0/0 is outside the new focus and goes for any tile of it.
  FetchPlan moved = make_plan(f.grid, {Disc{{505, 5}, 12}}, f.index);
  ASSERT_FALSE(moved.wanted({0, 0}));
  EXPECT_EQ(m.victims(moved, 8, 30), (Keys{{0, 0}}));
}

TEST(TileMemory, TileBiggerThanTheWholeBudgetNeverFits) {
  Fixture f;
  TileMemory m(100);
  EXPECT_TRUE(m.fits(f.plan, 0, 100));  // exactly the budget fits in empty memory
  EXPECT_FALSE(m.fits(f.plan, 0, 101));
  EXPECT_FALSE(m.victims(f.plan, 0, 101).has_value());
  m.put(map_tile(f.out1), 50);
  EXPECT_FALSE(m.fits(f.plan, 0, 101));
  EXPECT_FALSE(m.make_room(f.plan, 0, 101).has_value());
  EXPECT_TRUE(m.holds(f.out1));  // nothing evicted in vain
  EXPECT_EQ(m.bytes(), 50u);
}

TEST(TileMemory, BudgetAccountingAfterEvictions) {
  Fixture f;
  TileMemory m(100);
  m.put(map_tile(f.out1), 20);
  m.put(map_tile(f.out2), 35);
  m.put(map_tile(f.out3), 10);
  m.put(map_tile({1, 1}), 25);  // rank 8
  ASSERT_EQ(m.bytes(), 90u);
  // 60 bytes for rank 0: out1 and out2 (55 bytes) are just enough; out3 and 1/1 stay.
  auto gone = m.make_room(f.plan, 0, 60);
  ASSERT_TRUE(gone.has_value());
  EXPECT_EQ(*gone, (Keys{f.out1, f.out2}));
  EXPECT_EQ(m.bytes(), 35u);
  EXPECT_EQ(m.count(), 2u);
  EXPECT_FALSE(m.holds(f.out1));
  EXPECT_FALSE(m.holds(f.out2));
  m.put(map_tile({0, 0}), 60);
  EXPECT_EQ(m.bytes(), 95u);
  EXPECT_LE(m.bytes(), m.budget());
  // Now out3 (outside) goes before 1/1 (rank 8), and then only 1/1 may go for rank 1; 0/0 stays.
  EXPECT_EQ(m.victims(f.plan, 1, 40), (Keys{f.out3, TileKey{1, 1}}));
  EXPECT_FALSE(m.victims(f.plan, 1, 41).has_value());
  gone = m.make_room(f.plan, 1, 40);
  ASSERT_TRUE(gone.has_value());
  EXPECT_EQ(gone->size(), 2u);
  EXPECT_EQ(m.bytes(), 60u);
  m.put(map_tile({-1, 0}), 40);
  EXPECT_EQ(m.bytes(), 100u);
  EXPECT_EQ(m.count(), 2u);
}
