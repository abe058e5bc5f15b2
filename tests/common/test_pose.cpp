#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include "pl/common/error.hpp"
#include "pl/common/pose.hpp"
#include "test_util.hpp"

using pl::test::TempDir;
using pl::test::write_file;

namespace {

pl::Trajectory spiral(std::size_t n) {
  pl::Trajectory t;
  for (std::size_t i = 0; i < n; ++i) {
    double a = 0.05 * static_cast<double>(i);
    t.poses.push_back(pl::make_pose(10 * std::cos(a), 10 * std::sin(a), 0.1 * a, 0.01 * a, -0.02 * a, a + M_PI / 2));
    t.times.push_back(1000.0 + 0.1 * static_cast<double>(i));
  }
  return t;
}

}  // namespace

TEST(Pose, MakePoseAndYaw) {
  pl::Pose p = pl::make_pose(1, 2, 3, 0, 0, 0.7);
  EXPECT_NEAR(pl::yaw_of(p), 0.7, 1e-12);
  EXPECT_NEAR(pl::rotation_angle(p), 0.7, 1e-12);
  EXPECT_TRUE(p.translation().isApprox(Eigen::Vector3d(1, 2, 3)));
  // Rz(yaw) Ry(pitch) Rx(roll): the x axis tilts down with positive pitch.
  pl::Pose q = pl::make_pose(0, 0, 0, 0, 0.1, 0);
  EXPECT_NEAR((q.linear() * Eigen::Vector3d::UnitX()).z(), -std::sin(0.1), 1e-12);
}

TEST(Pose, InterpolateHalfway) {
  pl::Pose a = pl::make_pose(0, 0, 0, 0, 0, 0), b = pl::make_pose(2, 4, 0, 0, 0, 1.0);
  pl::Pose m = pl::interpolate(a, b, 0.5);
  EXPECT_TRUE(m.translation().isApprox(Eigen::Vector3d(1, 2, 0)));
  EXPECT_NEAR(pl::yaw_of(m), 0.5, 1e-12);
}

TEST(Pose, KittiRoundTripAndAutodetect) {
  TempDir dir;
  pl::Trajectory t = spiral(50);
  pl::write_kitti_poses(dir / "p.txt", t);
  pl::Trajectory r = pl::read_trajectory(dir / "p.txt");
  ASSERT_EQ(r.format, pl::PoseFormat::Kitti);
  ASSERT_EQ(r.size(), t.size());
  EXPECT_FALSE(r.has_times());
  for (std::size_t i = 0; i < t.size(); ++i) EXPECT_TRUE(r.poses[i].isApprox(t.poses[i], 1e-9)) << i;
}

TEST(Pose, TumRoundTripKeepsTimes) {
  TempDir dir;
  pl::Trajectory t = spiral(30);
  pl::write_tum_poses(dir / "p.tum", t);
  pl::Trajectory r = pl::read_trajectory(dir / "p.tum");
  ASSERT_EQ(r.format, pl::PoseFormat::Tum);
  ASSERT_EQ(r.size(), 30u);
  for (std::size_t i = 0; i < t.size(); ++i) {
    EXPECT_NEAR(r.times[i], t.times[i], 1e-6);
    EXPECT_TRUE(r.poses[i].isApprox(t.poses[i], 1e-9)) << i;
  }
}

TEST(Pose, TumNeedsTimes) {
  TempDir dir;
  pl::Trajectory t = spiral(3);
  t.times.clear();
  EXPECT_THROW(pl::write_tum_poses(dir / "p.tum", t), pl::Error);
}

TEST(Pose, KittiRotationIsReorthonormalized) {
  TempDir dir;
  // A rotation rounded to 4 digits is not orthonormal; the reader projects it back onto SO(3).
  write_file(dir / "p.txt", "0.7071 -0.7071 0 1 0.7071 0.7071 0 2 0 0 1 3\n");
  pl::Trajectory r = pl::read_kitti_poses(dir / "p.txt");
  EXPECT_NEAR((r.poses[0].linear() * r.poses[0].linear().transpose() - Eigen::Matrix3d::Identity()).norm(), 0, 1e-12);
  EXPECT_NEAR(pl::yaw_of(r.poses[0]), M_PI / 4, 1e-4);
}

TEST(Pose, MalformedLineNamesFileAndLine) {
  TempDir dir;
  write_file(dir / "bad.txt", "1 0 0 0 0 1 0 0 0 0 1 0\n# comment\n1 0 0 0 0 1 0 0 0 0 1\n");
  try {
    pl::read_kitti_poses(dir / "bad.txt");
    FAIL() << "no error";
  } catch (const pl::Error& e) {
    std::string m = e.what();
    EXPECT_NE(m.find("bad.txt:3"), std::string::npos) << m;
    EXPECT_NE(m.find("12 numbers"), std::string::npos) << m;
  }
  write_file(dir / "bad2.txt", "0 1 2 3 0 0 0 1\n0.1 1 2 x 0 0 0 1\n");
  try {
    pl::read_tum_poses(dir / "bad2.txt");
    FAIL() << "no error";
  } catch (const pl::Error& e) {
    std::string m = e.what();
    EXPECT_NE(m.find("bad2.txt:2"), std::string::npos) << m;
    EXPECT_NE(m.find("field 4"), std::string::npos) << m;
  }
  write_file(dir / "odd.txt", "1 2 3\n");
  EXPECT_THROW(pl::read_trajectory(dir / "odd.txt"), pl::Error);
  EXPECT_THROW(pl::read_trajectory(dir / "missing.txt"), pl::Error);
}

TEST(Pose, RotationAngleKeepsSmallAngles) {
  for (double a : {1e-9, 1e-6, 1e-3, 0.5, 3.0}) EXPECT_NEAR(pl::rotation_angle(pl::make_pose(0, 0, 0, 0, 0, a)), a, 1e-12 + 1e-9 * a);
}

// A vehicle on a circle at a steady speed and turn rate: continuing one step's motion at its twist
// lands on the circle again, where scaling the step's translation and angle apart leaves the arc.
TEST(Pose, ScaleMotionStaysOnTheArc) {
  const double radius = 39.0, step = 5.0 * M_PI / 180.0;  // drive 0005's bends: 3.4 m a step
  auto on_circle = [&](double a) { return pl::make_pose(radius * std::sin(a), radius * (1.0 - std::cos(a)), 0.0, 0.0, 0.0, a); };
  const pl::Pose a = on_circle(0.0), b = on_circle(3.0 * step);
  const pl::Pose predicted = b * pl::scale_motion(a.inverse() * b, 1.0 / 3.0);
  const pl::Pose truth = on_circle(4.0 * step);
  EXPECT_LT((predicted.translation() - truth.translation()).norm(), 1e-9);
  EXPECT_NEAR(pl::yaw_of(predicted), 4.0 * step, 1e-12);
  // The chord scaled: a third of the translation from b, turned by a third of the angle.
  pl::Pose chord = pl::Pose::Identity();
  const pl::Pose d = a.inverse() * b;
  chord.linear() = pl::rotation_from_vector(pl::rotation_vector(d.linear()) / 3.0);
  chord.translation() = d.translation() / 3.0;
  EXPECT_GT(((b * chord).translation() - truth.translation()).norm(), 0.03);
  // exp and log are inverse, at a large and a tiny angle; f = 0 is no motion, f = 1 the motion.
  for (const double yaw : {2.5, 1e-7}) {
    const pl::Pose m = pl::make_pose(1.0, -2.0, 0.5, 0.1, -0.2, yaw);
    EXPECT_TRUE(pl::pose_from_twist(pl::twist_of(m)).isApprox(m, 1e-9));
    EXPECT_TRUE(pl::scale_motion(m, 1.0).isApprox(m, 1e-9));
    EXPECT_TRUE(pl::scale_motion(m, 0.0).isApprox(pl::Pose::Identity(), 1e-12));
    EXPECT_TRUE(pl::scale_motion(pl::scale_motion(m, 0.5), 2.0).isApprox(m, 1e-9));
  }
}

// The same rotation read two ways (a matrix, and the quaternion a writer made from it, as a
// recording of a KITTI drive carries its truth) differs in the last bits; on the grid both are the
// same bits, a pose already on it stays as it is, and no rotation moves by more than a few
// nanoradians. Random rotations, and the turns whose quaternion components tie (90 and 180 deg).
TEST(Pose, CanonicalRotationGivesTheSameBitsFromAMatrixAndItsQuaternion) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> angle(-M_PI, M_PI);
  std::vector<pl::Pose> poses;
  for (int i = 0; i < 2000; ++i) poses.push_back(pl::make_pose(1, 2, 3, 0.1 * angle(rng), 0.1 * angle(rng), angle(rng)));
  for (double yaw : {0.0, M_PI / 2, -M_PI / 2, M_PI, -M_PI, M_PI / 4}) poses.push_back(pl::make_pose(0, 0, 0, 0, 0, yaw));
  poses.push_back(pl::make_pose(0, 0, 0, M_PI / 2, 0, M_PI / 2));
  int differed = 0;
  for (const pl::Pose& p : poses) {
    // The quaternion written at 17 digits and read back, as a TUM file or a ROS message carries it.
    const Eigen::Quaterniond q(p.linear());
    char text[128];
    std::snprintf(text, sizeof(text), "%.17g %.17g %.17g %.17g", q.w(), q.x(), q.y(), q.z());
    double w, x, y, z;
    ASSERT_EQ(std::sscanf(text, "%lf %lf %lf %lf", &w, &x, &y, &z), 4);
    pl::Pose read = p;
    read.linear() = Eigen::Quaterniond(w, x, y, z).normalized().toRotationMatrix();
    differed += read.linear() != p.linear();
    const pl::Pose a = pl::canonical_rotation(p), b = pl::canonical_rotation(read);
    EXPECT_EQ(a.linear(), b.linear()) << "yaw " << pl::yaw_of(p);
    EXPECT_EQ(a.translation(), p.translation());
    EXPECT_EQ(pl::canonical_rotation(a).linear(), a.linear());
    EXPECT_LT(pl::rotation_angle(p.inverse() * a), 1e-8);
    EXPECT_LT((a.linear() * a.linear().transpose() - Eigen::Matrix3d::Identity()).norm(), 1e-14);
  }
  EXPECT_GT(differed, 100);  // the case it is for: the two readings do differ in their last bits
}
