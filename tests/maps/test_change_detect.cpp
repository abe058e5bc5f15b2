// Change candidates from reports: independent drives must agree; one drive, one vehicle's repeat
// within the hour, traffic that differs from drive to drive and reports of another version change
// nothing.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "pl/common/error.hpp"
#include "pl/maps/change_detect.hpp"
#include "change_reports.hpp"

namespace {

using pl::maps::ChangeRule;
using pl::maps::detect_changes;
using pl::schema::ChangeCell;
using pl::schema::ChangeReport;

// A report of one drive past tile (0, 0) (40 scans) with the given voxels.
ChangeReport report(const std::string& vehicle, const std::string& drive, double start, std::vector<ChangeCell> cells,
                    std::int64_t version = 2) {
  ChangeReport r = pl::test::drive_report("town", version, vehicle, drive, start);
  pl::schema::TileChangeEvidence t;
  t.key = {0, 0};
  t.scans = 40;
  t.cells = std::move(cells);
  r.tiles = {t};
  return r;
}

// A new container: 12 voxels on its face, each added in 8 scans and seen through in none.
std::vector<ChangeCell> container(int dx = 0) {
  std::vector<ChangeCell> out;
  for (int x = 10; x < 16; ++x)
    for (int z = 1; z < 3; ++z) out.push_back({x + dx, 8, z, 8, 0, 0, 0});
  return out;
}

// A truck driving by: voxels added in 3 scans each and seen through in 10 later ones, or (parked
// for the minute the drive took) added in 8 and never seen through; `lane` shifts it.
std::vector<ChangeCell> truck(int lane, bool parked) {
  std::vector<ChangeCell> out;
  for (int x = 2; x < 12; ++x)
    for (int z = 1; z < 4; ++z) out.push_back({x, 2 + lane, z, parked ? 8u : 3u, parked ? 0u : 10u, 0, 0});
  return out;
}

std::size_t candidates(const pl::maps::ChangeSummary& s) {
  std::size_t n = 0;
  for (const auto& t : s.tiles) n += t.candidate;
  return n;
}

const double kDay = 86400;

TEST(ChangeDetect, TwoIndependentDrivesAgreeingMakeACandidate) {
  const auto s = detect_changes({report("a", "a1", 0, container()), report("b", "b1", kDay, container(1))}, 2);
  ASSERT_EQ(s.tiles.size(), 1u);
  EXPECT_TRUE(s.tiles[0].candidate);
  EXPECT_EQ(s.tiles[0].passes.size(), 2u);
  EXPECT_EQ(s.tiles[0].added.size(), 14u) << "every voxel of each drive agrees with the other drive within a voxel";
  EXPECT_TRUE(s.tiles[0].removed.empty());
}

TEST(ChangeDetect, OneDriveOrOneVehicleWithinTheHourIsOnePass) {
  EXPECT_EQ(candidates(detect_changes({report("a", "a1", 0, container())}, 2)), 0u);
  const auto s = detect_changes({report("a", "a1", 0, container()), report("a", "a2", 600, container())}, 2);
  EXPECT_EQ(s.used, 1u);
  EXPECT_EQ(candidates(s), 0u);
  // The same vehicle a day later is another pass.
  EXPECT_EQ(candidates(detect_changes({report("a", "a1", 0, container()), report("a", "a2", kDay, container())}, 2)), 1u);
}

TEST(ChangeDetect, TrafficIsNoChange) {
  // Three drives, each with its own moving truck in another lane, and a truck parked for a minute
  // in one drive only: nothing agrees.
  const auto s = detect_changes({report("a", "a1", 0, truck(0, false)), report("b", "b1", kDay, truck(4, false)),
                                 report("c", "c1", 2 * kDay, truck(8, true))},
                                2);
  EXPECT_EQ(candidates(s), 0u);
  // The same truck seen moving in all three drives is seen through each time: still nothing.
  EXPECT_EQ(candidates(detect_changes({report("a", "a1", 0, truck(0, false)), report("b", "b1", kDay, truck(0, false)),
                                       report("c", "c1", 2 * kDay, truck(0, false))},
                                      2)),
            0u);
}

TEST(ChangeDetect, WhatManyScansOfAPassFoundStaysWhateverCrossedIt) {
  // A hedge grown half a metre up: its new top fills the lower part of 12 voxels, which 12 scans of
  // each pass found added, while rays to farther things crossed their empty upper part in 14.
  std::vector<ChangeCell> hedge, fewer;
  for (int x = 0; x < 12; ++x) {
    hedge.push_back({x, 6, 3, 12, 14, 0, 0});
    fewer.push_back({x, 6, 3, 11, 14, 0, 0});  // one scan short: crossed more than twice as often as found
  }
  EXPECT_EQ(candidates(detect_changes({report("a", "a1", 0, hedge), report("b", "b1", kDay, hedge)}, 2)), 1u);
  EXPECT_EQ(candidates(detect_changes({report("a", "a1", 0, fewer), report("b", "b1", kDay, fewer)}, 2)), 0u);
  ChangeRule strict;
  strict.added_stays = 13;
  EXPECT_EQ(candidates(detect_changes({report("a", "a1", 0, hedge), report("b", "b1", kDay, hedge)}, 2, strict)), 0u);
}

TEST(ChangeDetect, OnlyTheLastPassesCountAndOnlyTheVersionAsked) {
  // Changed in the two oldest of four passes, gone in the two newest (window 3): one of the last
  // three agrees, no candidate.
  const auto s = detect_changes({report("a", "a1", 0, container()), report("b", "b1", kDay, container()),
                                 report("c", "c1", 2 * kDay, {}), report("d", "d1", 3 * kDay, {})},
                                2);
  ASSERT_EQ(s.tiles.size(), 1u);
  EXPECT_EQ(s.tiles[0].passes.size(), 3u);
  EXPECT_FALSE(s.tiles[0].candidate);
  // Reports against version 1 do not count for version 2.
  const auto v = detect_changes({report("a", "a1", 0, container(), 1), report("b", "b1", kDay, container(), 1)}, 2);
  EXPECT_EQ(v.used, 0u);
  EXPECT_TRUE(v.tiles.empty());
}

TEST(ChangeDetect, RemovedNeedsPassesNotConfirmedByReturns) {
  std::vector<ChangeCell> gone, glass;
  for (int x = 0; x < 8; ++x) {
    gone.push_back({x, 5, 2, 0, 0, 0, 6});   // passed through in 6 scans, confirmed in none
    glass.push_back({x, 5, 2, 0, 0, 4, 6});  // passed in 6, and confirmed in 4: still there
  }
  EXPECT_EQ(candidates(detect_changes({report("a", "a1", 0, gone), report("b", "b1", kDay, gone)}, 2)), 1u);
  EXPECT_EQ(candidates(detect_changes({report("a", "a1", 0, glass), report("b", "b1", kDay, glass)}, 2)), 0u);
}

TEST(ChangeDetect, RefusesMixedReportsAndBadRules) {
  ChangeReport other = report("b", "b1", kDay, container());
  other.voxel_m = 0.25;
  EXPECT_THROW(detect_changes({report("a", "a1", 0, container()), other}, 2), pl::Error);
  ChangeRule rule;
  rule.window = 1;  // fewer passes judged than must agree
  EXPECT_THROW(detect_changes({}, 2, rule), pl::Error);
  rule = {};
  rule.added_stays = rule.added_min - 1;
  EXPECT_THROW(detect_changes({}, 2, rule), pl::Error);
  const std::string csv = pl::maps::change_summary_csv(detect_changes({report("a", "a1", 0, container()), report("b", "b1", kDay, container())}, 2));
  EXPECT_EQ(csv, "tx,ty,passes,agreed,added,removed,candidate,drives\n0,0,2,12,12,0,1,a/a1 b/b1\n");
}

}  // namespace
