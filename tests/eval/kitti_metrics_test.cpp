#include "pl/eval/kitti_metrics.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "eval_test_util.hpp"
#include "pl/common/error.hpp"

namespace pl::eval {
namespace {

using test::kitti_trajectory;
using Poses = std::vector<Pose, Eigen::aligned_allocator<Pose>>;
constexpr double kPi = 3.14159265358979323846;

// n poses along x, `step` metres apart.
Poses straight(std::size_t n, double step) {
  Poses p;
  for (std::size_t i = 0; i < n; ++i) p.push_back(make_pose(step * static_cast<double>(i), 0, 0));
  return p;
}

Poses scaled(Poses p, double s) {
  for (auto& q : p) q.translation() *= s;
  return p;
}

KittiResult kitti(const Trajectory& est, const Trajectory& gt) {
  return compute_kitti_metrics(est, gt, pair_poses(est, gt, "est", "gt"));
}

// Segments of length L from every 10th frame on a 1 m/frame line of `last_frame` + 1 frames.
std::size_t expected_segments(std::size_t last_frame, std::size_t length) {
  return (last_frame - length) / 10 + 1;
}

TEST(EvalKitti, ScaledStraightLineGivesOnePercent) {
  const Poses g = straight(1001, 1.0);  // 1 km
  const KittiResult r = kitti(kitti_trajectory(scaled(g, 1.01)), kitti_trajectory(g));
  EXPECT_NEAR(r.overall.translation_pct, 1.0, 1e-9);
  EXPECT_NEAR(r.overall.rotation_deg_per_100m, 0.0, 1e-12);
  EXPECT_NEAR(r.path_length, 1000.0, 1e-9);
  ASSERT_EQ(r.by_length.size(), 8u);
  std::size_t total = 0;
  for (std::size_t k = 0; k < 8; ++k) {
    const auto& g8 = r.by_length[k];
    EXPECT_DOUBLE_EQ(g8.lo, 100.0 * (k + 1));
    EXPECT_EQ(g8.segments, expected_segments(1000, 100 * (k + 1))) << g8.lo;
    EXPECT_NEAR(g8.translation_pct, 1.0, 1e-9);
    total += g8.segments;
  }
  EXPECT_EQ(r.segments.size(), total);
  EXPECT_EQ(r.overall.segments, total);
  EXPECT_EQ(r.by_length.front().segments, 91u);
  EXPECT_EQ(r.by_length.back().segments, 21u);
  // 1 m a frame at 10 Hz is 36 km/h: one speed bin.
  ASSERT_EQ(r.by_speed.size(), 1u);
  EXPECT_DOUBLE_EQ(r.by_speed[0].lo, 30.0);
  EXPECT_DOUBLE_EQ(r.by_speed[0].hi, 40.0);
  EXPECT_EQ(r.by_speed[0].segments, total);
  EXPECT_FALSE(r.times_from_files);
}

TEST(EvalKitti, SegmentEndsAtTheFirstFrameAtOrPastTheLength) {
  // 3 m a frame: a 100 m segment ends 34 frames (102 m) later; the error of a 1.01 scale is
  // 1.02 m over the 102 m travelled, reported per 100 m of nominal length: 1.02 %.
  const Poses g = straight(400, 3.0);
  const KittiResult r = kitti(kitti_trajectory(scaled(g, 1.01)), kitti_trajectory(g));
  ASSERT_FALSE(r.by_length.empty());
  EXPECT_DOUBLE_EQ(r.by_length[0].lo, 100.0);
  EXPECT_NEAR(r.by_length[0].translation_pct, 1.02, 1e-9);
  EXPECT_EQ(r.segments.front().last - r.segments.front().first, 34u);
}

TEST(EvalKitti, ConstantYawRateErrorGivesItsRotationError) {
  // The estimate turns at omega rad/m where the ground truth drives straight: over a segment of
  // length L the relative rotation error is omega * L (so omega per metre), and the translation
  // error is the distance between the arc's chord end and the straight line's end.
  const double omega = 0.001;
  const Poses g = straight(1001, 1.0);
  Poses e;
  for (std::size_t i = 0; i < g.size(); ++i) {
    const double s = static_cast<double>(i);
    e.push_back(make_pose(std::sin(omega * s) / omega, (1.0 - std::cos(omega * s)) / omega, 0, 0, 0, omega * s));
  }
  const KittiResult r = kitti(kitti_trajectory(e), kitti_trajectory(g));
  const double deg_per_100m = omega * 180.0 / kPi * 100.0;  // 5.7296
  EXPECT_NEAR(r.overall.rotation_deg_per_100m, deg_per_100m, 1e-9);
  double weighted = 0.0;
  std::size_t total = 0;
  ASSERT_EQ(r.by_length.size(), 8u);
  for (const auto& g8 : r.by_length) {
    const double L = g8.lo;
    const double dx = std::sin(omega * L) / omega - L, dy = (1.0 - std::cos(omega * L)) / omega;
    const double expected_pct = std::hypot(dx, dy) / L * 100.0;
    EXPECT_NEAR(g8.rotation_deg_per_100m, deg_per_100m, 1e-9) << L;
    EXPECT_NEAR(g8.translation_pct, expected_pct, 1e-9) << L;
    weighted += expected_pct * static_cast<double>(g8.segments);
    total += g8.segments;
  }
  EXPECT_NEAR(r.overall.translation_pct, weighted / static_cast<double>(total), 1e-9);
  EXPECT_NEAR(r.by_length[0].translation_pct, 5.0, 0.01);  // ~ omega * L / 2 = 5 % at 100 m
}

TEST(EvalKitti, SpeedFromTumTimestamps) {
  // 1 m a pose, 0.05 s apart: 20 m/s = 72 km/h.
  const Poses g = straight(1001, 1.0);
  std::vector<double> t;
  for (std::size_t i = 0; i < g.size(); ++i) t.push_back(1000.0 + 0.05 * static_cast<double>(i));
  const KittiResult r = kitti(test::tum_trajectory(scaled(g, 1.02), t), test::tum_trajectory(g, t));
  EXPECT_TRUE(r.times_from_files);
  EXPECT_NEAR(r.overall.translation_pct, 2.0, 1e-9);
  ASSERT_EQ(r.by_speed.size(), 1u);
  EXPECT_DOUBLE_EQ(r.by_speed[0].lo, 70.0);
  EXPECT_DOUBLE_EQ(r.by_speed[0].hi, 80.0);
}

TEST(EvalKitti, SpeedBinsSplitFastAndSlowParts) {
  // 500 m at 1 m/frame (36 km/h), then 2000 m at 2 m/frame (72 km/h), 10 Hz frames.
  Poses g;
  double x = 0;
  for (int i = 0; i < 500; ++i, x += 1.0) g.push_back(make_pose(x, 0, 0));
  for (int i = 0; i < 1000; ++i, x += 2.0) g.push_back(make_pose(x, 0, 0));
  const KittiResult r = kitti(kitti_trajectory(g), kitti_trajectory(g));
  std::vector<double> bins;
  for (const auto& b : r.by_speed) bins.push_back(b.lo);
  EXPECT_EQ(bins.front(), 30.0);
  EXPECT_EQ(bins.back(), 70.0);
  std::size_t total = 0;
  for (const auto& b : r.by_speed) total += b.segments;
  EXPECT_EQ(total, r.segments.size());
}

TEST(EvalKitti, ShortEstimateUsesItsPairsOnly) {
  const Poses g = straight(1001, 1.0);
  Poses e = scaled(g, 1.01);
  e.resize(301);  // 300 m
  const KittiResult r = kitti(kitti_trajectory(e), kitti_trajectory(g));
  ASSERT_EQ(r.by_length.size(), 3u);  // 100, 200, 300 m
  EXPECT_EQ(r.by_length[2].segments, 1u);
  EXPECT_NEAR(r.overall.translation_pct, 1.0, 1e-9);
}

TEST(EvalKitti, TooShortIsAnError) {
  const Poses g = straight(50, 1.0);
  try {
    kitti(kitti_trajectory(g), kitti_trajectory(g));
    FAIL() << "expected an error";
  } catch (const pl::Error& e) {
    EXPECT_NE(std::string(e.what()).find("shorter than the shortest KITTI segment"), std::string::npos) << e.what();
  }
}

TEST(EvalKitti, PerfectEstimateHasNoError) {
  const Trajectory g = test::curvy_path(800, 1.5);
  const KittiResult r = kitti(g, g);
  EXPECT_GT(r.segments.size(), 100u);
  EXPECT_NEAR(r.overall.translation_pct, 0.0, 1e-9);
  EXPECT_NEAR(r.overall.rotation_deg_per_100m, 0.0, 1e-9);
}

TEST(EvalKitti, ErrorIsInvariantToAGlobalRigidMotionOfTheEstimate) {
  const Trajectory g = test::curvy_path(800, 1.5);
  Trajectory e = g;
  const Pose m = make_pose(50, -20, 3, 0.1, 0.2, 1.0);
  for (auto& p : e.poses) p = m * p;  // relative errors do not see a global motion
  const KittiResult r = kitti(e, g);
  EXPECT_NEAR(r.overall.translation_pct, 0.0, 1e-9);
  EXPECT_NEAR(r.overall.rotation_deg_per_100m, 0.0, 1e-9);
}

}  // namespace
}  // namespace pl::eval
