// The places of a map: their bytes, and the proposals for a scan taken somewhere on the map.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <random>

#include "pl/common/error.hpp"
#include "pl/registration/place_index.hpp"

namespace {

using pl::registration::Place;
using pl::registration::PlaceIndex;

constexpr double kDeg = M_PI / 180.0;

// A town of walls of random heights on flat ground, 300 m square (world frame, sensor at z = 0).
std::vector<Eigen::Vector3d> town(int seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-150.0, 150.0), h(1.0, 12.0), a(-M_PI, M_PI), l(3.0, 15.0);
  std::vector<Eigen::Vector3d> pts;
  for (int k = 0; k < 400; ++k) {
    const Eigen::Vector2d at(u(rng), u(rng));
    const double yaw = a(rng), len = l(rng), height = h(rng);
    const Eigen::Vector2d dir(std::cos(yaw), std::sin(yaw));
    for (double s = 0; s < len; s += 0.4)
      for (double z = 0; z < height; z += 0.4) pts.emplace_back(at.x() + s * dir.x(), at.y() + s * dir.y(), z - 1.7);
  }
  for (double x = -150; x <= 150; x += 1.0)
    for (double y = -150; y <= 150; y += 1.0) pts.emplace_back(x, y, -1.7);
  return pts;
}

std::vector<Eigen::Vector3f> seen_from(const std::vector<Eigen::Vector3d>& w, const Eigen::Isometry3d& sensor) {
  std::vector<Eigen::Vector3f> out;
  const Eigen::Isometry3d inv = sensor.inverse();
  for (const Eigen::Vector3d& p : w) {
    const Eigen::Vector3d q = inv * p;
    if (q.head<2>().norm() < 80.0) out.push_back(q.cast<float>());
  }
  return out;
}

Eigen::Isometry3d pose(double x, double y, double yaw) {
  return Eigen::Translation3d(x, y, 0) * Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ());
}

// Places every 4 m along a straight road west to east, heading east.
PlaceIndex road_places(const std::vector<Eigen::Vector3d>& w) {
  std::vector<Place> places;
  for (double x = -80; x <= 80; x += 4.0) {
    Place p;
    const Eigen::Isometry3d at = pose(x, 0, 0);
    p.position = at.translation();
    p.yaw = 0;
    p.descriptor = pl::registration::make_place_descriptor(seen_from(w, at));
    places.push_back(p);
  }
  return PlaceIndex({}, places);
}

TEST(PlaceIndex, EncodesToTheSameBytesAndBackWithinTheHeightStep) {
  const auto w = town(1);
  const PlaceIndex index = road_places(w);
  const std::string bytes = index.encode();
  EXPECT_EQ(bytes, road_places(w).encode());
  const PlaceIndex back = PlaceIndex::decode(bytes, "test");
  ASSERT_EQ(back.places().size(), index.places().size());
  EXPECT_EQ(back.config().rings, index.config().rings);
  EXPECT_EQ(back.config().sectors, index.config().sectors);
  for (std::size_t i = 0; i < back.places().size(); ++i) {
    EXPECT_EQ(back.places()[i].position, index.places()[i].position);
    const auto& a = back.places()[i].descriptor.cells;
    const auto& b = index.places()[i].descriptor.cells;
    ASSERT_EQ(a.size(), b.size());
    for (std::size_t k = 0; k < a.size(); ++k) {
      EXPECT_EQ(a[k] == 0, b[k] == 0);
      EXPECT_NEAR(a[k], b[k], 0.051);
    }
  }
  EXPECT_EQ(back.encode(), bytes);
}

TEST(PlaceIndex, DamagedBytesAreRefusedNamingTheProblem) {
  const std::string bytes = road_places(town(1)).encode();
  auto message = [](const std::string& b) {
    try {
      PlaceIndex::decode(b, "places.bin");
    } catch (const pl::Error& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  EXPECT_NE(message("PLPX" + bytes.substr(4)).find("not a places file"), std::string::npos);
  EXPECT_NE(message(bytes.substr(0, bytes.size() - 1)).find("bytes need"), std::string::npos);
  EXPECT_NE(message(bytes + "x").find("bytes need"), std::string::npos);
  EXPECT_NE(message(bytes.substr(0, 10)).find("ends early"), std::string::npos);
  std::string format = bytes;
  format[4] = 9;
  EXPECT_NE(message(format).find("format 9"), std::string::npos);
  std::string grid = bytes;
  grid[8] = grid[9] = grid[10] = static_cast<char>(0xff);
  EXPECT_NE(message(grid).find("a grid of"), std::string::npos);
  std::string nan = bytes;
  const double q = std::nan("");
  std::memcpy(&nan[4 + 4 + 4 + 4 + 8 + 8 + 4], &q, 8);  // the first place's x
  EXPECT_NE(message(nan).find("x is not a finite number"), std::string::npos);
  EXPECT_NE(message(bytes).find("accepted"), std::string::npos);
  // A descriptor of another grid does not join an index.
  Place odd;
  odd.descriptor = pl::registration::make_place_descriptor({}, {10, 30, 80.0, 2.0});
  EXPECT_THROW(PlaceIndex({}, {odd}), pl::Error);
}

TEST(PlaceIndex, ProposesTheRightPlaceAndHeadingForAScanTakenTurnedBetweenPlaces) {
  const auto w = town(2);
  const PlaceIndex index = road_places(w);
  // Between two places, 0.7 m off the road's line, facing 140 degrees from the places' heading.
  for (const double x : {-61.0, -13.0, 27.0, 70.0}) {
    const Eigen::Isometry3d truth = pose(x, 0.7, 140.0 * kDeg);
    const auto proposals = index.propose(pl::registration::make_place_descriptor(seen_from(w, truth)), 3);
    ASSERT_FALSE(proposals.empty());
    const auto& best = proposals.front();
    EXPECT_LT((best.pose.translation() - truth.translation()).head<2>().norm(), 4.0) << "at x = " << x;
    const double dyaw = std::remainder(pl::registration::heading_of(best.pose) - 140.0 * kDeg, 2.0 * M_PI);
    EXPECT_LT(std::abs(dyaw), 7.0 * kDeg) << "at x = " << x;
  }
  // Only places within a radius are proposed: none near a point far from the road.
  EXPECT_TRUE(index.propose(index.places().front().descriptor, 3, Eigen::Vector2d(0, 120), 20.0).empty());
  const auto near = index.propose(index.places().front().descriptor, 50, Eigen::Vector2d(-80, 0), 10.0);
  EXPECT_EQ(near.size(), 3u);  // the places at -80, -76 and -72
}

}  // namespace
