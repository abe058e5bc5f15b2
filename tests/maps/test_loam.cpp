// LOAM-style odometry: features on a ray-cast scene with known geometry, degenerate and empty
// scans, a known motion, a simulated drive against its ground truth, and `pl-map build --poses lidar`.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <random>
#include <sstream>

#include "pl/common/error.hpp"
#include "pl/common/stats.hpp"
#include "pl/maps/loam.hpp"
#include "pl/recordings/dataset.hpp"
#include "test_util.hpp"

using pl::test::TempDir;

namespace {

// A scene of axis-aligned boxes over flat ground, ray cast by a 64-beam spinning sensor.
struct Box {
  Eigen::Vector3d lo, hi;
};
struct Scene {
  double ground_z = -1.73;
  bool ground = true;
  std::vector<Box> boxes;
};

// Ray from o along unit d: distance to the nearest surface, or infinity.
double cast(const Scene& s, const Eigen::Vector3d& o, const Eigen::Vector3d& d) {
  double best = std::numeric_limits<double>::infinity();
  if (s.ground && d.z() < -1e-9) best = (s.ground_z - o.z()) / d.z();
  for (const Box& b : s.boxes) {
    double t0 = 0, t1 = best;
    bool hit = true;
    for (int k = 0; k < 3 && hit; ++k) {
      if (std::abs(d[k]) < 1e-12) {
        hit = o[k] >= b.lo[k] && o[k] <= b.hi[k];
        continue;
      }
      double a = (b.lo[k] - o[k]) / d[k], c = (b.hi[k] - o[k]) / d[k];
      if (a > c) std::swap(a, c);
      t0 = std::max(t0, a);
      t1 = std::min(t1, c);
      hit = t0 <= t1;
    }
    if (hit && t0 > 0 && t0 < best) best = t0;
  }
  return best;
}

// A scan from `pose` (sensor frame), laser by laser like KITTI: each ring one counter-clockwise turn
// from straight ahead. `rings` gets the beam of every point.
pl::Scan scan_scene(const Scene& s, const pl::Pose& pose, std::vector<std::uint16_t>& rings, double noise_m = 0.0, int seed = 1) {
  constexpr int azimuths = 1800;
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, noise_m);
  pl::Scan out;
  rings.clear();
  for (int b = 0; b < 64; ++b) {
    const double el = (2.0 - 26.8 * b / 63.0) * M_PI / 180.0;
    for (int a = 0; a < azimuths; ++a) {
      const double az = 2.0 * M_PI * a / azimuths;
      const Eigen::Vector3d ds(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el));
      const double t = cast(s, pose.translation(), pose.linear() * ds);
      if (!(t < 100.0)) continue;
      const Eigen::Vector3d p = (t + (noise_m > 0 ? noise(rng) : 0.0)) * ds;
      out.push_back({static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z()), 0.5f});
      rings.push_back(static_cast<std::uint16_t>(b));
    }
  }
  return out;
}

// A pillar ahead, a back wall and two side walls: every direction of motion is held.
Scene street() {
  Scene s;
  s.boxes.push_back({{8, -1, -1.73}, {10, 1, 4}});      // pillar
  s.boxes.push_back({{30, -40, -1.73}, {31, 40, 10}});  // back wall
  s.boxes.push_back({{-40, 12, -1.73}, {30, 13, 8}});   // left wall
  s.boxes.push_back({{-40, -16, -1.73}, {30, -15, 6}});  // right wall
  s.boxes.push_back({{-20, 5, -1.73}, {-18, 6, 2}});    // a kiosk behind on the left
  return s;
}

double azimuth_deg(const Eigen::Vector3f& p) { return std::atan2(p.y(), p.x()) * 180.0 / M_PI; }

}  // namespace

TEST(LoamFeatures, EdgesOnCornersNoneOnShadowsPlanesOnSurfaces) {
  Scene s;
  s.boxes.push_back({{8, -1, -1.73}, {10, 1, 4}});      // the pillar: silhouettes at azimuth +-7.125 deg
  s.boxes.push_back({{30, -40, -1.73}, {31, 40, 10}});  // the wall behind it
  std::vector<std::uint16_t> rings;
  pl::Scan scan = scan_scene(s, pl::Pose::Identity(), rings);
  pl::maps::LoamConfig cfg;
  pl::maps::LoamFeatures f = pl::maps::extract_loam_features(scan, rings, cfg);
  ASSERT_EQ(f.edge_time.size(), f.edges.size());
  ASSERT_EQ(f.plane_time.size(), f.planes.size());
  int at_corners = 0;
  const double silhouette = std::atan2(1.0, 8.0) * 180.0 / M_PI;
  for (const auto& e : f.edges) {
    const double range = e.head<2>().norm();
    // The near side of the pillar's silhouette: its two front vertical edges.
    if (std::abs(e.x() - 8.0f) < 0.05f && std::abs(std::abs(e.y()) - 1.0f) < 0.15f) ++at_corners;
    // The far side of a silhouette borders the pillar's shadow: never an edge.
    EXPECT_FALSE(range > 9.0 && std::abs(std::abs(azimuth_deg(e)) - silhouette) < 0.6) << e.transpose();
  }
  EXPECT_GE(at_corners, 20) << f.edges.size() << " edges";
  // Plane points on all three surfaces, none on the pillar's vertical edges.
  int ground = 0, front = 0, wall = 0;
  for (const auto& p : f.planes) {
    ground += std::abs(p.z() + 1.73f) < 0.01f;
    front += std::abs(p.x() - 8.0f) < 0.01f;
    wall += std::abs(p.x() - 30.0f) < 0.01f;
    EXPECT_FALSE(std::abs(p.x() - 8.0f) < 0.01f && std::abs(std::abs(p.y()) - 1.0f) < 0.05f) << p.transpose();
  }
  EXPECT_GT(ground, 300);
  EXPECT_GT(front, 20);
  EXPECT_GT(wall, 50);
  // One point per leaf: no two plane points share a 0.4 m voxel.
  std::vector<std::array<long, 3>> keys;
  for (const auto& p : f.planes)
    keys.push_back({std::lround(std::floor(p.x() / 0.4)), std::lround(std::floor(p.y() / 0.4)), std::lround(std::floor(p.z() / 0.4))});
  std::sort(keys.begin(), keys.end());
  EXPECT_EQ(std::adjacent_find(keys.begin(), keys.end()), keys.end());
  // Sweep times: straight ahead 0, right -1/4, left +1/4 (a counter-clockwise spin).
  for (std::size_t i = 0; i < f.planes.size(); ++i)
    EXPECT_NEAR(f.plane_time[i], azimuth_deg(f.planes[i]) / 360.0, 1e-5);
}

TEST(LoamFeatures, OneRingPerPointOrAClearError) {
  pl::Scan scan(10, pl::PointXYZI{5, 0, 0, 0});
  std::vector<std::uint16_t> rings(9, 0);
  EXPECT_THROW(pl::maps::extract_loam_features(scan, rings), pl::Error);
  pl::maps::LoamOdometry odo;
  EXPECT_THROW(odo.add(scan, rings, 0.0), pl::Error);
  pl::maps::LoamConfig bad;
  bad.map_cell_m = 0;
  EXPECT_THROW(pl::maps::LoamOdometry{bad}, pl::Error);
  // Too short rings, points inside the minimum range, non-finite points: no features, no crash.
  rings.push_back(0);
  scan[3].x = std::numeric_limits<float>::quiet_NaN();
  scan[4] = {0.5f, 0, 0, 0};
  auto f = pl::maps::extract_loam_features(scan, rings);
  EXPECT_TRUE(f.edges.empty());
  EXPECT_TRUE(f.planes.empty());
}

TEST(LoamOdometry, RecoversAKnownMotionWithFullInformation) {
  const Scene s = street();
  std::vector<std::uint16_t> r0, r1;
  const pl::Pose start = pl::make_pose(100.0, -50.0, 3.0, 0.0, 0.0, 0.3);  // the odometry frame is the world's
  const pl::Pose moved = pl::make_pose(0.8, 0.15, 0.02, 0.002, -0.003, 0.02);
  pl::Scan a = scan_scene(s, pl::Pose::Identity(), r0), b = scan_scene(s, moved, r1);
  pl::maps::LoamOdometry odo;
  odo.start(start);
  pl::maps::LoamFrame f0 = odo.add(a, r0, 0.0);
  EXPECT_TRUE(f0.pose.isApprox(start));
  EXPECT_TRUE(f0.keyframe);
  EXPECT_GT(odo.map_planes(), 500u);
  EXPECT_GT(odo.map_edges(), 20u);
  pl::maps::LoamFrame f1 = odo.add(b, r1, 0.1);  // predicted at the first pose: 0.8 m off
  const pl::Pose truth = start * moved;
  const pl::Pose err = truth.inverse() * f1.pose;
  EXPECT_LT(err.translation().norm(), 0.01) << f1.pose.translation().transpose();
  EXPECT_LT(pl::rotation_angle(err), 0.05 * M_PI / 180.0);
  EXPECT_FALSE(f1.degenerate);
  EXPECT_GT(f1.planes, 200);
  EXPECT_GT(f1.edges, 5);
  EXPECT_GT(f1.iterations, 0);
  EXPECT_GE(f1.ms, 0.0);
  // The information: symmetric, positive definite, translation held in every direction.
  EXPECT_TRUE(f1.information.isApprox(f1.information.transpose(), 1e-9));
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>> es(f1.information);
  EXPECT_GT(es.eigenvalues()(0), 0.0);
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> et(f1.information.topLeftCorner<3, 3>());
  EXPECT_GT(et.eigenvalues()(0), 10.0);
}

TEST(LoamOdometry, ASmallLocalMapIsPrunedAsTheSensorMoves) {
  // Cells beyond 15 m are dropped (and their hash slots reused) scan after scan; the odometry still
  // follows the motion on what is left near the sensor.
  const Scene s = street();
  pl::maps::LoamConfig small;
  small.map_radius_m = 15.0;
  small.keyframe_m = 0.2;
  pl::maps::LoamOdometry pruned(small), full;
  std::vector<std::uint16_t> r;
  std::size_t most_pruned = 0, most_full = 0;
  for (int i = 0; i <= 20; ++i) {
    const pl::Pose truth = pl::make_pose(-0.3 * i, 0.02 * i, 0.0, 0.0, 0.0, 0.004 * i);  // backwards, away from the pillar
    pl::Scan scan = scan_scene(s, truth, r, 0.01, i);
    pl::maps::LoamFrame a = pruned.add(scan, r, 0.1 * i), b = full.add(scan, r, 0.1 * i);
    EXPECT_LT((a.pose.translation() - truth.translation()).norm(), 0.03) << i;
    EXPECT_LT((b.pose.translation() - truth.translation()).norm(), 0.02) << i;
    most_pruned = std::max(most_pruned, pruned.map_planes());
    most_full = std::max(most_full, full.map_planes());
  }
  EXPECT_LT(most_pruned * 2, most_full);
  EXPECT_GT(pruned.map_edges(), 0u);
}

TEST(LoamOdometry, EmptyAndFeaturelessScansAreFlaggedNotFatal) {
  pl::maps::LoamOdometry odo;
  pl::Scan empty;
  std::vector<std::uint16_t> none;
  pl::maps::LoamFrame f = odo.add(empty, none, 0.0);
  EXPECT_TRUE(f.degenerate);
  EXPECT_TRUE(f.pose.isApprox(pl::Pose::Identity()));
  EXPECT_EQ(f.edges + f.planes, 0);
  f = odo.add(empty, none, 0.1);
  EXPECT_TRUE(f.degenerate);
  EXPECT_TRUE(f.information.isZero());
  EXPECT_THROW(odo.start(pl::Pose::Identity()), pl::Error);  // too late: the origin is set

  // Flat ground only: height, roll and pitch are held, the rest is not. The frame is flagged and the
  // unconstrained directions keep the prediction (no motion).
  Scene flat;
  pl::maps::LoamOdometry ground;
  std::vector<std::uint16_t> r;
  pl::Scan g0 = scan_scene(flat, pl::Pose::Identity(), r, 0.02, 1);
  ground.add(g0, r, 0.0);
  pl::Scan g1 = scan_scene(flat, pl::make_pose(0, 0, 0.05), r, 0.02, 2);  // 5 cm lower ground: sensor 5 cm up
  f = ground.add(g1, r, 0.1);
  EXPECT_TRUE(f.degenerate);
  EXPECT_NEAR(f.pose.translation().z(), 0.05, 0.005);
  EXPECT_LT(f.pose.translation().head<2>().norm(), 1e-3);  // ~9 cm when weak directions are updated too
  EXPECT_LT(std::abs(pl::yaw_of(f.pose)), 1e-4);
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>> es(f.information);
  EXPECT_LT(es.eigenvalues()(0), 1e-6 * es.eigenvalues()(5));
}

TEST(LoamOdometry, ABlockedViewKeepsThePredictionAndStaysOutOfTheMap) {
  const Scene s = street();
  Scene boxed = s;  // trucks all round the sensor at the third scan
  boxed.boxes.push_back({{-1.0, 1.2, -1.73}, {4.0, 3.5, 3.0}});
  boxed.boxes.push_back({{-1.0, -3.5, -1.73}, {4.0, -1.2, 3.0}});
  boxed.boxes.push_back({{3.5, -1.2, -1.73}, {6.0, 1.2, 3.0}});
  boxed.boxes.push_back({{-3.0, -1.2, -1.73}, {-1.0, 1.2, 3.0}});
  pl::maps::LoamOdometry odo;
  std::vector<std::uint16_t> r;
  auto step = [](int i) { return pl::make_pose(0.5 * i, 0.0, 0.0); };
  for (int i = 0; i < 2; ++i) {
    pl::Scan scan = scan_scene(s, step(i), r);
    EXPECT_FALSE(odo.add(scan, r, 0.1 * i).degenerate) << i;
  }
  const std::size_t planes = odo.map_planes();
  pl::Scan blocked = scan_scene(boxed, step(2), r);
  pl::maps::LoamFrame f = odo.add(blocked, r, 0.2);
  EXPECT_TRUE(f.degenerate);
  EXPECT_FALSE(f.keyframe);
  EXPECT_LT(f.edges + f.planes, odo.config().min_correspondences);
  EXPECT_TRUE(f.information.isZero());
  EXPECT_LT((f.pose.translation() - step(2).translation()).norm(), 0.02);  // constant velocity
  EXPECT_EQ(odo.map_planes(), planes);
  pl::Scan clear = scan_scene(s, step(3), r);
  f = odo.add(clear, r, 0.3);
  EXPECT_FALSE(f.degenerate);
  EXPECT_LT((f.pose.translation() - step(3).translation()).norm(), 0.01);
}

TEST(LoamOdometry, FollowsASimulatedDrive) {
  TempDir dir;
  auto sim = pl::test::run(pl::test::tool("pl-sim") + " --route loop --frames 80 --out " + (dir / "drive"));
  ASSERT_EQ(sim.exit_code, 0) << sim.output;
  pl::Dataset ds = pl::open_dataset(dir / "drive");
  ASSERT_EQ(ds.size(), 80u);
  // pl-sim sweeps each scan over 0.1 s (point_times/): the odometry corrects its features for it.
  ASSERT_FALSE(ds.point_times_dir.empty());
  pl::maps::LoamConfig cfg;
  cfg.deskew = true;
  pl::maps::LoamOdometry odo(cfg);
  odo.start(ds.ground_truth.poses[0]);
  // The same drive on one thread, the features extracted by the caller: the same poses to the bit.
  pl::maps::LoamConfig one_cfg = cfg;
  one_cfg.threads = 1;
  pl::maps::LoamOdometry one(one_cfg);
  one.start(ds.ground_truth.poses[0]);
  double path = 0, worst_t = 0, worst_r = 0;
  std::vector<double> rel;
  pl::Pose last = pl::Pose::Identity();
  int degenerate = 0;
  for (std::size_t i = 0; i < ds.size(); ++i) {
    pl::Scan scan = ds.load_scan(i);
    const std::vector<std::uint16_t> rings = ds.rings(scan);
    pl::maps::LoamFrame f = odo.add(scan, rings, ds.times[i]);
    degenerate += f.degenerate;
    ASSERT_TRUE(one.add(pl::maps::extract_loam_features(scan, rings, one_cfg), ds.times[i]).pose.matrix() == f.pose.matrix()) << "scan " << i;
    // The first scan goes into the local map as swept: with no velocity yet it cannot be deskewed,
    // and the second scan registers to it some centimetres off. From the third on the velocity is known.
    if (i > 1) {
      const pl::Pose& g0 = ds.ground_truth.poses[i - 1];
      const pl::Pose& g1 = ds.ground_truth.poses[i];
      path += (g1.translation() - g0.translation()).norm();
      const pl::Pose err = (g0.inverse() * g1).inverse() * (last.inverse() * f.pose);
      rel.push_back(err.translation().norm());
      worst_t = std::max(worst_t, err.translation().norm());
      worst_r = std::max(worst_r, pl::rotation_angle(err));
    }
    last = f.pose;
  }
  ASSERT_GT(path, 30.0);
  const double drift = (last.translation() - ds.ground_truth.poses.back().translation()).norm();
  EXPECT_LT(drift, 0.01 * path) << drift << " m over " << path << " m";
  EXPECT_LT(pl::median(rel), 0.01);  // scan to scan: median under 1 cm
  // The worst scans are those where a turn ends within a sweep (the yaw rate changes mid-sweep; no
  // constant-velocity deskew fits it): about 5 cm and 0.17 deg on this drive.
  EXPECT_LT(worst_t, 0.06);
  EXPECT_LT(worst_r, 0.2 * M_PI / 180.0);
  EXPECT_EQ(degenerate, 0);
}

TEST(LoamOdometry, PlMapBuildWithLidarPosesWritesOnePosePerScan) {
  TempDir dir;
  auto sim = pl::test::run(pl::test::tool("pl-sim") + " --route loop --frames 15 --out " + (dir / "drive"));
  ASSERT_EQ(sim.exit_code, 0) << sim.output;
  const std::string map = pl::test::tool("pl-map") + " build --dataset " + (dir / "drive");
  auto lidar = pl::test::run(map + " --poses lidar --traj-out " + (dir / "lidar.txt") + " --out " + (dir / "lidar.pcd"));
  ASSERT_EQ(lidar.exit_code, 0) << lidar.output;
  EXPECT_NE(lidar.output.find("deskew on"), std::string::npos) << lidar.output;  // pl-sim scans are swept
  auto gt = pl::test::run(map + " --poses gt --traj-out " + (dir / "gt.txt") + " --out " + (dir / "gt.pcd"));
  ASSERT_EQ(gt.exit_code, 0) << gt.output;
  pl::Dataset ds = pl::open_dataset(dir / "drive");
  pl::Trajectory est = pl::read_kitti_poses(dir / "lidar.txt"), truth = pl::read_kitti_poses(dir / "gt.txt");
  ASSERT_EQ(est.size(), ds.size());
  ASSERT_EQ(truth.size(), ds.size());
  for (std::size_t i = 0; i < ds.size(); ++i) {
    EXPECT_LT((truth.poses[i].translation() - ds.ground_truth.poses[i].translation()).norm(), 1e-4) << i;
    // Within 8 cm: the second scan's registration to the first, swept and not deskewable (no
    // velocity yet), puts the odometry some 6 cm off, and the rest follows from there.
    EXPECT_LT((est.poses[i].translation() - ds.ground_truth.poses[i].translation()).norm(), 0.08) << i;
  }
  EXPECT_TRUE(std::ifstream(dir / "lidar.pcd").good());
  auto bad = pl::test::run(map + " --poses odometry --out " + (dir / "x.pcd"));
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_NE(bad.output.find("--poses takes gt"), std::string::npos) << bad.output;
}
