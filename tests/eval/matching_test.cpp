#include "pl/eval/matching.hpp"

#include <gtest/gtest.h>

#include <functional>

#include "eval_test_util.hpp"
#include "pl/common/error.hpp"

namespace pl::eval {
namespace {

using test::kitti_trajectory;
using test::tum_trajectory;
using Poses = std::vector<Pose, Eigen::aligned_allocator<Pose>>;

Poses line_poses(std::size_t n) {
  Poses p;
  for (std::size_t i = 0; i < n; ++i) p.push_back(make_pose(static_cast<double>(i), 0, 0));
  return p;
}

std::vector<double> times(std::size_t n, double start, double dt) {
  std::vector<double> t;
  for (std::size_t i = 0; i < n; ++i) t.push_back(start + dt * static_cast<double>(i));
  return t;
}

std::string message_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const pl::Error& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(EvalMatching, KittiPairsLineByLine) {
  const PosePairs p = pair_poses(kitti_trajectory(line_poses(5)), kitti_trajectory(line_poses(5)), "e", "g");
  EXPECT_EQ(p.est, (std::vector<std::size_t>{0, 1, 2, 3, 4}));
  EXPECT_EQ(p.gt, (std::vector<std::size_t>{0, 1, 2, 3, 4}));
}

TEST(EvalMatching, ShorterKittiEstimatePairsItsLines) {
  const PosePairs p = pair_poses(kitti_trajectory(line_poses(3)), kitti_trajectory(line_poses(10)), "e", "g");
  EXPECT_EQ(p.gt, (std::vector<std::size_t>{0, 1, 2}));
}

TEST(EvalMatching, LongerKittiEstimateIsAnError) {
  const std::string msg = message_of(
      [] { pair_poses(kitti_trajectory(line_poses(11)), kitti_trajectory(line_poses(10)), "run/est.txt", "gt.txt"); });
  EXPECT_NE(msg.find("run/est.txt"), std::string::npos) << msg;
  EXPECT_NE(msg.find("11 poses"), std::string::npos) << msg;
  EXPECT_NE(msg.find("cannot be longer"), std::string::npos) << msg;
}

TEST(EvalMatching, MixedFormatsAreAnErrorThatSaysToConvert) {
  const std::string msg = message_of([] {
    pair_poses(tum_trajectory(line_poses(3), times(3, 0, 0.1)), kitti_trajectory(line_poses(3)), "est.tum", "gt.kitti");
  });
  EXPECT_NE(msg.find("est.tum"), std::string::npos) << msg;
  EXPECT_NE(msg.find("TUM"), std::string::npos) << msg;
  EXPECT_NE(msg.find("KITTI"), std::string::npos) << msg;
  EXPECT_NE(msg.find("convert"), std::string::npos) << msg;
}

TEST(EvalMatching, TumPairsWithinFiveMilliseconds) {
  const auto gt = tum_trajectory(line_poses(10), times(10, 100.0, 0.1));
  const auto est = tum_trajectory(line_poses(10), times(10, 100.005, 0.1));
  const PosePairs p = pair_poses(est, gt, "e", "g");
  EXPECT_EQ(p.size(), 10u);
  for (std::size_t k = 0; k < p.size(); ++k) EXPECT_EQ(p.est[k], p.gt[k]);
}

TEST(EvalMatching, TumRejectsSixMilliseconds) {
  const auto gt = tum_trajectory(line_poses(10), times(10, 100.0, 0.1));
  const auto est = tum_trajectory(line_poses(10), times(10, 100.006, 0.1));
  const std::string msg = message_of([&] { pair_poses(est, gt, "est.tum", "gt.tum"); });
  EXPECT_NE(msg.find("within 5 ms"), std::string::npos) << msg;
  EXPECT_NE(msg.find("est.tum"), std::string::npos) << msg;
}

TEST(EvalMatching, TumKeepsOnlyThePosesWithinTolerance) {
  const auto gt = tum_trajectory(line_poses(4), {1.0, 2.0, 3.0, 4.0});
  // 1.004 is 4 ms late (pairs), 2.006 is 6 ms late (no pair), 2.996 is 4 ms early (pairs), 4.0 exact.
  const auto est = tum_trajectory(line_poses(4), {1.004, 2.006, 2.996, 4.0});
  const PosePairs p = pair_poses(est, gt, "e", "g");
  EXPECT_EQ(p.est, (std::vector<std::size_t>{0, 2, 3}));
  EXPECT_EQ(p.gt, (std::vector<std::size_t>{0, 2, 3}));
}

TEST(EvalMatching, TumUsesEachGroundTruthPoseOnceAndPrefersTheClosest) {
  const auto gt = tum_trajectory(line_poses(3), {0.0, 1.0, 2.0});
  // Both estimates are within 5 ms of gt time 1.0; the closer one (1.001) gets it.
  const auto est = tum_trajectory(line_poses(2), {0.997, 1.001});
  const PosePairs p = pair_poses(est, gt, "e", "g");
  ASSERT_EQ(p.size(), 1u);
  EXPECT_EQ(p.est[0], 1u);
  EXPECT_EQ(p.gt[0], 1u);
}

TEST(EvalMatching, TumNearestGroundTruthWins) {
  // GT every 4 ms: the estimate at 0.0055 is within 5 ms of 0.004 and 0.008; 0.004 is nearer.
  const auto gt = tum_trajectory(line_poses(4), {0.0, 0.004, 0.008, 0.012});
  const auto est = tum_trajectory(line_poses(1), {0.0055});
  const PosePairs p = pair_poses(est, gt, "e", "g");
  ASSERT_EQ(p.size(), 1u);
  EXPECT_EQ(p.gt[0], 1u);
}

}  // namespace
}  // namespace pl::eval
