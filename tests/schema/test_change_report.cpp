// The change report's JSON: what a vehicle writes the service reads back exactly, and what the
// service must refuse it refuses with an error naming the field.
#include <gtest/gtest.h>

#include <string>

#include "pl/common/error.hpp"
#include "pl/schema/change_report.hpp"

namespace {

using pl::schema::ChangeCell;
using pl::schema::ChangeReport;
using pl::schema::parse_change_report;

ChangeReport sample() {
  ChangeReport r;
  r.map = "town";
  r.version = 4;
  r.vehicle = "vehicle-7";
  r.drive = "2026-12-06.7";
  r.start = 1796530000.25;
  r.end = 1796530084.5;
  r.voxel_m = 0.5;
  r.tile_m = 20.0;
  pl::schema::TileChangeEvidence a;
  a.key = {-1, 2};
  a.scans = 40;
  a.cells = {{-10, 81, 1, 5, 0, 0, 0}, {-10, 81, 2, 4, 1, 0, 0}, {-3, 90, -1, 0, 0, 2, 7}};
  // Samples of the added structure, in centimetres: in voxels (-10, 81, 1) and (-10, 81, 2).
  a.points = {{-480, 4060, 70}, {-460, 4090, 120}};
  pl::schema::TileChangeEvidence b;
  b.key = {0, 0};
  b.scans = 12;
  r.tiles = {a, b};
  return r;
}

// The text with `from` replaced by `to` (once; the test fails when `from` is not in it).
std::string edited(const std::string& text, const std::string& from, const std::string& to) {
  const auto at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  std::string out = text;
  if (at != std::string::npos) out.replace(at, from.size(), to);
  return out;
}

std::string error_of(const std::string& text) {
  try {
    parse_change_report(text);
  } catch (const pl::Error& e) {
    return e.what();
  }
  return "";
}

TEST(ChangeReport, ReadsBackWhatWasWritten) {
  const ChangeReport r = sample();
  const ChangeReport back = parse_change_report(pl::schema::change_report_json(r));
  EXPECT_EQ(back.map, r.map);
  EXPECT_EQ(back.version, r.version);
  EXPECT_EQ(back.vehicle, r.vehicle);
  EXPECT_EQ(back.drive, r.drive);
  EXPECT_DOUBLE_EQ(back.start, r.start);
  EXPECT_DOUBLE_EQ(back.end, r.end);
  EXPECT_DOUBLE_EQ(back.voxel_m, r.voxel_m);
  EXPECT_DOUBLE_EQ(back.tile_m, r.tile_m);
  ASSERT_EQ(back.tiles.size(), 2u);
  EXPECT_TRUE(back.tiles[0].key == r.tiles[0].key);
  EXPECT_EQ(back.tiles[0].scans, 40u);
  EXPECT_EQ(back.tiles[0].cells, r.tiles[0].cells);
  EXPECT_TRUE(back.tiles[1].cells.empty());
  EXPECT_EQ(back.tiles[0].points, r.tiles[0].points);
  EXPECT_TRUE(back.tiles[1].points.empty());
}

TEST(ChangeReport, SamplePointsLieInTheVoxelsReportedAdded) {
  const std::string good = pl::schema::change_report_json(sample());
  ASSERT_NE(good.find("\"points\":[-480,4060,70,-460,4090,120]"), std::string::npos) << good;
  // In voxel (-3, 90, -1), reported passed through, not added; outside every reported voxel; out of order; not triples.
  EXPECT_NE(error_of(edited(good, "-460,4090,120]", "-140,4510,-20]")).find("added > 0"), std::string::npos);
  EXPECT_NE(error_of(edited(good, "-460,4090,120]", "-460,4090,900]")).find("added > 0"), std::string::npos);
  EXPECT_NE(error_of(edited(good, "[-480,4060,70,-460", "[-460,4060,70,-480")).find("order"), std::string::npos);
  EXPECT_NE(error_of(edited(good, "-460,4090,120]", "-460,4090]")).find("3 integers"), std::string::npos);
  EXPECT_NE(error_of(edited(good, "-460,4090,120]", "-460,4090,1.5]")).find("integers"), std::string::npos);
  pl::schema::ChangeReportLimits small;
  small.max_points = 1;
  EXPECT_NE([&] {
    try {
      parse_change_report(good, small);
    } catch (const pl::Error& e) {
      return std::string(e.what());
    }
    return std::string();
  }().find("sample points"), std::string::npos);
  EXPECT_EQ(pl::schema::voxel_of_cm({-1, 49, 50}, 0.5), (std::array<std::int32_t, 3>{-1, 0, 1}));
}

TEST(ChangeReport, RefusesWhatIsWrongAndSaysWhat) {
  const std::string good = pl::schema::change_report_json(sample());
  ASSERT_EQ(error_of(good), "");
  EXPECT_NE(error_of("{\"format\": ").find("not JSON"), std::string::npos);
  EXPECT_NE(error_of("[1, 2]").find("not a JSON object"), std::string::npos);
  EXPECT_NE(error_of(edited(good, "\"format_version\":1", "\"format_version\":2")).find("format_version 2"), std::string::npos);
  EXPECT_NE(error_of(edited(good, "\"map\":\"town\"", "\"map\":\"../etc\"")).find("\"map\""), std::string::npos);
  EXPECT_NE(error_of(edited(good, "\"version\":4", "\"version\":0")).find("\"version\""), std::string::npos);
  EXPECT_NE(error_of(edited(good, "\"vehicle\":\"vehicle-7\"", "\"vehicle\":\"\"")).find("\"vehicle\""), std::string::npos);
  EXPECT_NE(error_of(edited(good, "\"drive\":\"2026-12-06.7\"", "\"drive\":\"a b\"")).find("\"drive\""), std::string::npos);
  EXPECT_NE(error_of(edited(good, "\"end\":1796530084.5", "\"end\":1.0")).find("before"), std::string::npos);
  EXPECT_NE(error_of(edited(good, "\"voxel_m\":0.5", "\"voxel_m\":0.0")).find("voxel_m"), std::string::npos);
  EXPECT_NE(error_of(edited(good, "\"tile_m\":20.0", "\"tile_m\":0.001")).find("tile_m"), std::string::npos);
  // Tiles out of order, a voxel outside its tile, voxels out of order, a count that is negative.
  EXPECT_NE(error_of(edited(good, "\"tx\":0,\"ty\":0", "\"tx\":-1,\"ty\":2")).find("key order"), std::string::npos);
  EXPECT_NE(error_of(edited(good, "[-10,81,1,5", "[-50,81,1,5")).find("outside its tile"), std::string::npos);
  EXPECT_NE(error_of(edited(good, "-10,81,2,4,1", "-10,80,2,4,1")).find("order"), std::string::npos);
  EXPECT_NE(error_of(edited(good, "-10,81,1,5,0", "-10,81,1,-5,0")).find("negative"), std::string::npos);
  EXPECT_NE(error_of(edited(good, "-3,90,-1,0,0,2,7]", "-3,90,-1,0,0,2]")).find("7 integers"), std::string::npos);
  EXPECT_NE(error_of(edited(good, "\"cells\":[-10", "\"cells\":[[[[-10")).find("nested"), std::string::npos);
}

TEST(ChangeReport, HoldsItsBounds) {
  const std::string good = pl::schema::change_report_json(sample());
  pl::schema::ChangeReportLimits small;
  small.max_bytes = good.size() - 1;
  EXPECT_THROW(parse_change_report(good, small), pl::Error);
  small = {};
  small.max_tiles = 1;
  EXPECT_THROW(parse_change_report(good, small), pl::Error);
  small = {};
  small.max_cells = 2;
  EXPECT_THROW(parse_change_report(good, small), pl::Error);
  small.max_cells = 3;
  EXPECT_NO_THROW(parse_change_report(good, small));
}

}  // namespace
