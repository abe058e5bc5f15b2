#include "pl/eval/matching.hpp"

#include <gtest/gtest.h>

#include <fstream>
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
// Headers say which frames a file's lines are: a run that did not start at the drive's first scan
// pairs with the drive's ground truth by frame, and files that cannot be matched are refused.
TEST(EvalMatching, FrameNumbersPairARunThatStartedLaterAndRefuseWhatCannotMatch) {
  Trajectory gt = kitti_trajectory(line_poses(20));
  gt.frame = "lidar";
  for (long i = 0; i < 20; ++i) gt.frame_ids.push_back(i);
  Trajectory est = kitti_trajectory(line_poses(3));
  est.frame = "lidar";
  est.frame_ids = {11, 13, 15};
  PosePairs p = pair_poses(est, gt, "e", "g");
  EXPECT_EQ(p.gt, (std::vector<std::size_t>{11, 13, 15}));
  EXPECT_EQ(p.est, (std::vector<std::size_t>{0, 1, 2}));
  // A ground truth without frame numbers and of another length: no line is known to match.
  Trajectory plain = kitti_trajectory(line_poses(20));
  std::string msg = message_of([&] { pair_poses(est, plain, "run.txt", "gt.txt"); });
  EXPECT_NE(msg.find("run.txt holds the poses of frames 11, 13, 15, but the ground truth gt.txt has 20 lines and no frame numbers"),
            std::string::npos) << msg;
  // Cut to the same scans (as many lines), it pairs line by line; so does a run from frame 0.
  EXPECT_EQ(pair_poses(est, kitti_trajectory(line_poses(3)), "e", "g").gt, (std::vector<std::size_t>{0, 1, 2}));
  Trajectory first = kitti_trajectory(line_poses(3));
  first.frame_ids = {0, 1, 2};
  EXPECT_EQ(pair_poses(first, plain, "e", "g").gt, (std::vector<std::size_t>{0, 1, 2}));
  // A frame the ground truth does not have.
  est.frame_ids = {11, 13, 25};
  msg = message_of([&] { pair_poses(est, gt, "run.txt", "gt.txt"); });
  EXPECT_NE(msg.find("frame 25 (line 3 of its poses) is not among the ground truth's frames in gt.txt (0-19)"), std::string::npos) << msg;
  // Poses of different frames.
  est.frame_ids = {11, 13, 15};
  gt.frame = "cam0";
  msg = message_of([&] { pair_poses(est, gt, "run.txt", "gt.txt"); });
  EXPECT_NE(msg.find("holds poses of the lidar frame but the ground truth gt.txt of the cam0 frame"), std::string::npos) << msg;
}

TEST(EvalMatching, CameraPosesAgainstLidarPosesAreRefused) {
  // LiDAR poses drive in x-y (z up); KITTI's cam0 ground truth drives in x-z (y down).
  Poses lidar, cam;
  for (int i = 0; i < 50; ++i) {
    lidar.push_back(make_pose(i, 0.3 * i, 0.01 * (i % 3)));
    cam.push_back(make_pose(-0.3 * i, 0.01 * (i % 3), i));
  }
  Trajectory est = kitti_trajectory(lidar);
  est.frame = "lidar";
  const std::string msg = message_of([&] { pair_poses(est, kitti_trajectory(cam), "run.txt", "00.txt"); });
  EXPECT_NE(msg.find("00.txt looks like camera poses"), std::string::npos) << msg;
  EXPECT_NO_THROW(pair_poses(est, kitti_trajectory(lidar), "run.txt", "gt.txt"));
}

// The header round trip: frame and frame numbers written as comments and read back.
TEST(EvalMatching, PoseFileHeadersRoundTrip) {
  test::TempDir dir;
  Trajectory t = kitti_trajectory(line_poses(6));
  t.frame = "lidar";
  t.frame_ids = {1, 3, 5, 7, 20, 21};
  write_trajectory(dir.file("t.txt"), t, PoseFormat::Kitti);
  const Trajectory back = read_trajectory(dir.file("t.txt"));
  EXPECT_EQ(back.frame, "lidar");
  EXPECT_EQ(back.frame_ids, t.frame_ids);
  EXPECT_EQ(back.size(), 6u);
  std::ifstream in(dir.file("t.txt"));
  std::string l1, l2;
  std::getline(in, l1);
  std::getline(in, l2);
  EXPECT_EQ(l1, "# frame: lidar");
  EXPECT_EQ(l2, "# frames: 1-7:2,20,21");
}

}  // namespace pl::eval
