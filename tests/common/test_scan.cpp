#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "pl/common/error.hpp"
#include "pl/common/meta.hpp"
#include "pl/common/scan.hpp"
#include "test_util.hpp"

namespace {

// A scan stored laser by laser, as KITTI stores them: each laser one counter-clockwise turn starting
// just left of straight ahead (0.3 deg). Azimuth jitter of 0.05 deg makes the sign flip back and forth near
// +-180 deg, as real data does (KITTI 00 frame 94 has it on 40 of its rings).
pl::Scan laser_by_laser(const std::vector<double>& angles_deg, std::vector<std::uint16_t>& truth, unsigned seed = 1) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> jitter(0.0, 0.05), range_noise(0.0, 0.3);
  pl::Scan scan;
  truth.clear();
  for (std::size_t ring = 0; ring < angles_deg.size(); ++ring) {
    double el = angles_deg[ring] * M_PI / 180.0;
    for (int k = 0; k < 1798; ++k) {  // 0.3 .. 359.7 deg
      if (k % 97 == 13) continue;  // dropouts
      double az_deg = 0.3 + 0.2 * k + jitter(rng);
      if (az_deg > 180.0) az_deg -= 360.0;
      double az = az_deg * M_PI / 180.0;
      double r = 8.0 + 4.0 * std::abs(std::sin(3 * az)) + range_noise(rng);
      scan.push_back({static_cast<float>(r * std::cos(el) * std::cos(az)), static_cast<float>(r * std::cos(el) * std::sin(az)),
                      static_cast<float>(r * std::sin(el)), static_cast<float>(ring)});
      truth.push_back(static_cast<std::uint16_t>(ring));
    }
  }
  return scan;
}

}  // namespace

TEST(Scan, RingsFromAzimuthWrapAreExact) {
  std::vector<std::uint16_t> truth;
  pl::Scan scan = laser_by_laser(pl::hdl64_vertical_angles_deg(), truth);
  auto rings = pl::rings_from_azimuth(scan);
  ASSERT_EQ(rings.size(), scan.size());
  std::size_t wrong = 0;
  for (std::size_t i = 0; i < rings.size(); ++i) wrong += rings[i] != truth[i];
  EXPECT_EQ(wrong, 0u);
  EXPECT_EQ(rings.back(), 63);
}

TEST(Scan, TrailingReturnPastStraightAheadStaysInLastRing) {
  std::vector<std::uint16_t> truth;
  pl::Scan scan = laser_by_laser(pl::hdl64_vertical_angles_deg(), truth);
  scan.push_back({10.0f, 0.001f, -3.0f, 0.0f});  // the last laser's final return at +0.006 deg
  auto rings = pl::rings_from_azimuth(scan);
  EXPECT_EQ(rings.back(), 63);
}

TEST(Scan, RingsFromElevationTable) {
  std::vector<double> angles = {15, 13, 11, 9, 7, 5, 3, 1, -1, -3, -5, -7, -9, -11, -13, -15};  // VLP-16 like
  std::vector<std::uint16_t> truth;
  pl::Scan scan = laser_by_laser(angles, truth);
  auto rings = pl::rings_from_elevation(scan, angles);
  for (std::size_t i = 0; i < rings.size(); ++i) ASSERT_EQ(rings[i], truth[i]) << i;
  EXPECT_THROW(pl::rings_from_elevation(scan, {}), pl::Error);
}

TEST(Scan, KeepEveryFourthRingKeepsAQuarter) {
  std::vector<std::uint16_t> truth;
  pl::Scan scan = laser_by_laser(pl::hdl64_vertical_angles_deg(), truth);
  std::vector<std::uint16_t> kept_rings;
  pl::Scan s16 = pl::keep_every_kth_ring(scan, truth, 4, 0, &kept_rings);
  EXPECT_NEAR(static_cast<double>(s16.size()) / scan.size(), 0.25, 0.001);
  ASSERT_EQ(kept_rings.size(), s16.size());
  EXPECT_EQ(kept_rings.front(), 0);
  EXPECT_EQ(kept_rings.back(), 15);
  for (const auto& p : s16) EXPECT_EQ(static_cast<int>(p.intensity) % 4, 0);  // intensity holds the true ring here
  EXPECT_THROW(pl::keep_every_kth_ring(scan, truth, 0), pl::Error);
  EXPECT_THROW(pl::keep_every_kth_ring(scan, {}, 4), pl::Error);
}

TEST(Scan, FovCropKeepsTheFrontHalf) {
  pl::Scan scan;
  for (int k = 0; k < 360; ++k) {
    double az = (k + 0.5) * M_PI / 180.0;
    scan.push_back({static_cast<float>(10 * std::cos(az)), static_cast<float>(10 * std::sin(az)), 0.f, 0.f});
  }
  pl::Scan front = pl::crop_fov(scan, 180.0);
  EXPECT_EQ(front.size(), 180u);
  for (const auto& p : front) EXPECT_GE(p.x, 0.0f);
  pl::Scan left = pl::crop_fov(scan, 90.0, 90.0);
  EXPECT_EQ(left.size(), 90u);
  for (const auto& p : left) EXPECT_GE(p.y, 0.0f);
  EXPECT_EQ(pl::crop_fov(scan, 360.0).size(), 360u);
}

TEST(Scan, RangeCrop) {
  pl::Scan scan = {{1, 0, 0, 0}, {3, 4, 0, 0}, {0, 0, 10, 0}, {60, 0, 0, 0}};
  pl::Scan kept = pl::crop_range(scan, 2.0, 50.0);
  ASSERT_EQ(kept.size(), 2u);
  EXPECT_EQ(kept[0].x, 3.0f);
  EXPECT_EQ(kept[1].z, 10.0f);
}

TEST(Scan, BinRoundTripAndBadSize) {
  pl::test::TempDir dir;
  pl::Scan scan = {{1.5f, -2.25f, 0.125f, 0.5f}, {100.f, 200.f, -3.f, 0.f}};
  pl::write_kitti_bin(dir / "000000.bin", scan);
  pl::Scan back = pl::read_kitti_bin(dir / "000000.bin");
  ASSERT_EQ(back.size(), 2u);
  EXPECT_EQ(back[0].y, -2.25f);
  EXPECT_EQ(back[1].x, 100.f);
  pl::test::write_file(dir / "000001.bin", std::string(20, '\0'));
  try {
    pl::read_kitti_bin(dir / "000001.bin");
    FAIL();
  } catch (const pl::Error& e) {
    EXPECT_NE(std::string(e.what()).find("16 bytes a point"), std::string::npos) << e.what();
  }
}

TEST(Scan, PrepareScanChainsTheSteps) {
  std::vector<std::uint16_t> truth;
  pl::Scan scan = laser_by_laser(pl::hdl64_vertical_angles_deg(), truth);
  pl::ScanPrepConfig cfg;
  cfg.beams = 16;
  cfg.fov_deg = 180.0;
  pl::Scan s = pl::prepare_scan(scan, truth, cfg);
  // A quarter of the beams, half of the turn.
  EXPECT_NEAR(static_cast<double>(s.size()) / scan.size(), 0.125, 0.005);
  for (const auto& p : s) {
    EXPECT_GE(p.x, 0.0f);
    EXPECT_EQ(static_cast<int>(p.intensity) % 4, 0);
  }
  cfg.voxel_m = 1.0;
  EXPECT_LT(pl::prepare_scan(scan, truth, cfg).size(), s.size() / 2);
  cfg.beams = 20;
  EXPECT_THROW(pl::prepare_scan(scan, truth, cfg), pl::Error);
}
