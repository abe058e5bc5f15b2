// The tile client's fetch planning (client/src/fetch_plan.hpp) and its index of known keys
// (client/src/tile_index.hpp): which tiles are wanted for the discs and in which order, which discs
// are asked about and with which have= hashes, and what an ROI answer says about the keys it leaves
// out. Plain logic: the decisions are checked on hand-made grids, discs and indexes.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "fetch_plan.hpp"
#include "tile_index.hpp"

using pl::TileBounds;
using pl::TileGrid;
using pl::TileKey;
using pl::client::CachedTile;
using pl::client::Disc;
using pl::client::FetchPlan;
using pl::client::make_plan;
using pl::client::TileIndex;
using Eigen::Vector2d;

namespace pl {
inline void PrintTo(const TileKey& k, std::ostream* os) { *os << k.tx << "/" << k.ty; }
}  // namespace pl

namespace {

// A distinct valid-looking hash per number.
std::string hash_of(int n) {
  std::string h = std::to_string(n);
  return std::string(64 - h.size(), 'a') + h;
}

CachedTile tile(TileKey k, int n) { return CachedTile{k, hash_of(n), 100}; }
CachedTile no_tile(TileKey k) { return CachedTile{k, {}, 0}; }

std::vector<TileKey> keys_of(const FetchPlan& p) {
  std::vector<TileKey> out;
  for (const auto& w : p.wants) out.push_back(w.key);
  return out;
}

// Knows every key of the disc on the grid (a tile at each).
void know_all(TileIndex& index, const TileGrid& g, const Disc& d, int first_hash = 0) {
  for (const TileKey& k : g.keys_in_disc(d.center.x(), d.center.y(), d.radius)) index.learn(tile(k, first_hash++));
}

}  // namespace

TEST(FetchPlanGeometry, TouchingIsUpToTheDiscEdgeInclusive) {
  const TileBounds box{10, 10, 20, 20};
  // (7, 6) is 3 m left of and 4 m below the box's corner: 5 m away.
  EXPECT_TRUE(pl::client::touches(box, {7, 6}, 5.0));
  EXPECT_FALSE(pl::client::touches(box, {7, 6}, 4.999));
  EXPECT_DOUBLE_EQ(pl::client::box_distance(box, {7, 6}), 5.0);
  // Straight across an edge only that axis counts.
  EXPECT_DOUBLE_EQ(pl::client::box_distance(box, {15, 26}), 6.0);
  EXPECT_TRUE(pl::client::touches(box, {15, 26}, 6.0));
  EXPECT_FALSE(pl::client::touches(box, {15, 26}, 5.9));
  // Inside: distance 0, touching any disc.
  EXPECT_DOUBLE_EQ(pl::client::box_distance(box, {12, 19}), 0.0);
  EXPECT_TRUE(pl::client::touches(box, {12, 19}, 0.0));
}

TEST(FetchPlan, TilesTouchingTheDiscEdgeAreWantedAndNoOthers) {
  TileGrid g(10);
  TileIndex index;
  // From the middle of tile 0/0 the four edge neighbours are 5 m away, the diagonal ones 7.07 m.
  // Boxes are half-open (TileGrid, the server's ROI): a disc ending exactly on the low edge of
  // 1/0 and 0/1 takes them, one ending exactly on the (open) high edge of -1/0 and 0/-1 does not.
  FetchPlan exact = make_plan(g, {Disc{{5, 5}, 5.0}}, index);
  EXPECT_EQ(keys_of(exact), (std::vector<TileKey>{{0, 0}, {0, 1}, {1, 0}}));
  EXPECT_DOUBLE_EQ(exact.wants[1].distance, 5.0);
  FetchPlan inside = make_plan(g, {Disc{{5, 5}, 4.99}}, index);
  EXPECT_EQ(keys_of(inside), (std::vector<TileKey>{{0, 0}}));
  FetchPlan past = make_plan(g, {Disc{{5, 5}, 5.01}}, index);
  EXPECT_EQ(keys_of(past), (std::vector<TileKey>{{0, 0}, {-1, 0}, {0, -1}, {0, 1}, {1, 0}}));
  FetchPlan corners = make_plan(g, {Disc{{5, 5}, 7.08}}, index);
  EXPECT_EQ(corners.wants.size(), 9u);
  EXPECT_FALSE(corners.wanted({2, 0}));
}

TEST(FetchPlan, NearestFirstAcrossTwoDiscs) {
  TileGrid g(10);
  TileIndex index;
  // Disc A: the middle of tile 0/0, 12 m (3 x 3 tiles). Disc B, second in the list: inside tile
  // 5/0 only. B's tile is as near as A's own and comes before A's neighbours.
  FetchPlan p = make_plan(g, {Disc{{5, 5}, 12}, Disc{{55, 5}, 3}}, index, 7);
  EXPECT_EQ(p.gen, 7u);
  const std::vector<TileKey> expected{{0, 0}, {5, 0},                     // 0 m (ties by key)
                                      {-1, 0}, {0, -1}, {0, 1}, {1, 0},   // 5 m
                                      {-1, -1}, {-1, 1}, {1, -1}, {1, 1}};  // 7.07 m
  ASSERT_EQ(keys_of(p), expected);
  EXPECT_DOUBLE_EQ(p.wants[1].distance, 0.0);
  EXPECT_DOUBLE_EQ(p.wants[2].distance, 5.0);
  EXPECT_DOUBLE_EQ(p.wants[9].distance, std::sqrt(50.0));
  for (std::size_t i = 0; i < expected.size(); ++i) EXPECT_EQ(p.rank_of(expected[i]), i);
  EXPECT_FALSE(p.rank_of({4, 0}).has_value());  // between the discs: outside the plan
  EXPECT_FALSE(p.wanted({4, 0}));
}

TEST(FetchPlan, TileWantedByTwoDiscsTakesTheNearerDistance) {
  TileGrid g(10);
  TileIndex index;
  // Tile 1/0 is 5 m from A's center and under B's center; tile 2/0 only in B, 2 m away.
  FetchPlan p = make_plan(g, {Disc{{5, 5}, 12}, Disc{{18, 5}, 2}}, index);
  ASSERT_TRUE(p.rank_of({1, 0}).has_value());
  EXPECT_DOUBLE_EQ(p.wants[*p.rank_of({1, 0})].distance, 0.0);
  EXPECT_LT(*p.rank_of({1, 0}), *p.rank_of({2, 0}));
  EXPECT_DOUBLE_EQ(p.wants[*p.rank_of({2, 0})].distance, 2.0);
  EXPECT_LT(*p.rank_of({2, 0}), *p.rank_of({-1, 0}));
  // Each key once.
  EXPECT_EQ(p.wants.size(), 9u + 1u);
}

TEST(FetchPlan, TheOrderOfTheDiscsChangesNoWant) {
  TileGrid g(10);
  TileIndex index;
  // Overlapping discs of different sizes: each shared tile takes the nearer distance whichever disc
  // names it first, and ties stay in key order.
  const Disc a{{5, 5}, 25}, b{{31, -4}, 18};
  const FetchPlan ab = make_plan(g, {a, b}, index), ba = make_plan(g, {b, a}, index);
  ASSERT_EQ(keys_of(ab), keys_of(ba));
  // A disc's distance to a tile it touches (infinite when it does not).
  auto from = [&](const Disc& d, const TileKey& k) {
    const pl::TileBounds box = g.bounds_of(k);
    return pl::client::touches(box, d.center, d.radius) ? pl::client::box_distance(box, d.center) : INFINITY;
  };
  for (std::size_t i = 0; i < ab.wants.size(); ++i) {
    const TileKey k = ab.wants[i].key;
    EXPECT_DOUBLE_EQ(ab.wants[i].distance, ba.wants[i].distance);
    EXPECT_DOUBLE_EQ(ab.wants[i].distance, std::min(from(a, k), from(b, k)));
    EXPECT_EQ(ab.rank_of(k), i);
    if (i > 0 && ab.wants[i].distance == ab.wants[i - 1].distance) {
      EXPECT_LT(ab.wants[i - 1].key, k);
    }
  }
}

TEST(FetchPlan, AsksOnlyAboutDiscsWithUnknownKeysOneTileWider) {
  TileGrid g(10);
  TileIndex index;
  const Disc a{{5, 5}, 12}, b{{105, 5}, 12};
  know_all(index, g, a);
  FetchPlan p = make_plan(g, {a, b}, index);
  ASSERT_EQ(p.queries.size(), 1u);  // a is known whole
  EXPECT_EQ(p.queries[0].disc.center, b.center);
  EXPECT_DOUBLE_EQ(p.queries[0].disc.radius, 12 + 10);
  EXPECT_TRUE(p.queries[0].have.empty());  // nothing known near b
  // One unknown key of a (a "no tile here" row counts as known) is enough to ask about it again.
  index.forget({1, 1});
  index.learn(no_tile({105 / 10, 0}));
  FetchPlan q = make_plan(g, {a, b}, index);
  ASSERT_EQ(q.queries.size(), 2u);
  EXPECT_EQ(q.queries[0].disc.center, a.center);  // in disc order
  EXPECT_EQ(q.queries[1].disc.center, b.center);
  // The wider disc is capped at the server's limit.
  TileGrid km(1000);
  FetchPlan far = make_plan(km, {Disc{{0, 0}, 4995}}, TileIndex{});
  ASSERT_EQ(far.queries.size(), 1u);
  EXPECT_DOUBLE_EQ(far.queries[0].disc.radius, pl::client::kMaxRoiRadius);
}

TEST(FetchPlan, HaveNamesTheKnownTilesOfTheWiderDisc) {
  TileGrid g(10);
  TileIndex index;
  index.learn(tile({0, 0}, 1));
  index.learn(tile({2, 0}, 2));   // 15 m from (5, 5): outside the 12 m disc, inside the 22 m one
  index.learn(tile({4, 0}, 3));   // 35 m: outside both
  index.learn(no_tile({0, 1}));   // known, but no tile to name
  FetchPlan p = make_plan(g, {Disc{{5, 5}, 12}}, index);
  ASSERT_EQ(p.queries.size(), 1u);
  EXPECT_EQ(p.queries[0].have, (std::vector<std::string>{hash_of(1), hash_of(2)}));
  // One hash at two keys: have= would hide one of them, so nothing is named from then on.
  index.learn(CachedTile{{-1, 0}, hash_of(1), 100});
  EXPECT_FALSE(index.have_usable());
  FetchPlan q = make_plan(g, {Disc{{5, 5}, 12}}, index);
  ASSERT_EQ(q.queries.size(), 1u);
  EXPECT_TRUE(q.queries[0].have.empty());
}

TEST(FetchPlan, HaveIsCappedInKeyOrder) {
  TileGrid g(1);
  TileIndex index;
  std::vector<TileKey> known;
  for (int x = 0; x < 10; ++x)
    for (int y = 0; y < 10; ++y) {
      index.learn(tile({x, y}, x * 10 + y));
      known.push_back({x, y});
    }
  FetchPlan p = make_plan(g, {Disc{{5, 5}, 20}}, index);  // 100 known tiles, unknown keys around them
  ASSERT_EQ(p.queries.size(), 1u);
  ASSERT_EQ(p.queries[0].have.size(), pl::client::kMaxHave);
  for (std::size_t i = 0; i < pl::client::kMaxHave; ++i) EXPECT_EQ(p.queries[0].have[i], hash_of(known[i].tx * 10 + known[i].ty));
}

TEST(FetchPlan, NoDiscsNoWants) {
  TileGrid g(10);
  TileIndex index;
  FetchPlan p = make_plan(g, {}, index);
  EXPECT_TRUE(p.wants.empty());
  EXPECT_TRUE(p.queries.empty());
  EXPECT_FALSE(p.rank_of({0, 0}).has_value());
}

TEST(TileIndex, LearnsReplacesForgetsAndClears) {
  TileIndex index;
  EXPECT_EQ(index.find({1, 2}), nullptr);
  index.learn(tile({1, 2}, 1));
  ASSERT_NE(index.find({1, 2}), nullptr);
  EXPECT_EQ(index.find({1, 2})->hash, hash_of(1));
  index.learn(no_tile({1, 2}));  // the key's row is replaced
  ASSERT_TRUE(index.knows({1, 2}));
  EXPECT_FALSE(index.find({1, 2})->exists());
  index.learn(tile({1, 2}, 1));  // the same hash at the same key again: have= still usable
  EXPECT_TRUE(index.have_usable());
  index.forget({1, 2});
  EXPECT_FALSE(index.knows({1, 2}));
  index.learn(tile({3, 3}, 1));  // the hash at a second key
  EXPECT_FALSE(index.have_usable());
  index.clear();
  EXPECT_EQ(index.size(), 0u);
  EXPECT_TRUE(index.have_usable());
}

TEST(TileIndex, AnswerMarksOnlyUnknownLeftOutKeysAsEmpty) {
  TileIndex index;
  index.learn(tile({0, 0}, 1));  // known: the server left it out because of have=
  const std::vector<TileKey> disc{{0, 0}, {0, 1}, {1, 0}, {1, 1}};
  auto rows = pl::client::rows_of_answer({tile({1, 0}, 2)}, disc, index);
  ASSERT_EQ(rows.size(), 3u);
  EXPECT_EQ(rows[0].key, (TileKey{1, 0}));  // the listed tile, first and as listed
  EXPECT_EQ(rows[0].hash, hash_of(2));
  EXPECT_EQ(rows[1].key, (TileKey{0, 1}));
  EXPECT_FALSE(rows[1].exists());
  EXPECT_EQ(rows[2].key, (TileKey{1, 1}));
  EXPECT_FALSE(rows[2].exists());
}
