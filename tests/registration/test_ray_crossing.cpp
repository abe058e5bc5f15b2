// The ray-crossing rule on exact surfaces: a wall a ray passes through, a return just behind its own
// surface, a ray grazing the ground, a ray passing beside a wall's end, and the probe's say over the walk.
#include <gtest/gtest.h>

#include <Eigen/Core>

#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "pl/common/error.hpp"
#include "pl/registration/ray_crossing.hpp"

namespace {

using pl::registration::CellBlock;
using pl::registration::MapPoint;
using pl::registration::PointMap;
using pl::registration::RayCrossingConfig;
using pl::registration::walk_ray;

// A wall x = 10 (normal +x), y within [-2, 2], z within [0, 3], and the ground z = 0 for x within
// [-5, 30], y within [-10, 10], sampled every 0.2 m; far from the origin to keep the anchor honest.
const Eigen::Vector3d kOrigin(4.0e5, 5.0e6, 30.0);

std::unique_ptr<PointMap> scene(bool wall, bool ground) {
  std::vector<Eigen::Vector3d> p;
  std::vector<Eigen::Vector3f> n;
  if (wall)
    for (double y = -1.9; y < 2.0; y += 0.2)
      for (double z = 0.1; z < 3.0; z += 0.2) {
        p.push_back(kOrigin + Eigen::Vector3d(10.0, y, z));
        n.emplace_back(1, 0, 0);
      }
  if (ground)
    for (double x = -4.9; x < 30; x += 0.2)
      for (double y = -9.9; y < 10; y += 0.2) {
        p.push_back(kOrigin + Eigen::Vector3d(x, y, 0.0));
        n.emplace_back(0, 0, 1);
      }
  auto map = std::make_unique<PointMap>(kOrigin, 0.7);
  map->add(1, p, n);
  return map;
}

// The map points a ray from `from` to `to` (relative to kOrigin) crosses, one entry per report.
std::vector<Eigen::Vector3d> crossings(const PointMap& map, const Eigen::Vector3d& from, const Eigen::Vector3d& to,
                                       const RayCrossingConfig& cfg = {}) {
  std::vector<Eigen::Vector3d> out;
  CellBlock block;
  walk_ray(map, kOrigin + from, kOrigin + to, cfg, block, [&](const MapPoint&, const Eigen::Vector3d& at) { out.push_back(at - kOrigin); });
  return out;
}

TEST(RayCrossing, ARayThroughAWallCrossesItNearWhereItPasses) {
  const auto map = scene(true, false);
  const auto hits = crossings(*map, {0, 0.05, 1.5}, {20, 0.05, 1.5});
  ASSERT_FALSE(hits.empty());
  for (const Eigen::Vector3d& h : hits) {
    EXPECT_NEAR(h.x(), 10.0, 1e-4);
    EXPECT_LT((h - Eigen::Vector3d(10, 0.05, 1.5)).norm(), 0.15);
  }
  // At 45 degrees (|cos| 0.71) it still counts; at 70 degrees (|cos| 0.34 < 0.4) it does not.
  EXPECT_FALSE(crossings(*map, {0, -10, 1.5}, {20, 10, 1.5}).empty());
  const double t = std::tan(70.0 * M_PI / 180.0);
  EXPECT_TRUE(crossings(*map, {8, -2 * t, 1.5}, {12, 2 * t, 1.5}).empty());
}

TEST(RayCrossing, AReturnWithinTheMarginBehindItsSurfaceCrossesNothing) {
  const auto map = scene(true, false);
  EXPECT_TRUE(crossings(*map, {0, 0.05, 1.5}, {10.9, 0.05, 1.5}).empty());  // 0.9 m behind: within the 1 m margin
  EXPECT_TRUE(crossings(*map, {0, 0.05, 1.5}, {10.0, 0.05, 1.5}).empty());  // on the wall
  EXPECT_TRUE(crossings(*map, {0, 0.05, 1.5}, {8.0, 0.05, 1.5}).empty());   // short of it
  EXPECT_FALSE(crossings(*map, {0, 0.05, 1.5}, {11.2, 0.05, 1.5}).empty());
  RayCrossingConfig wide;
  wide.margin_m = 1.5;
  EXPECT_TRUE(crossings(*map, {0, 0.05, 1.5}, {11.2, 0.05, 1.5}, wide).empty());
}

TEST(RayCrossing, AGrazingRayAndARayBesideAnEdgeCrossNothing) {
  const auto ground = scene(false, true);
  // From 1.7 m up to a return 0.1 m below the ground 25 m away: |cos| 0.07 with the ground's normal.
  EXPECT_TRUE(crossings(*ground, {0, 0, 1.7}, {25, 0, -0.1}).empty());
  // Steeply through it (|cos| 0.6) it is crossed.
  EXPECT_FALSE(crossings(*ground, {0, 0, 6.0}, {8, 0, -4.0}).empty());
  // 0.25 m beside the wall's end (its last column at y = 1.9 m): near its points, never through them.
  const auto wall = scene(true, false);
  EXPECT_TRUE(crossings(*wall, {0, 2.15, 1.5}, {20, 2.15, 1.5}).empty());
  EXPECT_FALSE(crossings(*wall, {0, 1.95, 1.5}, {20, 1.95, 1.5}).empty());
}

TEST(RayCrossing, ProbesRunFromStartEveryStepAndStopWhenTheProbeSays) {
  const auto map = scene(true, false);
  RayCrossingConfig cfg;
  std::vector<double> at;
  CellBlock block;
  int crossed = 0;
  const Eigen::Vector3d from = kOrigin + Eigen::Vector3d(0, 0.1, 1.5);  // to 20 m straight ahead, exactly
  walk_ray(*map, from, from + Eigen::Vector3d(20, 0, 0), cfg, block,
           [&](const Eigen::Vector3d&, double s) {
             at.push_back(s);
             return true;
           },
           [&](const MapPoint&, const Eigen::Vector3d&) { ++crossed; });
  ASSERT_EQ(at.size(), 32u);  // 3.0, 3.5, ... 18.5: short of 20 - 1
  EXPECT_DOUBLE_EQ(at.front(), 3.0);
  EXPECT_DOUBLE_EQ(at.back(), 18.5);
  EXPECT_GT(crossed, 0);
  at.clear();
  crossed = 0;
  walk_ray(*map, from, from + Eigen::Vector3d(20, 0, 0), cfg, block,
           [&](const Eigen::Vector3d&, double s) {
             at.push_back(s);
             return s < 6.0;  // ends the walk before the wall
           },
           [&](const MapPoint&, const Eigen::Vector3d&) { ++crossed; });
  EXPECT_EQ(at.size(), 7u);
  EXPECT_EQ(crossed, 0);
}

TEST(RayCrossing, ValidateNamesTheField) {
  EXPECT_NO_THROW(RayCrossingConfig{}.validate());
  auto error_of = [](RayCrossingConfig c) {
    try {
      c.validate();
    } catch (const pl::Error& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  RayCrossingConfig c;
  c.step_m = 0;
  EXPECT_NE(error_of(c).find("step_m"), std::string::npos);
  c = {};
  c.pass_radius_m = 3;
  EXPECT_NE(error_of(c).find("pass_radius_m"), std::string::npos);
  c = {};
  c.cross_radius_m = -1;
  EXPECT_NE(error_of(c).find("cross_radius_m"), std::string::npos);
  c = {};
  c.min_incidence = 1.5;
  EXPECT_NE(error_of(c).find("min_incidence"), std::string::npos);
  c = {};
  c.margin_m = -0.1;
  EXPECT_NE(error_of(c).find("margin_m"), std::string::npos);
  c = {};
  c.start_m = std::nan("");
  EXPECT_NE(error_of(c).find("start_m"), std::string::npos);
}

}  // namespace
