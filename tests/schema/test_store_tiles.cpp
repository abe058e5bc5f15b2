// The map store's tiles: idempotent puts over shared blobs, deletes, input checks, box queries, and
// the schema refusing tile writes to published versions.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "pl/schema/store.hpp"
#include "error_of.hpp"
#include "store_fixture.hpp"
#include "store_test_util.hpp"

namespace {

using pl::store::Store;
using pl::store::TileRecord;
using pl::test::contains;
using pl::test::error_of;
using pl::test::fake_draco;
using pl::test::kOrigin;
using pl::test::put_cell;
using pl::test::StoreTest;

TEST_P(StoreTest, PutTileIsIdempotentAndBlobsAreShared) {
  Store s = Store::open(path);
  s.create_map("m", kOrigin, 10, 0.2);
  s.create_version("m", std::nullopt, "");
  std::string data = fake_draco(42, 1000);
  auto r1 = s.put_tile("m", 1, {3, -4}, data, 1234, 31, -39, 0, 39, -31, 2);
  std::int64_t id1 = raw_scalar("SELECT id FROM tiles WHERE tx = 3 AND ty = -4");
  auto r2 = s.put_tile("m", 1, {3, -4}, data, 1234, 31, -39, 0, 39, -31, 2);
  EXPECT_EQ(r1.hash, pl::store::content_hash(data));
  EXPECT_EQ(r1.bytes, 1000);
  EXPECT_EQ(r2.hash, r1.hash);
  EXPECT_EQ(raw_scalar("SELECT id FROM tiles WHERE tx = 3 AND ty = -4"), id1);  // same record
  EXPECT_EQ(count("tiles"), 1);
  EXPECT_EQ(count("blobs"), 1);
  EXPECT_EQ(s.blob(r1.hash), data);
  EXPECT_TRUE(s.has_blob(r1.hash));
  EXPECT_FALSE(s.has_blob(pl::store::content_hash("other")));
  EXPECT_FALSE(s.blob(pl::store::content_hash("other")));

  auto found = s.find_tile("m", 1, {3, -4});
  ASSERT_TRUE(found);
  EXPECT_EQ(found->hash, r1.hash);
  EXPECT_EQ(found->points, 1234);
  EXPECT_DOUBLE_EQ(found->min_x, 31);
  EXPECT_DOUBLE_EQ(found->min_y, -39);
  EXPECT_DOUBLE_EQ(found->max_z, 2);

  // The same bytes under another key, and the copy in version 2: more rows, one blob.
  s.put_tile("m", 1, {0, 0}, data, 1234, 1, 1, 0, 9, 9, 2);
  s.publish("m", 1);
  s.create_version("m", std::nullopt, "");
  EXPECT_EQ(count("tiles"), 4);
  EXPECT_EQ(count("blobs"), 1);

  // New bytes for a key of version 2: a second blob; version 1 keeps its record and blob.
  std::string data2 = fake_draco(43, 700);
  auto r3 = s.put_tile("m", 2, {3, -4}, data2, 99, 31, -39, 0, 39, -31, 2);
  EXPECT_EQ(count("blobs"), 2);
  EXPECT_EQ(s.find_tile("m", 1, {3, -4})->hash, r1.hash);
  EXPECT_EQ(s.find_tile("m", 2, {3, -4})->hash, r3.hash);
  EXPECT_EQ(s.find_tile("m", 2, {3, -4})->points, 99);

  // Replacing it again drops the now unused blob; the shared one stays.
  s.put_tile("m", 2, {3, -4}, fake_draco(44, 600), 98, 31, -39, 0, 39, -31, 2);
  EXPECT_FALSE(s.has_blob(r3.hash));
  EXPECT_TRUE(s.has_blob(r1.hash));
  EXPECT_EQ(count("blobs"), 2);
  EXPECT_TRUE(s.integrity_ok());
}

// Bytes of every value, and long runs of them, come back as they went in (PostgreSQL hands bytea
// over as hex text, decoded by the store).
TEST_P(StoreTest, BlobsOfEveryByteValueReadBackExactly) {
  Store s = Store::open(path);
  s.create_map("m", kOrigin, 20, 0.2);
  s.create_version("m", std::nullopt, "");
  std::string every;
  for (int round = 0; round < 300; ++round)
    for (int b = 0; b < 256; ++b) every += static_cast<char>((b * 7 + round) & 0xFF);
  const auto rec = s.put_tile("m", 1, {0, 0}, every, 1, 0, 0, 0, 1, 1, 1);
  EXPECT_EQ(s.blob(rec.hash), every);
  const std::string one(1, '\0');
  const auto rec1 = s.put_tile("m", 1, {1, 0}, one, 1, 20, 0, 0, 21, 1, 1);
  EXPECT_EQ(s.blob(rec1.hash), one);
  s.put_places("m", 1, every);
  EXPECT_EQ(s.places("m", 1), every);
}

TEST_P(StoreTest, DeleteTile) {
  Store s = Store::open(path);
  s.create_map("m", kOrigin, 10, 0.2);
  s.create_version("m", std::nullopt, "");
  auto shared = put_cell(s, "m", 1, 0, 0, 1);
  s.publish("m", 1);
  s.create_version("m", std::nullopt, "");
  auto own = put_cell(s, "m", 2, 1, 1, 2);
  EXPECT_TRUE(s.delete_tile("m", 2, {0, 0}));
  EXPECT_FALSE(s.delete_tile("m", 2, {0, 0}));  // already gone
  EXPECT_FALSE(s.delete_tile("m", 2, {7, 7}));  // never there
  EXPECT_FALSE(s.find_tile("m", 2, {0, 0}));
  EXPECT_TRUE(s.find_tile("m", 1, {0, 0}));
  EXPECT_TRUE(s.has_blob(shared.hash));  // version 1 still uses it
  EXPECT_TRUE(s.delete_tile("m", 2, {1, 1}));
  EXPECT_FALSE(s.has_blob(own.hash));  // nobody uses it any more
  EXPECT_TRUE(s.tiles_in_box("m", 2, -100, -100, 100, 100).empty());
  EXPECT_EQ(s.tiles_in_box("m", 1, -100, -100, 100, 100).size(), 1u);
  if (sqlite()) {
    EXPECT_EQ(count("tile_rtree"), count("tiles"));
  }
  EXPECT_TRUE(s.integrity_ok());
}

TEST_P(StoreTest, PutTileValidatesItsInput) {
  Store s = Store::open(path);
  s.create_map("m", kOrigin, 10, 0.2);
  s.create_version("m", std::nullopt, "");
  EXPECT_TRUE(contains(error_of([&] { s.put_tile("m", 1, {0, 0}, "", 1, 0, 0, 0, 1, 1, 1); }), "empty"));
  EXPECT_TRUE(contains(error_of([&] { s.put_tile("m", 1, {0, 0}, "x", -1, 0, 0, 0, 1, 1, 1); }), "negative"));
  EXPECT_TRUE(contains(error_of([&] { s.put_tile("m", 1, {0, 0}, "x", 1, 2, 0, 0, 1, 1, 1); }), "min > max"));
  EXPECT_TRUE(contains(error_of([&] { s.put_tile("m", 1, {0, 0}, "x", 1, 0, 0, 0, 1, NAN, 1); }), "finite"));
  EXPECT_EQ(count("tiles"), 0);
  EXPECT_EQ(count("blobs"), 0);
}

TEST_P(StoreTest, TilesInBoxMatchesABruteForceFilter) {
  Store s = Store::open(path);
  s.create_map("m", kOrigin, 10, 0.2);
  s.create_map("other", kOrigin, 10, 0.2);
  s.create_version("m", std::nullopt, "");
  s.create_version("other", std::nullopt, "");
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  {
    Store::Transaction tx(s);
    for (int tx_ = -6; tx_ <= 5; ++tx_) {
      for (int ty = -6; ty <= 5; ++ty) {
        if ((tx_ * 7 + ty * 3) % 5 == 0) continue;  // holes
        // A random sub-box of the cell, with irrational-looking bounds (not float32-exact).
        double x0 = tx_ * 10.0, y0 = ty * 10.0;
        double ax = x0 + 4.9 * u(rng), bx = x0 + 5.0 + 4.999 * u(rng);
        double ay = y0 + 4.9 * u(rng), by = y0 + 5.0 + 4.999 * u(rng);
        std::uint32_t seed = static_cast<std::uint32_t>((tx_ + 10) * 100 + ty + 10);
        s.put_tile("m", 1, {tx_, ty}, fake_draco(seed, 64), 10, ax, ay, -1, bx, by, 1);
        // The other map has the same keys everywhere: it must never show up in m's answers.
        s.put_tile("other", 1, {tx_, ty}, fake_draco(seed + 1, 64), 10, x0, y0, -1, x0 + 10, y0 + 10, 1);
      }
    }
    tx.commit();
  }
  s.publish("m", 1);
  s.create_version("m", std::nullopt, "");  // version 2: copies, some moved and deleted
  s.put_tile("m", 2, {0, 0}, fake_draco(1, 64), 10, 40, 40, 0, 41, 41, 1);
  s.delete_tile("m", 2, {-6, -6});
  auto all1 = s.list_tiles("m", 1);
  auto all2 = s.list_tiles("m", 2);
  ASSERT_GT(all1.size(), 100u);

  auto brute = [](const std::vector<TileRecord>& all, double x0, double y0, double x1, double y1) {
    std::vector<TileRecord> out;
    for (const auto& t : all)
      if (t.min_x <= x1 && t.max_x >= x0 && t.min_y <= y1 && t.max_y >= y0) out.push_back(t);
    return out;
  };
  auto same = [](const std::vector<TileRecord>& a, const std::vector<TileRecord>& b) {
    if (a.size() != b.size()) return false;
    for (std::size_t i = 0; i < a.size(); ++i)
      if (a[i].key != b[i].key || a[i].hash != b[i].hash || a[i].min_x != b[i].min_x || a[i].max_y != b[i].max_y)
        return false;
    return true;
  };

  std::vector<std::array<double, 4>> queries;
  std::uniform_real_distribution<double> c(-75.0, 65.0), w(0.0, 30.0);
  for (int i = 0; i < 300; ++i) {
    double x = c(rng), y = c(rng);
    queries.push_back({x, y, x + w(rng) * (i % 3), y + w(rng) * (i % 4)});  // includes points and lines
  }
  queries.push_back({-1e9, -1e9, 1e9, 1e9});
  queries.push_back({1000, 1000, 2000, 2000});
  // Rectangles that exactly touch a tile's edge from outside (closed boxes: they intersect).
  for (std::size_t i = 0; i < all1.size(); i += 17) {
    const auto& t = all1[i];
    queries.push_back({t.max_x, t.min_y, t.max_x + 3, t.max_y});
    queries.push_back({t.min_x - 3, t.max_y, t.min_x, t.max_y + 3});
    queries.push_back({t.min_x - 3, t.min_y - 3, std::nextafter(t.min_x, -1e9), t.max_y});  // just misses
  }
  std::size_t nonempty = 0;
  for (const auto& q : queries) {
    auto got1 = s.tiles_in_box("m", 1, q[0], q[1], q[2], q[3]);
    auto want1 = brute(all1, q[0], q[1], q[2], q[3]);
    EXPECT_TRUE(same(got1, want1)) << q[0] << " " << q[1] << " " << q[2] << " " << q[3] << ": " << got1.size() << " vs "
                                   << want1.size();
    auto got2 = s.tiles_in_box("m", 2, q[0], q[1], q[2], q[3]);
    EXPECT_TRUE(same(got2, brute(all2, q[0], q[1], q[2], q[3])));
    nonempty += !want1.empty();
  }
  EXPECT_GT(nonempty, queries.size() / 3);
  EXPECT_TRUE(s.tiles_in_box("m", 1, 10, 10, -10, -10).empty());  // inverted
  EXPECT_TRUE(s.tiles_in_box("m", 1, NAN, 0, 10, 10).empty());
  EXPECT_TRUE(s.tiles_in_box("m", 3, -1e9, -1e9, 1e9, 1e9).empty());  // no such version
}

TEST_P(StoreTest, SchemaRefusesTileWritesToPublishedVersions) {
  {
    Store s = Store::open(path);
    s.create_map("m", kOrigin, 10, 0.2);
    s.create_version("m", std::nullopt, "");
    put_cell(s, "m", 1, 0, 0, 1);
    s.publish("m", 1);
  }
  EXPECT_TRUE(contains(raw_exec("DELETE FROM tiles"), "staged"));
  EXPECT_TRUE(contains(raw_exec("UPDATE tiles SET points = 0"), "staged"));
  EXPECT_TRUE(contains(raw_exec("INSERT INTO tiles (map_id, version, tx, ty, hash, points, bytes, min_x, min_y, "
                                "min_z, max_x, max_y, max_z) SELECT map_id, version, 5, 5, hash, 1, 1, 0, 0, 0, 1, "
                                "1, 1 FROM tiles"),
                       "staged"));
  EXPECT_NE(raw_exec("UPDATE versions SET state = 'staged'"), "");
  EXPECT_NE(raw_exec("DELETE FROM blobs"), "");  // still used by a tile
  EXPECT_EQ(raw_scalar("SELECT count(*) FROM tiles"), 1);
}

}  // namespace
