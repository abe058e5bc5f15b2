// Map updates from change reports, on a real SQLite store: a street with a parked car tiled into a
// store, then two drives' reports that the car is gone and a container stands where there was
// none. Only the two tiles they agree on are rebuilt; every other keeps its stored bytes; pl-map
// diff says why; one drive, or reports of another version, change nothing.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "pl/common/error.hpp"
#include "pl/common/tile_codec.hpp"
#include "pl/maps/catalog.hpp"
#include "pl/maps/import.hpp"
#include "pl/maps/map_update.hpp"
#include "pl/schema/change_report.hpp"
#include "change_reports.hpp"
#include "error_of.hpp"
#include "test_util.hpp"

namespace {

using pl::maps::MapUpdateConfig;
using pl::maps::update_map;
using pl::schema::ChangeCell;
using pl::schema::ChangeReport;
using pl::store::Store;

// The car: a raised body (a van's) 0.6 to 1.5 m up, over x 25..29, y 5..7 (tile (1, 0)).
constexpr double kCarX0 = 25, kCarX1 = 29, kCarY0 = 5, kCarY1 = 7, kCarZ0 = 0.6, kCarZ1 = 1.5;

// Ground over 60 x 40 m (tiles (0..2, 0..1) of 20 m) every 0.2 m, and the car's faces.
pl::Cloud street() {
  pl::Cloud c;
  for (double x = 0.1; x < 60; x += 0.2)
    for (double y = 0.1; y < 40; y += 0.2) c.points.emplace_back(x, y, 0.0);
  for (double x = kCarX0; x <= kCarX1 + 1e-9; x += 0.2)
    for (double z = kCarZ0; z <= kCarZ1 + 1e-9; z += 0.2) {
      c.points.emplace_back(x, kCarY0, z);
      c.points.emplace_back(x, kCarY1, z);
    }
  for (double x = kCarX0; x <= kCarX1 + 1e-9; x += 0.2)
    for (double y = kCarY0; y <= kCarY1 + 1e-9; y += 0.2) c.points.emplace_back(x, y, kCarZ1);
  c.intensity.assign(c.points.size(), 0.3f);
  return c;
}

// One drive's report: tile (1, 0) with the car's voxels passed through, tile (2, 0) with a
// container's face at y = 10, x 45..48, z 0..2 added (and its sample every 0.2 m), the others seen
// with nothing changed.
ChangeReport drive(const std::string& vehicle, const std::string& id, double start, std::int64_t version = 1) {
  ChangeReport r = pl::test::drive_report("street", version, vehicle, id, start, 30);
  pl::schema::TileChangeEvidence seen0, car, box, seen1;
  seen0.key = {0, 0};
  car.key = {1, 0};
  box.key = {2, 0};
  seen1.key = {0, 1};
  for (auto* t : {&seen0, &car, &box, &seen1}) t->scans = 20;
  // The car's 0.5 m cells and one more all round: its faces lie on cell edges, where the tiles'
  // quantization (up to 20 mm) puts their points on either side.
  for (int x = 49; x < 59; ++x)
    for (int y = 9; y < 15; ++y)
      for (int z = 1; z < 4; ++z) car.cells.push_back({x, y, z, 0, 0, 0, 6});
  for (int x = 90; x < 96; ++x)
    for (int z = 0; z < 4; ++z) box.cells.push_back({x, 20, z, 8, 0, 0, 0});
  for (int x = 4500; x < 4800; x += 20)
    for (int z = 10; z < 200; z += 20) box.points.push_back({x, 1002, z});
  r.tiles = {seen0, seen1, car, box};
  std::sort(r.tiles.begin(), r.tiles.end(), [](const auto& a, const auto& b) { return a.key < b.key; });
  return r;
}

// The street, tiled with normals and intensity stored (as maps were before 2026-12-08), or with
// positions only (pl-map tile's default).
struct Street {
  pl::test::TempDir dir;
  std::string db = dir / "maps.sqlite";
  explicit Street(bool attributes = true) {
    pl::maps::ImportConfig cfg;
    cfg.origin = pl::GeoPoint{48.0, 11.0, 500.0};
    if (attributes) cfg.codec.normal_bits = 6, cfg.codec.intensity_bits = 4;
    pl::maps::import_cloud(db, "street", street(), "street", cfg);
    Store s = Store::open(db, false);
    s.publish("street", 1);
  }
};

TEST(MapUpdate, RebuildsOnlyTheTilesDrivesAgreeOnAndKeepsTheOthersBytes) {
  Street st;
  Store s = Store::open(st.db, false);
  const auto r = update_map(s, "street", {drive("v1", "a", 1000), drive("v2", "b", 90000)});
  ASSERT_TRUE(r.version.has_value());
  EXPECT_EQ(r.parent, 1);
  EXPECT_EQ(r.version->state, pl::store::VersionState::Staged);
  ASSERT_EQ(r.tiles.size(), 2u);
  EXPECT_TRUE(r.tiles[0].key == (pl::TileKey{1, 0}));
  EXPECT_TRUE(r.tiles[1].key == (pl::TileKey{2, 0}));
  EXPECT_GT(r.tiles[0].removed, 100u);
  EXPECT_EQ(r.tiles[0].added, 0u);
  EXPECT_EQ(r.tiles[1].removed, 0u);
  EXPECT_GT(r.tiles[1].added, 100u);

  // Every other tile is the same stored blob.
  const auto v1 = s.list_tiles("street", 1), v2 = s.list_tiles("street", r.version->number);
  ASSERT_EQ(v1.size(), v2.size());
  std::size_t same = 0;
  for (std::size_t i = 0; i < v1.size(); ++i) same += v1[i].hash == v2[i].hash;
  EXPECT_EQ(same, v1.size() - 2);
  EXPECT_EQ(r.unchanged, v1.size() - 2);

  // The car is gone and the ground under and round it kept; the container's face is there, facing +-y.
  const pl::TileCloud car = pl::decode_tile(*s.blob(s.find_tile("street", 2, {1, 0})->hash));
  std::size_t body = 0, ground = 0;
  for (const auto& p : car.points) {
    const bool over = p.x() > kCarX0 - 0.3 && p.x() < kCarX1 + 0.3 && p.y() > kCarY0 - 0.3 && p.y() < kCarY1 + 0.3;
    body += over && p.z() > 0.4;
    ground += std::abs(p.z()) < 0.05;
  }
  EXPECT_EQ(body, 0u);
  EXPECT_EQ(ground, 100u * 100u);  // the tile's 20 x 20 m of ground at 0.2 m
  const pl::TileCloud box = pl::decode_tile(*s.blob(s.find_tile("street", 2, {2, 0})->hash));
  std::size_t face = 0, facing = 0;
  for (std::size_t i = 0; i < box.size(); ++i) {
    const auto& p = box.points[i];
    if (p.z() < 0.05) continue;
    face += std::abs(p.y() - 10.02) < 0.05 && p.x() > 44.9 && p.x() < 48.1;
    facing += std::abs(box.normals[i].y()) > 0.9;
  }
  EXPECT_GE(face, 100u);
  EXPECT_EQ(face, box.size() - 100u * 100u);
  EXPECT_GE(facing * 10, face * 8) << "the normals of the added points: the face's, but where the ground is near";
  ASSERT_EQ(box.intensity.size(), box.size());

  // The diff names the two tiles and why; the log holds the update.
  const auto d = pl::maps::diff_versions(s, "street", 1, 2);
  EXPECT_EQ(d.changed, 2u);
  EXPECT_NE(d.text.find("~ 1 0  (v2 update: -"), std::string::npos) << d.text;
  EXPECT_NE(d.text.find("voxels passed through"), std::string::npos) << d.text;
  EXPECT_NE(d.text.find("~ 2 0  (v2 update: -0 points in 0 voxels passed through, +"), std::string::npos) << d.text;
  EXPECT_NE(d.text.find("v1/a v2/b"), std::string::npos) << d.text;
  EXPECT_EQ(pl::maps::update_reasons(s, "street", 2).size(), 2u);
  EXPECT_TRUE(pl::maps::update_reasons(s, "street", 1).empty());
}

TEST(MapUpdate, OneDriveOrAnotherVersionsReportsStageNothing) {
  Street st;
  Store s = Store::open(st.db, false);
  // One drive; one vehicle's two drives within the hour (one pass); two drives against another version.
  EXPECT_FALSE(update_map(s, "street", {drive("v1", "a", 1000)}).version);
  EXPECT_FALSE(update_map(s, "street", {drive("v1", "a", 1000), drive("v1", "b", 1600)}).version);
  const auto other = update_map(s, "street", {drive("v1", "a", 1000, 7), drive("v2", "b", 90000, 7)});
  EXPECT_FALSE(other.version);
  EXPECT_EQ(other.summary.used, 0u);
  EXPECT_EQ(s.list_versions("street").size(), 1u);
  // Two drives do, with a rule asking for three they do not.
  MapUpdateConfig three;
  three.rule.min_drives = 3;
  EXPECT_FALSE(update_map(s, "street", {drive("v1", "a", 1000), drive("v2", "b", 90000)}, three).version);
  EXPECT_TRUE(update_map(s, "street", {drive("v1", "a", 1000), drive("v2", "b", 90000)}).version);
}

// A rebuilt tile keeps the attributes its parent has: none beside the positions here.
TEST(MapUpdate, TilesOfPositionsOnlyStaySo) {
  Street st(false);
  Store s = Store::open(st.db, false);
  const auto r = update_map(s, "street", {drive("v1", "a", 1000), drive("v2", "b", 90000)});
  ASSERT_TRUE(r.version.has_value());
  ASSERT_EQ(r.tiles.size(), 2u);
  for (const auto& t : r.tiles) {
    const pl::TileCloud c = pl::decode_tile(*s.blob(s.find_tile("street", r.version->number, t.key)->hash));
    EXPECT_GE(c.size(), 100u * 100u);  // the ground at least
    EXPECT_TRUE(c.normals.empty());
    EXPECT_TRUE(c.intensity.empty());
  }
}

TEST(MapUpdate, RefusesWhatItCannotUpdate) {
  Street st;
  Store s = Store::open(st.db, false);
  const std::vector<ChangeReport> two = {drive("v1", "a", 1000), drive("v2", "b", 90000)};
  EXPECT_NE(pl::test::error_of([&] { update_map(s, "nowhere", two); }).find("no map named"), std::string::npos);
  auto grid = two;
  for (auto& r : grid) r.tile_m = 30;
  EXPECT_NE(pl::test::error_of([&] { update_map(s, "street", grid); }).find("30"), std::string::npos);
  // A map with nothing published yet.
  pl::maps::ImportConfig cfg;
  cfg.origin = pl::GeoPoint{48.0, 11.0, 500.0};
  pl::maps::import_cloud(st.db, "draft", street(), "street", cfg);
  EXPECT_NE(pl::test::error_of([&] { update_map(s, "draft", two); }).find("no published version"), std::string::npos);
  EXPECT_EQ(s.list_versions("street").size(), 1u);
}

TEST(MapUpdate, PlMapUpdateTakesTheStoresReportsAndDiffSaysWhy) {
  Street st;
  {
    Store s = Store::open(st.db, false);
    for (const auto& r : {drive("v1", "a", 1000), drive("v2", "b", 90000)})
      ASSERT_EQ(s.put_report("street", 1, r.vehicle, r.drive, r.start, r.end, pl::schema::change_report_json(r), "test"),
                Store::ReportPut::Stored);
  }
  const std::string pl_map = pl::test::tool("pl-map");
  // One drive's file alone: nothing.
  pl::test::write_file(st.dir / "a.json", pl::schema::change_report_json(drive("v1", "a", 1000)));
  auto one = pl::test::run(pl_map + " update --db " + st.db + " --map street --reports " + (st.dir / "a.json"));
  ASSERT_EQ(one.exit_code, 0) << one.output;
  EXPECT_NE(one.output.find("nothing to update"), std::string::npos) << one.output;
  // The store's two: a version, published.
  auto up = pl::test::run(pl_map + " update --db " + st.db + " --map street --publish");
  ASSERT_EQ(up.exit_code, 0) << up.output;
  EXPECT_NE(up.output.find("2 reports, 2 independent passes against v1; 2 change candidates"), std::string::npos) << up.output;
  EXPECT_NE(up.output.find("version 2 staged (parent v1): 2 tiles rebuilt"), std::string::npos) << up.output;
  EXPECT_NE(up.output.find("version 2 is current"), std::string::npos) << up.output;
  auto diff = pl::test::run(pl_map + " diff --db " + st.db + " --map street --from 1 --to 2");
  ASSERT_EQ(diff.exit_code, 0) << diff.output;
  EXPECT_NE(diff.output.find("~ 1 0  (v2 update: -"), std::string::npos) << diff.output;
  EXPECT_NE(diff.output.find("2 changed"), std::string::npos) << diff.output;
  // A map that does not exist: said, nothing written.
  auto bad = pl::test::run(pl_map + " update --db " + st.db + " --map nowhere");
  EXPECT_NE(bad.exit_code, 0);
  EXPECT_NE(bad.output.find("no map named"), std::string::npos) << bad.output;
}

}  // namespace
