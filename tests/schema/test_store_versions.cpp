// The map store's maps and versions: names and parameters, a version's life from staged to retired,
// totals and parents, rollbacks, and unknown maps and versions.
#include <gtest/gtest.h>

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "pl/common/error.hpp"
#include "pl/schema/store.hpp"
#include "error_of.hpp"
#include "store_fixture.hpp"
#include "store_test_util.hpp"

namespace {

using pl::store::Store;
using pl::store::VersionState;
using pl::test::contains;
using pl::test::error_of;
using pl::test::is_utc_iso8601;
using pl::test::kOrigin;
using pl::test::put_cell;
using pl::test::StoreTest;

// ---- maps ----------------------------------------------------------------------------------------

TEST_P(StoreTest, CreatesFindsAndListsMaps) {
  Store s = Store::open(path);
  auto b = s.create_map("b-map", kOrigin, 25.0, 0.1);
  auto a = s.create_map("a.map_1", {-33.9, 151.2, 3.0}, 20.0, 0.2);
  EXPECT_GT(a.id, 0);
  EXPECT_NE(a.id, b.id);
  EXPECT_EQ(b.name, "b-map");
  EXPECT_DOUBLE_EQ(b.tile_size, 25.0);
  EXPECT_DOUBLE_EQ(b.voxel_size, 0.1);
  EXPECT_FALSE(b.current);
  EXPECT_TRUE(is_utc_iso8601(b.created)) << b.created;

  auto found = s.find_map("b-map");
  ASSERT_TRUE(found);
  EXPECT_EQ(found->id, b.id);
  EXPECT_EQ(found->created, b.created);
  EXPECT_FALSE(s.find_map("nope"));
  EXPECT_FALSE(s.find_map("bad name"));

  auto all = s.list_maps();
  ASSERT_EQ(all.size(), 2u);
  EXPECT_EQ(all[0].name, "a.map_1");  // by name
  EXPECT_EQ(all[1].name, "b-map");
}

TEST_P(StoreTest, ValidatesMapNamesAndParameters) {
  Store s = Store::open(path);
  std::string longest(64, 'x');
  EXPECT_NO_THROW(s.create_map(longest, kOrigin, 20, 0.2));
  EXPECT_NO_THROW(s.create_map("Az09_.-", kOrigin, 20, 0.2));
  for (std::string bad :
       {std::string(), std::string(65, 'x'), std::string("has space"), std::string("a/b"), std::string("semi;colon"),
        std::string("quote'"), std::string("tab\t"), std::string("m\xc3\xbcnchen"), std::string("nul\0x", 5)}) {
    std::string msg = error_of([&] { s.create_map(bad, kOrigin, 20, 0.2); });
    EXPECT_TRUE(contains(msg, "invalid map name")) << "[" << bad << "] " << msg;
  }
  EXPECT_TRUE(contains(error_of([&] { s.create_map("m", {91, 0, 0}, 20, 0.2); }), "origin"));
  EXPECT_TRUE(contains(error_of([&] { s.create_map("m", {0, -181, 0}, 20, 0.2); }), "origin"));
  EXPECT_TRUE(contains(error_of([&] { s.create_map("m", kOrigin, 0, 0.2); }), "sizes"));
  EXPECT_TRUE(contains(error_of([&] { s.create_map("m", kOrigin, 20, -1); }), "sizes"));
  EXPECT_EQ(s.list_maps().size(), 2u);
}

TEST_P(StoreTest, RefusesADuplicateMapName) {
  Store s = Store::open(path);
  s.create_map("city", kOrigin, 20, 0.2);
  std::string msg = error_of([&] { s.create_map("city", kOrigin, 30, 0.3); });
  EXPECT_TRUE(contains(msg, "city")) << msg;
  EXPECT_TRUE(contains(msg, "already exists")) << msg;
  EXPECT_DOUBLE_EQ(s.find_map("city")->tile_size, 20);
}

// ---- versions ------------------------------------------------------------------------------------

TEST_P(StoreTest, VersionLifecycle) {
  Store s = Store::open(path);
  s.create_map("m", kOrigin, 10, 0.2);

  auto v1 = s.create_version("m", std::nullopt, "first survey");
  EXPECT_EQ(v1.number, 1);
  EXPECT_FALSE(v1.parent);
  EXPECT_EQ(v1.state, VersionState::Staged);
  EXPECT_EQ(v1.note, "first survey");
  EXPECT_EQ(v1.tiles, 0);
  EXPECT_TRUE(is_utc_iso8601(v1.created));
  put_cell(s, "m", 1, 0, 0, 1);
  put_cell(s, "m", 1, 1, 0, 2);
  put_cell(s, "m", 1, -1, -1, 3);
  EXPECT_FALSE(s.find_map("m")->current);  // staged: not current
  s.publish("m", 1);
  EXPECT_EQ(s.find_map("m")->current, 1);
  EXPECT_EQ(s.find_version("m", 1)->state, VersionState::Published);

  // A new version starts as a staged copy of the current one.
  auto v2 = s.create_version("m", std::nullopt, "second");
  EXPECT_EQ(v2.number, 2);
  EXPECT_EQ(v2.parent, 1);
  EXPECT_EQ(v2.state, VersionState::Staged);
  EXPECT_EQ(v2.tiles, 3);
  auto t1 = s.list_tiles("m", 1), t2 = s.list_tiles("m", 2);
  ASSERT_EQ(t1.size(), t2.size());
  for (std::size_t i = 0; i < t1.size(); ++i) {
    EXPECT_EQ(t1[i].key, t2[i].key);
    EXPECT_EQ(t1[i].hash, t2[i].hash);
    EXPECT_EQ(t1[i].points, t2[i].points);
    EXPECT_DOUBLE_EQ(t1[i].max_y, t2[i].max_y);
  }
  put_cell(s, "m", 2, 5, 5, 4);
  EXPECT_TRUE(s.delete_tile("m", 2, {0, 0}));
  EXPECT_EQ(s.find_map("m")->current, 1);  // still 1 until published
  EXPECT_EQ(s.list_tiles("m", 1).size(), 3u);
  EXPECT_FALSE(s.find_tile("m", 1, {5, 5}));  // staged tiles only through their version

  s.publish("m", 2);
  EXPECT_EQ(s.find_map("m")->current, 2);
  EXPECT_EQ(s.find_version("m", 1)->state, VersionState::Retired);
  EXPECT_EQ(s.find_version("m", 2)->state, VersionState::Published);

  // Published and retired versions are read-only; publishing them again is refused.
  for (std::int64_t v : {1, 2}) {
    std::string state = v == 1 ? "retired" : "published";
    std::string msg = error_of([&] { put_cell(s, "m", v, 9, 9, 5); });
    EXPECT_TRUE(contains(msg, "version " + std::to_string(v))) << msg;
    EXPECT_TRUE(contains(msg, state)) << msg;
    msg = error_of([&] { s.delete_tile("m", v, {1, 0}); });
    EXPECT_TRUE(contains(msg, state)) << msg;
    msg = error_of([&] { s.publish("m", v); });
    EXPECT_TRUE(contains(msg, "version " + std::to_string(v) + " is " + state)) << msg;
  }
  EXPECT_EQ(s.list_tiles("m", 1).size(), 3u);

  auto versions = s.list_versions("m");
  ASSERT_EQ(versions.size(), 2u);
  EXPECT_EQ(versions[0].number, 1);
  EXPECT_EQ(versions[1].number, 2);
  EXPECT_EQ(versions[1].tiles, 3);
}

TEST_P(StoreTest, VersionTotalsAndExplicitParent) {
  Store s = Store::open(path);
  s.create_map("m", kOrigin, 10, 0.2);
  s.create_version("m", std::nullopt, "");
  auto a = put_cell(s, "m", 1, 0, 0, 1, 300);
  auto b = put_cell(s, "m", 1, 0, 1, 2, 500);
  auto v = s.find_version("m", 1);
  ASSERT_TRUE(v);
  EXPECT_EQ(v->tiles, 2);
  EXPECT_EQ(v->points, a.points + b.points);
  EXPECT_EQ(v->bytes, 800);

  // Before any publish, an empty parent means an empty version; an explicit one is copied.
  auto v2 = s.create_version("m", std::nullopt, "empty");
  EXPECT_FALSE(v2.parent);
  EXPECT_EQ(v2.tiles, 0);
  auto v3 = s.create_version("m", 1, "from staged 1");
  EXPECT_EQ(v3.number, 3);
  EXPECT_EQ(v3.parent, 1);
  EXPECT_EQ(v3.tiles, 2);
  std::string msg = error_of([&] { s.create_version("m", 7, ""); });
  EXPECT_TRUE(contains(msg, "no version 7")) << msg;
  EXPECT_EQ(s.list_versions("m").size(), 3u);
}

// A rollback publishes a new version holding an older one's content: the current number only grows
// (vehicles refuse a lower one than they have verified), and repeated rollbacks walk back through
// the content history, never to a version that was rolled back.
TEST_P(StoreTest, RollbacksAreNewVersionsThatWalkBackThroughTheHistory) {
  Store s = Store::open(path);
  s.create_map("m", kOrigin, 10, 0.2);
  EXPECT_TRUE(contains(error_of([&] { s.rollback("m"); }), "no published version"));
  for (int i = 1; i <= 3; ++i) {
    s.create_version("m", std::nullopt, "v" + std::to_string(i));
    put_cell(s, "m", i, i, 0, static_cast<std::uint32_t>(i));
    s.put_places("m", i, "places of v" + std::to_string(i));
    s.publish("m", i);
  }
  EXPECT_EQ(s.create_version("m", std::nullopt, "staged, never published").number, 4);
  auto hashes = [&](std::int64_t v) {
    std::vector<std::string> out;
    for (const auto& t : s.list_tiles("m", v)) out.push_back(std::to_string(t.key.tx) + ":" + t.hash);
    return out;
  };
  EXPECT_EQ(s.find_map("m")->current, 3);
  EXPECT_EQ(s.rollback_target("m"), 2);
  const auto blobs_before = s.list_tiles("m", 2).size();
  EXPECT_EQ(s.rollback("m"), 5);  // 4 is the staged version above: a rollback takes the next number
  EXPECT_EQ(s.find_map("m")->current, 5);
  const auto v5 = s.find_version("m", 5);
  EXPECT_EQ(v5->state, VersionState::Published);
  EXPECT_EQ(v5->parent, 2);
  EXPECT_TRUE(contains(v5->note, "rollback of v3")) << v5->note;
  EXPECT_EQ(hashes(5), hashes(2));
  EXPECT_EQ(s.list_tiles("m", 2).size(), blobs_before);
  EXPECT_EQ(s.places("m", 5), "places of v2");
  EXPECT_EQ(s.find_version("m", 3)->state, VersionState::Retired);
  EXPECT_EQ(s.find_version("m", 2)->state, VersionState::Retired);  // never published again
  EXPECT_EQ(s.find_version("m", 4)->state, VersionState::Staged);

  // A new publish after the rollback: rolling back goes to 5's content (2's), then to 1's, never to 3's.
  s.create_version("m", std::nullopt, "v6");
  EXPECT_EQ(s.find_version("m", 6)->parent, 5);
  put_cell(s, "m", 6, 6, 0, 6);
  s.publish("m", 6);
  EXPECT_EQ(s.rollback("m"), 7);
  EXPECT_EQ(s.find_version("m", 7)->parent, 5);
  EXPECT_EQ(hashes(7), hashes(2));
  EXPECT_EQ(s.rollback("m"), 8);
  EXPECT_EQ(s.find_version("m", 8)->parent, 1);
  EXPECT_EQ(hashes(8), hashes(1));
  EXPECT_EQ(s.find_map("m")->current, 8);
  std::string msg = error_of([&] { s.rollback("m"); });
  EXPECT_TRUE(contains(msg, "first version published")) << msg;
  EXPECT_EQ(s.find_map("m")->current, 8);
  EXPECT_EQ(s.list_versions("m").size(), 8u);  // the refused rollback left no version behind

  int published = 0;
  for (const auto& v : s.list_versions("m")) published += v.state == VersionState::Published;
  EXPECT_EQ(published, 1);
  EXPECT_TRUE(s.integrity_ok());
}

// What runs before the copy is published runs in the rollback's transaction: when it throws,
// nothing of the rollback is left.
TEST_P(StoreTest, ARollbackWhoseSigningFailsLeavesNothing) {
  Store s = Store::open(path);
  s.create_map("m", kOrigin, 10, 0.2);
  for (int i = 1; i <= 2; ++i) {
    s.create_version("m", std::nullopt, "");
    put_cell(s, "m", i, i, 0, static_cast<std::uint32_t>(i));
    s.publish("m", i);
  }
  std::int64_t seen = 0;
  const std::string msg = error_of([&] {
    s.rollback("m", [&](std::int64_t staged) {
      seen = staged;
      EXPECT_EQ(s.find_version("m", staged)->state, VersionState::Staged);
      throw pl::Error("no key");
    });
  });
  EXPECT_TRUE(contains(msg, "no key")) << msg;
  EXPECT_EQ(seen, 3);
  EXPECT_EQ(s.find_map("m")->current, 2);
  EXPECT_EQ(s.list_versions("m").size(), 2u);
  EXPECT_EQ(s.rollback("m"), 3);
}

TEST_P(StoreTest, UnknownMapsAndVersions) {
  Store s = Store::open(path);
  EXPECT_FALSE(s.find_map("ghost"));
  EXPECT_FALSE(s.find_version("ghost", 1));
  EXPECT_TRUE(s.list_versions("ghost").empty());
  EXPECT_FALSE(s.find_tile("ghost", 1, {0, 0}));
  EXPECT_TRUE(s.list_tiles("ghost", 1).empty());
  EXPECT_TRUE(s.tiles_in_box("ghost", 1, -1e9, -1e9, 1e9, 1e9).empty());
  EXPECT_TRUE(s.upload_log("ghost").empty());
  for (auto& msg :
       {error_of([&] { s.create_version("ghost", std::nullopt, ""); }), error_of([&] { s.publish("ghost", 1); }),
        error_of([&] { s.rollback("ghost"); }), error_of([&] { put_cell(s, "ghost", 1, 0, 0, 1); }), error_of([&] {
          s.delete_tile("ghost", 1, {0, 0});
        })}) {
    EXPECT_TRUE(contains(msg, "unknown map ghost")) << msg;
    EXPECT_TRUE(contains(msg, path)) << msg;
  }
  EXPECT_FALSE(s.places("ghost", 1));
  EXPECT_FALSE(s.places_hash("ghost", 1));
  for (auto& msg : {error_of([&] { s.put_places("ghost", 1, "p"); }), error_of([&] { s.delete_places("ghost", 1); })}) {
    EXPECT_TRUE(contains(msg, "unknown map ghost")) << msg;
    EXPECT_TRUE(contains(msg, path)) << msg;
  }
  s.create_map("m", kOrigin, 10, 0.2);
  EXPECT_FALSE(s.find_version("m", 1));
  EXPECT_TRUE(contains(error_of([&] { s.publish("m", 1); }), "no version 1"));
  EXPECT_TRUE(contains(error_of([&] { put_cell(s, "m", 1, 0, 0, 1); }), "no version 1"));
  EXPECT_FALSE(s.places("m", 1));
  EXPECT_FALSE(s.places_hash("m", 1));
  EXPECT_TRUE(contains(error_of([&] { s.put_places("m", 1, "p"); }), "map m has no version 1"));
  EXPECT_TRUE(contains(error_of([&] { s.delete_places("m", 1); }), "map m has no version 1"));
}

}  // namespace
