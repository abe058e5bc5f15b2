#include "pl/eval/ape.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "eval_test_util.hpp"
#include "pl/common/error.hpp"
#include "pl/eval/alignment.hpp"

namespace pl::eval {
namespace {

using test::curvy_path;
using test::kitti_trajectory;
using Poses = std::vector<Pose, Eigen::aligned_allocator<Pose>>;

ApeResult ape(const Trajectory& est, const Trajectory& gt, const ApeOptions& options = {}) {
  return compute_ape(est, gt, pair_poses(est, gt, "est", "gt"), options);
}

Trajectory shifted(const Trajectory& t, const Eigen::Vector3d& shift) {
  Trajectory out = t;
  for (auto& p : out.poses) p.translation() += shift;
  return out;
}

TEST(EvalApe, ConstantShiftOfThreeFourGivesFiveEverywhere) {
  const Trajectory gt = curvy_path(60);
  const ApeResult r = ape(shifted(gt, {3, 4, 0}), gt);
  EXPECT_EQ(r.alignment, Alignment::None);
  EXPECT_EQ(r.matched, 60u);
  EXPECT_DOUBLE_EQ(r.coverage, 1.0);
  for (double e : r.errors) EXPECT_NEAR(e, 5.0, 1e-12);
  EXPECT_NEAR(r.error.mean, 5.0, 1e-12);
  EXPECT_NEAR(r.error.median, 5.0, 1e-12);
  EXPECT_NEAR(r.error.rmse, 5.0, 1e-12);
  EXPECT_NEAR(r.error.max, 5.0, 1e-12);
  EXPECT_NEAR(r.error.std, 0.0, 1e-12);
  EXPECT_NEAR(r.vertical.rmse, 0.0, 1e-12);  // the shift is horizontal (z-up path)
}

TEST(EvalApe, ErrorsOneToFour) {
  Poses g, e;
  for (int i = 0; i < 4; ++i) {
    g.push_back(make_pose(10.0 * i, 0, 0));
    e.push_back(make_pose(10.0 * i, 0, i + 1.0));  // error i+1 straight up
  }
  const ApeResult r = ape(kitti_trajectory(e), kitti_trajectory(g));
  EXPECT_DOUBLE_EQ(r.error.mean, 2.5);
  EXPECT_DOUBLE_EQ(r.error.median, 2.5);
  EXPECT_DOUBLE_EQ(r.error.rmse, std::sqrt(7.5));
  EXPECT_DOUBLE_EQ(r.error.std, std::sqrt(1.25));
  EXPECT_DOUBLE_EQ(r.error.max, 4.0);
  EXPECT_EQ(r.vertical_axis, 2);
  EXPECT_DOUBLE_EQ(r.vertical.mean_abs, 2.5);
  EXPECT_DOUBLE_EQ(r.vertical.rmse, std::sqrt(7.5));
  EXPECT_NEAR(r.longitudinal.rmse, 0.0, 1e-15);
  EXPECT_NEAR(r.lateral.rmse, 0.0, 1e-15);
}

TEST(EvalApe, CoverageWithAShorterEstimate) {
  const Trajectory gt = curvy_path(40);
  Trajectory est = gt;
  est.poses.resize(30);
  const ApeResult r = ape(est, gt);
  EXPECT_EQ(r.matched, 30u);
  EXPECT_EQ(r.gt_poses, 40u);
  EXPECT_DOUBLE_EQ(r.coverage, 0.75);
  EXPECT_NEAR(r.error.max, 0.0, 1e-12);
}

TEST(EvalApe, Se3AlignmentRecoversARigidMotion) {
  const Trajectory gt = curvy_path(200);
  Pose motion = make_pose(12.0, -7.0, 2.5, 0.05, -0.03, 0.6);
  Trajectory est = gt;
  for (auto& p : est.poses) p = motion * p;

  const ApeResult raw = ape(est, gt);
  EXPECT_GT(raw.error.mean, 5.0);  // unaligned, the motion shows

  ApeOptions options;
  options.alignment = Alignment::Se3;
  const ApeResult r = ape(est, gt, options);
  EXPECT_EQ(r.alignment, Alignment::Se3);
  EXPECT_LT(r.error.max, 1e-9);
  // The alignment maps the estimate back: it is the inverse of the applied motion.
  EXPECT_TRUE((r.alignment_transform * motion).matrix().isApprox(Eigen::Matrix4d::Identity(), 1e-9))
      << (r.alignment_transform * motion).matrix();
}

TEST(EvalApe, Se3AlignmentIsTheLeastSquaresOptimum) {
  // With noise, the aligned error is below the error of the true motion's inverse and of small
  // perturbations of the found alignment.
  const Trajectory gt = curvy_path(300);
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0.0, 0.3);
  const Pose motion = make_pose(-4.0, 9.0, 1.0, 0.0, 0.02, -1.1);
  Trajectory est = gt;
  for (auto& p : est.poses) {
    p = motion * p;
    p.translation() += Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
  }
  ApeOptions options;
  options.alignment = Alignment::Se3;
  const ApeResult r = ape(est, gt, options);
  auto sse_with = [&](const Pose& t) {
    double s = 0;
    for (std::size_t i = 0; i < gt.size(); ++i)
      s += (t * est.poses[i].translation() - gt.poses[i].translation()).squaredNorm();
    return s;
  };
  const double best = sse_with(r.alignment_transform);
  EXPECT_NEAR(best, r.error.rmse * r.error.rmse * 300.0, 1e-6 * best);
  EXPECT_LE(best, sse_with(motion.inverse()));
  for (const Pose& d : {make_pose(0.01, 0, 0), make_pose(0, 0, 0, 0, 0, 1e-4), make_pose(0, 0, 0.01, 1e-4, 0, 0)})
    EXPECT_LT(best, sse_with(d * r.alignment_transform));
  EXPECT_NEAR(r.alignment_transform.linear().determinant(), 1.0, 1e-12);
}

TEST(EvalApe, AlignmentOfPlanarPointsIsARotationNotAReflection) {
  // Coplanar points invite a reflection from a naive SVD solution.
  Positions src, dst;
  const Pose motion = make_pose(1, 2, 3, 0, 0, 2.0);
  for (int i = 0; i < 8; ++i) {
    Eigen::Vector3d p(std::cos(i * 0.7) * 5, std::sin(i * 1.3) * 3, 0);
    src.push_back(p);
    dst.push_back(motion * p);
  }
  const Pose t = align_rigid(src, dst);
  EXPECT_NEAR(t.linear().determinant(), 1.0, 1e-12);
  EXPECT_TRUE(t.matrix().isApprox(motion.matrix(), 1e-9));
  EXPECT_THROW(align_rigid({}, {}), pl::Error);
  EXPECT_THROW(align_rigid(src, {}), pl::Error);
}

TEST(EvalApe, Sim3RemovesAScaledRotatedShiftedCopyThatSe3CannotRemove) {
  // The estimate is the ground truth scaled by 1.03 about the origin, then rotated and moved.
  const Trajectory gt = curvy_path(300);
  const Pose motion = make_pose(12.0, -7.0, 0.5, 0.02, -0.01, 0.9);
  Trajectory est = gt;
  for (auto& p : est.poses) {
    p.translation() *= 1.03;
    p = motion * p;
  }
  ApeOptions options;
  options.alignment = Alignment::Sim3;
  const ApeResult sim3 = ape(est, gt, options);
  EXPECT_EQ(sim3.alignment, Alignment::Sim3);
  EXPECT_NEAR(sim3.alignment_scale, 1.0 / 1.03, 1e-12);  // the factor applied to the estimate
  EXPECT_LT(sim3.error.max, 1e-9);
  EXPECT_NEAR(sim3.alignment_transform.linear().determinant(), 1.0, 1e-12);
  // Undoing the motion and the scale: T (s p) = motion^-1 p / 1.03 for every p.
  const Eigen::Vector3d probe(3.0, -4.0, 5.0);
  EXPECT_NEAR((sim3.alignment_transform * (sim3.alignment_scale * probe) - (motion.inverse() * probe) / 1.03).norm(), 0.0,
              1e-9);

  options.alignment = Alignment::Se3;
  const ApeResult se3 = ape(est, gt, options);
  EXPECT_DOUBLE_EQ(se3.alignment_scale, 1.0);
  // 3 % of a path some 450 m long, minus what the best rotation and translation can hide.
  EXPECT_GT(se3.error.rmse, 1.0);
  EXPECT_GT(se3.error.max, 2.0);
}

TEST(EvalApe, SimilarityAlignmentRecoversScaleRotationTranslation) {
  Positions src, dst;
  const Pose motion = make_pose(-3, 8, 1, 0.3, -0.2, 2.5);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-20.0, 20.0);
  for (int i = 0; i < 50; ++i) {
    const Eigen::Vector3d p(u(rng), u(rng), 0.1 * u(rng));
    src.push_back(p);
    dst.push_back(motion * (0.5 * p));  // the source is twice the target's size
  }
  const Similarity s = align_similarity(src, dst);
  EXPECT_NEAR(s.scale, 0.5, 1e-12);
  EXPECT_TRUE(s.rigid.matrix().isApprox(motion.matrix(), 1e-9)) << s.rigid.matrix();
  for (std::size_t i = 0; i < src.size(); ++i) EXPECT_NEAR((s(src[i]) - dst[i]).norm(), 0.0, 1e-9);
  Eigen::Matrix4d expected = motion.matrix();
  expected.topLeftCorner<3, 3>() *= 0.5;
  EXPECT_TRUE(s.matrix().isApprox(expected, 1e-9));

  // Coplanar points: still a rotation, not a reflection; the scale stays positive.
  Positions flat_src, flat_dst;
  for (int i = 0; i < 8; ++i) {
    const Eigen::Vector3d p(std::cos(i * 0.7) * 5, std::sin(i * 1.3) * 3, 0);
    flat_src.push_back(p);
    flat_dst.push_back(motion * (2.0 * p));
  }
  const Similarity f = align_similarity(flat_src, flat_dst);
  EXPECT_NEAR(f.rigid.linear().determinant(), 1.0, 1e-12);
  EXPECT_NEAR(f.scale, 2.0, 1e-12);

  EXPECT_THROW(align_similarity({}, {}), pl::Error);
  EXPECT_THROW(align_similarity(src, {}), pl::Error);
  const Positions same(5, Eigen::Vector3d(1e6, 2e6, 3.0));  // far away, but all one point
  EXPECT_THROW(align_similarity(same, Positions(5, Eigen::Vector3d::Zero())), pl::Error);
}

TEST(EvalApe, LongitudinalLateralVerticalOnAStraightLine) {
  const Eigen::Vector3d forward(0.6, 0.8, 0.0);  // a known direction in the xy plane
  const Eigen::Vector3d left(-0.8, 0.6, 0.0);
  Poses g, e;
  for (int i = 0; i < 50; ++i) {
    // The pose's own x axis points elsewhere (yaw 2 rad): the split must not use it.
    Pose p = make_pose(0, 0, 0, 0, 0, 2.0);
    p.translation() = forward * (2.0 * i);
    g.push_back(p);
    Pose q = p;
    q.translation() += 2.0 * forward + (i % 2 == 0 ? 1.0 : -1.0) * left + Eigen::Vector3d(0, 0, 0.5);
    e.push_back(q);
  }
  const ApeResult r = ape(kitti_trajectory(e), kitti_trajectory(g));
  EXPECT_EQ(r.vertical_axis, 2);
  EXPECT_NEAR(r.longitudinal.mean_abs, 2.0, 1e-12);
  EXPECT_NEAR(r.longitudinal.rmse, 2.0, 1e-12);
  EXPECT_NEAR(r.lateral.mean_abs, 1.0, 1e-12);
  EXPECT_NEAR(r.lateral.rmse, 1.0, 1e-12);
  EXPECT_NEAR(r.vertical.mean_abs, 0.5, 1e-12);
  EXPECT_NEAR(r.error.mean, std::sqrt(4.0 + 1.0 + 0.25), 1e-12);
}

TEST(EvalApe, ComponentsFollowTheTurnsAndAddUpToTheError) {
  const Trajectory gt = curvy_path(300);
  Trajectory est = gt;
  std::mt19937 rng(3);
  std::normal_distribution<double> noise(0.0, 0.5);
  for (auto& p : est.poses) p.translation() += Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
  const ApeResult r = ape(est, gt);
  const double sum_sq = r.longitudinal.rmse * r.longitudinal.rmse + r.lateral.rmse * r.lateral.rmse +
                        r.vertical.rmse * r.vertical.rmse;
  EXPECT_NEAR(sum_sq, r.error.rmse * r.error.rmse, 1e-9);

  // An error of 1 m to the left of the direction of travel, all along the curvy path.
  Trajectory left = gt;
  for (std::size_t i = 0; i < gt.size(); ++i) {
    const std::size_t a = i == 0 ? 0 : i - 1, b = i + 1 < gt.size() ? i + 1 : i;
    Eigen::Vector3d d = gt.poses[b].translation() - gt.poses[a].translation();
    d.z() = 0;
    left.poses[i].translation() += Eigen::Vector3d(-d.y(), d.x(), 0).normalized();
  }
  const ApeResult l = ape(left, gt);
  EXPECT_NEAR(l.lateral.mean_abs, 1.0, 1e-12);
  EXPECT_NEAR(l.longitudinal.rmse, 0.0, 1e-12);
}

TEST(EvalApe, KittiCameraFramePosesUseTheDirectionOfTravel) {
  // KITTI cam0 poses: x right, y down, z forward; the ground is the x-z plane. The car drives
  // 99 m along z, turns and drives 100 m along x, with identity rotations throughout (so the
  // pose's x axis is sideways on the first leg and forward on the second). Each estimate is off
  // by 0.7 m along the direction of travel, 0.3 m sideways and 0.2 m along y; the corner pose
  // (whose direction is diagonal) has no error.
  Poses g, e;
  const int n = 200;
  for (int i = 0; i < n; ++i) {
    const double h = 0.02 * std::sin(0.1 * i);  // a slight slope in y
    const bool first_leg = i < 100;
    const Eigen::Vector3d p = first_leg ? Eigen::Vector3d(0, h, i) : Eigen::Vector3d(i - 99, h, 99);
    const Eigen::Vector3d d = first_leg ? Eigen::Vector3d(0, 0, 1) : Eigen::Vector3d(1, 0, 0);
    const Eigen::Vector3d side(d.z(), 0, -d.x());
    g.push_back(make_pose(p.x(), p.y(), p.z()));
    const Eigen::Vector3d q = i == 99 ? p : Eigen::Vector3d(p + 0.7 * d + 0.3 * side + Eigen::Vector3d(0, -0.2, 0));
    e.push_back(make_pose(q.x(), q.y(), q.z()));
  }
  const ApeResult r = ape(kitti_trajectory(e), kitti_trajectory(g));
  EXPECT_EQ(r.vertical_axis, 1);
  EXPECT_TRUE(r.vertical_axis_auto);
  const double share = (n - 1.0) / n;
  EXPECT_NEAR(r.longitudinal.mean_abs, 0.7 * share, 1e-12);
  EXPECT_NEAR(r.lateral.mean_abs, 0.3 * share, 1e-12);
  EXPECT_NEAR(r.vertical.mean_abs, 0.2 * share, 1e-12);

  ApeOptions z_up;
  z_up.vertical_axis = 2;  // forcing z (wrong for this frame) makes z the vertical component
  const ApeResult forced = ape(kitti_trajectory(e), kitti_trajectory(g), z_up);
  EXPECT_FALSE(forced.vertical_axis_auto);
  EXPECT_NEAR(forced.vertical.mean_abs, (99 * 0.7 + 100 * 0.3) / n, 1e-12);
}

TEST(EvalApe, TravelDirectionsSurviveStops) {
  Positions p;
  for (int i = 0; i < 10; ++i) p.emplace_back(i, 0, 0);
  for (int i = 0; i < 20; ++i) p.emplace_back(9, 0, 0);  // stopped
  for (int i = 10; i < 20; ++i) p.emplace_back(i, 0, 0);
  const Positions d = travel_directions(p, 2);
  ASSERT_EQ(d.size(), p.size());
  for (const auto& v : d) EXPECT_TRUE(v.isApprox(Eigen::Vector3d(1, 0, 0), 1e-12)) << v.transpose();

  const Positions still = travel_directions(Positions(5, Eigen::Vector3d(1, 2, 3)), 2);
  for (const auto& v : still) EXPECT_NEAR(v.norm(), 1.0, 1e-12);
}

TEST(EvalApe, AutoVerticalAxisPicksTheSmallestExtent) {
  EXPECT_EQ(auto_vertical_axis({{0, 0, 0}, {100, 50, 2}}), 2);
  EXPECT_EQ(auto_vertical_axis({{0, 0, 0}, {100, 2, 50}}), 1);
  EXPECT_EQ(auto_vertical_axis({{0, 0, 0}, {1, 50, 40}}), 0);
  EXPECT_EQ(auto_vertical_axis({{0, 0, 0}, {100, 0, 0}}), 2);  // ties go to z
}

TEST(EvalApe, PathDistances) {
  const std::vector<double> d = path_distances({{0, 0, 0}, {3, 4, 0}, {3, 4, 12}});
  EXPECT_EQ(d, (std::vector<double>{0.0, 5.0, 17.0}));
}

TEST(EvalApe, TumPairsUseTheirTimestamps) {
  Poses g, e;
  std::vector<double> tg, te;
  for (int i = 0; i < 20; ++i) {
    g.push_back(make_pose(i, 0, 0));
    tg.push_back(0.1 * i);
  }
  for (int i = 0; i < 20; i += 2) {  // every other pose, 3 ms late, 0.5 m off in y
    e.push_back(make_pose(i, 0.5, 0));
    te.push_back(0.1 * i + 0.003);
  }
  const ApeResult r = ape(test::tum_trajectory(e, te), test::tum_trajectory(g, tg));
  EXPECT_EQ(r.matched, 10u);
  EXPECT_DOUBLE_EQ(r.coverage, 0.5);
  EXPECT_NEAR(r.error.max, 0.5, 1e-12);
  EXPECT_NEAR(r.error.std, 0.0, 1e-12);
}

}  // namespace
}  // namespace pl::eval
