// Pose graph back end: a drifting odometry chain pulled onto noisy GPS fixes with multipath outliers,
// the chain left alone without GPS, the odometry in another frame, GPS fixes tied to scans by time,
// and `pl-map build --poses lidar --gps --report` on a simulated drive against its ground truth.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <random>

#include <nlohmann/json.hpp>

#include "pl/common/error.hpp"
#include "pl/common/geo.hpp"
#include "pl/common/pose.hpp"
#include "pl/maps/pose_graph.hpp"
#include "pl/recordings/dataset.hpp"
#include "test_util.hpp"

using pl::maps::GpsEdge;
using pl::maps::Information6;
using pl::maps::PoseList;
using pl::test::TempDir;

namespace {

const Eigen::Vector3d kLever(-0.5, 0.0, 0.25);

// A winding drive: 0.5 m a scan, heading changing slowly, gentle hills.
PoseList truth_drive(std::size_t n) {
  PoseList out;
  double x = 0, y = 0, yaw = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const double s = static_cast<double>(i);
    out.push_back(pl::make_pose(x, y, 2.0 * std::sin(s / 150.0), 0.0, 0.01 * std::cos(s / 150.0), yaw));
    yaw += 0.012 * std::sin(s / 80.0);
    x += 0.5 * std::cos(yaw);
    y += 0.5 * std::sin(yaw);
  }
  return out;
}

// The truth's scan-to-scan motions with a yaw bias (0.034 deg/m) and noise, chained from the first true pose.
PoseList drifting_odometry(const PoseList& truth, int seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> nt(0.0, 0.003), nr(0.0, 0.0002);
  PoseList out{truth[0]};
  for (std::size_t i = 1; i < truth.size(); ++i) {
    pl::Pose d = truth[i - 1].inverse() * truth[i];
    const pl::Pose err = pl::make_pose(nt(rng), nt(rng), nt(rng), nr(rng), nr(rng), 0.0003 + nr(rng));
    out.push_back(out.back() * d * err);
  }
  return out;
}

// Well-constrained registrations, except every 50th scan: not registered (zero information).
std::vector<Information6> front_end_information(std::size_t n) {
  std::vector<Information6> info(n, Information6::Zero());
  for (std::size_t i = 1; i < n; ++i) {
    if (i % 50 == 0) continue;
    info[i].diagonal() << 200, 200, 400, 40000, 40000, 20000;
  }
  return info;
}

double mean_error(const PoseList& a, const PoseList& b) {
  double sum = 0;
  for (std::size_t i = 0; i < a.size(); ++i) sum += (a[i].translation() - b[i].translation()).norm();
  return sum / static_cast<double>(a.size());
}

// A fix every 2nd scan (rtk-fixed, 3 cm noise), and `outliers` of them 10 m off (multipath).
std::vector<GpsEdge> gps_fixes(const PoseList& truth, int outliers, int seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, 0.03);
  std::vector<GpsEdge> out;
  for (std::size_t i = 0; i < truth.size(); i += 2) {
    GpsEdge g;
    g.scan = i;
    g.antenna_world = truth[i] * kLever + Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
    g.std_m = 0.03;
    g.status = pl::kGpsFixed;
    out.push_back(g);
  }
  for (int k = 0; k < outliers; ++k) {
    GpsEdge& g = out[out.size() * static_cast<std::size_t>(2 * k + 1) / static_cast<std::size_t>(2 * outliers)];
    g.antenna_world += Eigen::Vector3d(6.0, -8.0, 0.0);  // 10 m off, reported sigma unchanged
  }
  return out;
}

}  // namespace

TEST(PoseGraph, GpsPullsADriftingChainOntoTheTruthAndRejectsMultipath) {
  const PoseList truth = truth_drive(600);
  const PoseList odo = drifting_odometry(truth, 7);
  const double before = mean_error(odo, truth);
  ASSERT_GT(before, 2.0);  // the chain really drifts (the yaw bias alone: metres over 300 m)
  pl::maps::PoseGraphReport rep;
  const PoseList opt = pl::maps::optimize_trajectory(odo, front_end_information(odo.size()), gps_fixes(truth, 10, 3), kLever, {}, &rep);
  ASSERT_EQ(opt.size(), odo.size());
  const double after = mean_error(opt, truth);
  EXPECT_LT(after, 0.05) << "before " << before;
  EXPECT_LT(after, 0.02 * before);
  double worst = 0, worst_rot = 0, worst_yaw = 0, odo_worst_yaw = 0;
  auto yaw_error = [](const pl::Pose& a, const pl::Pose& b) { return std::abs(std::remainder(pl::yaw_of(a) - pl::yaw_of(b), 2 * M_PI)); };
  for (std::size_t i = 0; i < opt.size(); ++i) {
    worst = std::max(worst, (opt[i].translation() - truth[i].translation()).norm());
    worst_rot = std::max(worst_rot, pl::rotation_angle(truth[i].inverse() * opt[i]));
    worst_yaw = std::max(worst_yaw, yaw_error(opt[i], truth[i]));
    odo_worst_yaw = std::max(odo_worst_yaw, yaw_error(odo[i], truth[i]));
  }
  EXPECT_LT(worst, 0.15);
  // Heading follows the fixes; roll about the direction of travel is seen only through the lever arm.
  EXPECT_GT(odo_worst_yaw, 5.0 * M_PI / 180.0);
  EXPECT_LT(worst_yaw, 0.75 * M_PI / 180.0);  // worst at the ends of the unregistered scans
  EXPECT_LT(worst_rot, 1.0 * M_PI / 180.0);
  EXPECT_GE(rep.keyframes, 200u);  // 0.5 m a scan, a keyframe every metre (2 or 3 scans on curves)
  EXPECT_LE(rep.keyframes, 300u);
  EXPECT_EQ(rep.gps_edges, 300u);
  EXPECT_EQ(rep.gps_outliers, 10u);
  EXPECT_GT(rep.gps_rms_before_m, 1.0);
  EXPECT_LT(rep.gps_rms_after_m, 0.06);
  EXPECT_EQ(rep.termination, "CONVERGENCE");
  EXPECT_GT(rep.iterations, 0);
}

TEST(PoseGraph, WithoutRobustLossTheOutliersWouldPullTheTrajectory) {
  // The same drive with a kernel so wide it is quadratic: the 10 m fixes drag the poses near them.
  const PoseList truth = truth_drive(600);
  const PoseList odo = drifting_odometry(truth, 7);
  pl::maps::PoseGraphConfig wide;
  wide.gps_kernel_sigmas = 1e6;
  const auto gps = gps_fixes(truth, 10, 3);
  const PoseList robust = pl::maps::optimize_trajectory(odo, front_end_information(odo.size()), gps, kLever, {});
  const PoseList plain = pl::maps::optimize_trajectory(odo, front_end_information(odo.size()), gps, kLever, wide);
  EXPECT_GT(mean_error(plain, truth), 3.0 * mean_error(robust, truth));
}

TEST(PoseGraph, AFewNoisyFixesDoNotTiltAShortDrive) {
  // Drive 0005's shape: 70 m with a bend, level; a consumer receiver (1.5 m, 2.25 m vertical) once a
  // second, the antenna 1.2 m off the sensor. The fixes hardly see the drive's tilt; only the prior
  // on the first keyframe's gravity direction holds it.
  PoseList truth;
  double x = 0, y = 0, yaw = 0;
  for (int i = 0; i < 154; ++i) {
    truth.push_back(pl::make_pose(x, y, 0, 0, 0, yaw));
    yaw += 0.012 * std::sin(i / 25.0);
    x += 0.45 * std::cos(yaw), y += 0.45 * std::sin(yaw);
  }
  const Eigen::Vector3d lever(-0.81, 0.32, -0.80);
  int worse = 0;
  for (int seed = 1; seed <= 5; ++seed) {
    std::mt19937 rng(seed);
    std::normal_distribution<double> noise(0.0, 1.5);
    std::vector<GpsEdge> gps;
    for (std::size_t i = 0; i < truth.size(); i += 10) {
      GpsEdge g;
      g.scan = i;
      g.antenna_world = truth[i] * lever + Eigen::Vector3d(noise(rng), noise(rng), 1.5 * noise(rng));
      g.std_m = 1.5;
      g.status = pl::kGpsSingle;
      gps.push_back(g);
    }
    auto max_tilt_deg = [](const PoseList& poses) {
      double worst = 0;
      for (const pl::Pose& p : poses) worst = std::max(worst, std::acos(std::clamp(p.linear()(2, 2), -1.0, 1.0)) * 180.0 / M_PI);
      return worst;
    };
    const PoseList held = pl::maps::optimize_trajectory(truth, front_end_information(truth.size()), gps, lever, {});
    pl::maps::PoseGraphConfig free;
    free.tilt_prior_deg = 0;
    const PoseList loose = pl::maps::optimize_trajectory(truth, front_end_information(truth.size()), gps, lever, free);
    EXPECT_LT(max_tilt_deg(held), 0.3) << seed;
    worse += max_tilt_deg(loose) > 1.0;
  }
  EXPECT_GE(worse, 3);  // without the prior, most draws tilt the drive by more than a degree
}

TEST(PoseGraph, WithoutGpsTheChainIsUnchanged) {
  const PoseList truth = truth_drive(200);
  const PoseList odo = drifting_odometry(truth, 11);
  for (const auto& gps : {std::vector<GpsEdge>{}, gps_fixes(truth, 0, 1)}) {
    std::vector<GpsEdge> unusable = gps;
    for (GpsEdge& g : unusable) g.status = pl::kGpsNone;  // dropped
    pl::maps::PoseGraphReport rep;
    const PoseList opt = pl::maps::optimize_trajectory(odo, front_end_information(odo.size()), unusable, kLever, {}, &rep);
    ASSERT_EQ(opt.size(), odo.size());
    for (std::size_t i = 0; i < odo.size(); ++i) {
      EXPECT_LT((opt[i].translation() - odo[i].translation()).norm(), 1e-9) << i;
      EXPECT_LT(pl::rotation_angle(odo[i].inverse() * opt[i]), 1e-9) << i;
    }
    EXPECT_EQ(rep.gps_edges, 0u);
    EXPECT_EQ(rep.termination, "no gps or loops");
    EXPECT_GE(rep.keyframes, 66u);
    EXPECT_LE(rep.keyframes, 100u);
  }
}

TEST(PoseGraph, OdometryInAnotherFrameIsBroughtIntoTheGpsFrame) {
  // Perfect odometry started at the origin: the fixes alone place it (yaw, translation and the lever arm).
  const PoseList truth = truth_drive(300);
  PoseList odo;
  const pl::Pose shift = pl::make_pose(-40.0, 120.0, 3.0, 0.0, 0.0, 2.0);
  for (const pl::Pose& p : truth) odo.push_back(shift * p);
  std::vector<GpsEdge> gps = gps_fixes(truth, 0, 5);
  for (GpsEdge& g : gps) g.status = pl::kGpsFloat, g.std_m = 0.03;  // floored at 0.1 m by the status
  pl::maps::PoseGraphReport rep;
  const PoseList opt = pl::maps::optimize_trajectory(odo, {}, gps, kLever, {}, &rep);
  EXPECT_LT(mean_error(opt, truth), 0.03);
  EXPECT_GT(rep.gps_rms_before_m, 50.0);
  EXPECT_LT(rep.gps_rms_after_m, 0.06);
  EXPECT_EQ(rep.gps_outliers, 0u);
}

TEST(PoseGraph, InterpolatedFixesUseTheMotionBetweenScans) {
  // Fixes half way between scans, 2.5 m a scan: taking the earlier scan's pose would be 1.25 m off.
  PoseList truth;
  for (int i = 0; i < 100; ++i) truth.push_back(pl::make_pose(2.5 * i, 0.02 * i * i, 0.0, 0.0, 0.0, std::atan(0.016 * i)));
  PoseList odo;
  for (const pl::Pose& p : truth) odo.push_back(pl::make_pose(5, 5, 0) * p);
  std::vector<GpsEdge> gps;
  for (std::size_t i = 0; i + 1 < truth.size(); ++i) {
    GpsEdge g;
    g.scan = i;
    g.fraction = 0.5;
    g.antenna_world = pl::interpolate(truth[i], truth[i + 1], 0.5) * kLever;
    g.std_m = 0.02;
    g.status = pl::kGpsFixed;
    gps.push_back(g);
  }
  const PoseList opt = pl::maps::optimize_trajectory(odo, {}, gps, kLever, {});
  EXPECT_LT(mean_error(opt, truth), 0.01);
}

TEST(PoseGraph, RejectsMismatchedInput) {
  const PoseList truth = truth_drive(10);
  EXPECT_THROW(pl::maps::optimize_trajectory(truth, std::vector<Information6>(3), {}, kLever, {}), pl::Error);
  GpsEdge g;
  g.scan = 10;
  g.status = pl::kGpsFixed;
  EXPECT_THROW(pl::maps::optimize_trajectory(truth, {}, {g}, kLever, {}), pl::Error);
  EXPECT_TRUE(pl::maps::optimize_trajectory({}, {}, {}, kLever, {}).empty());
}

TEST(PoseGraph, GpsEdgesFromADatasetFollowTheScanTimes) {
  pl::Dataset ds;
  ds.dir = "synthetic";
  ds.times = {0.0, 0.1, 0.2, 0.3};
  const pl::GeoPoint origin{49.0, 8.4, 110.0};
  const pl::EnuFrame enu(origin);
  auto fix = [&](double t, const Eigen::Vector3d& p, int status) {
    pl::GpsFix f;
    f.t = t;
    f.position = enu.to_geodetic(p);
    f.std_m = 0.02;
    f.status = status;
    return f;
  };
  ds.gps = {fix(-0.02, {1, 2, 3}, pl::kGpsFixed), fix(0.05, {4, 5, 6}, pl::kGpsFloat), fix(0.2, {7, 8, 9}, pl::kGpsSingle),
            fix(0.15, {0, 0, 0}, pl::kGpsNone), fix(0.32, {1, 1, 1}, pl::kGpsDgps), fix(0.5, {2, 2, 2}, pl::kGpsFixed),
            fix(-0.2, {3, 3, 3}, pl::kGpsFixed)};
  EXPECT_THROW(pl::maps::gps_edges_from_dataset(ds), pl::Error);  // no geographic reference
  ds.projection.kind = pl::WorldProjection::Kind::Enu;
  ds.projection.origin = origin;
  const auto edges = pl::maps::gps_edges_from_dataset(ds);
  ASSERT_EQ(edges.size(), 4u);  // status none, and the fixes 0.2 s outside the drive, dropped
  EXPECT_EQ(edges[0].scan, 0u);
  EXPECT_DOUBLE_EQ(edges[0].fraction, 0.0);
  EXPECT_LT((edges[0].antenna_world - Eigen::Vector3d(1, 2, 3)).norm(), 1e-6);
  EXPECT_EQ(edges[1].scan, 0u);
  EXPECT_NEAR(edges[1].fraction, 0.5, 1e-9);
  EXPECT_EQ(edges[1].status, pl::kGpsFloat);
  EXPECT_EQ(edges[2].scan, 1u);  // exactly at scan 2: the end of the span from scan 1
  EXPECT_NEAR(edges[2].fraction, 1.0, 1e-9);
  EXPECT_EQ(edges[3].scan, 3u);
  EXPECT_LT((edges[3].antenna_world - Eigen::Vector3d(1, 1, 1)).norm(), 1e-6);
}

// With --gps the ground truth is not used: the odometry starts in the first scan's frame and the
// fixes place it. It lands within a few centimetres of the truth, near what the odometry achieves
// when it is handed the true first pose.
TEST(PoseGraph, PlMapBuildWithGpsPlacesTheDriveWithoutGroundTruth) {
  TempDir dir;
  auto sim = pl::test::run(pl::test::tool("pl-sim") + " --route loop --frames 150 --out " + (dir / "drive"));
  ASSERT_EQ(sim.exit_code, 0) << sim.output;
  const std::string map = pl::test::tool("pl-map") + " build --dataset " + (dir / "drive");
  auto lidar = pl::test::run(map + " --poses lidar --traj-out " + (dir / "lidar.txt") + " --out " + (dir / "lidar.pcd"));
  ASSERT_EQ(lidar.exit_code, 0) << lidar.output;
  auto gps = pl::test::run(map + " --poses lidar --gps --traj-out " + (dir / "gps.txt") + " --report " + (dir / "report.json") +
                           " --odometry-out " + (dir / "odometry.txt") + " --out " + (dir / "gps.pcd"));
  ASSERT_EQ(gps.exit_code, 0) << gps.output;
  EXPECT_NE(gps.output.find("pose graph:"), std::string::npos) << gps.output;

  // --odometry-out: the odometry's own poses from the same run, before the graph, started where the
  // graph put the first scan. Started at the first true pose instead, they are the report's "before".
  const pl::Trajectory odometry = pl::read_trajectory(dir / "odometry.txt"), graph = pl::read_trajectory(dir / "gps.txt");
  const pl::Dataset drive = pl::open_dataset(dir / "drive");
  ASSERT_EQ(odometry.size(), 150u);
  ASSERT_EQ(graph.size(), 150u);
  EXPECT_LT((odometry.poses[0].translation() - graph.poses[0].translation()).norm(), 1e-6);
  auto error_from_truth = [&](const pl::Trajectory& t) {
    const pl::Pose to_truth = drive.ground_truth.poses[0] * t.poses[0].inverse();
    double sum = 0.0;
    for (std::size_t i = 0; i < 150; ++i) sum += ((to_truth * t.poses[i]).translation() - drive.ground_truth.poses[i].translation()).norm();
    return sum / 150.0;
  };
  const auto before_m = nlohmann::json::parse(pl::test::read_file(dir / "report.json")).at("mean_error_before_m").get<double>();
  EXPECT_NEAR(error_from_truth(odometry), before_m, 1e-6);  // the graph's poses so started: 2 mm from it

  auto ape = [&](const std::string& est) {
    auto r = pl::test::run(pl::test::tool("pl-eval") + " ape --json --est " + est + " --gt " + (dir / "drive/poses.txt"));
    EXPECT_EQ(r.exit_code, 0) << r.output;
    return nlohmann::json::parse(r.output.substr(r.output.find('{')));
  };
  const auto ape_lidar = ape(dir / "lidar.txt"), ape_gps = ape(dir / "gps.txt");
  EXPECT_EQ(ape_gps["matched"].get<int>(), 150);
  const double lidar_mean = ape_lidar["mean"].get<double>(), gps_mean = ape_gps["mean"].get<double>();
  EXPECT_LT(gps_mean, 0.05);
  EXPECT_LT(gps_mean, 2.0 * lidar_mean);

  const auto report = nlohmann::json::parse(pl::test::read_file(dir / "report.json"));
  const auto& pg = report.at("pose_graph");
  EXPECT_GT(pg.at("keyframes").get<int>(), 20);
  EXPECT_GT(pg.at("gps_edges").get<int>(), 100);
  EXPECT_LT(pg.at("gps_outliers").get<int>(), pg.at("gps_edges").get<int>() / 2);
  EXPECT_EQ(pg.at("termination").get<std::string>(), "CONVERGENCE");
  // The report's "before" is the odometry as if started at the first true pose: the --poses lidar run,
  // solved in another frame (the first scan's, not the world's), where float rounding and the
  // deskewing of swept scans take the two apart by up to a few centimetres over 150 scans.
  EXPECT_NEAR(report.at("mean_error_before_m").get<double>(), lidar_mean, 0.2 * lidar_mean);
  EXPECT_NEAR(report.at("mean_error_after_m").get<double>(), gps_mean, 1e-4);

  // --gps only corrects odometry; and the fixes need a geographic reference.
  auto gt = pl::test::run(map + " --poses gt --gps --out " + (dir / "x.pcd"));
  EXPECT_EQ(gt.exit_code, 2);
  EXPECT_NE(gt.output.find("--gps needs --poses lidar"), std::string::npos) << gt.output;
  gt = pl::test::run(map + " --poses gt --odometry-out " + (dir / "x.txt") + " --out " + (dir / "x.pcd"));
  EXPECT_EQ(gt.exit_code, 2);
  EXPECT_NE(gt.output.find("--odometry-out needs --poses lidar"), std::string::npos) << gt.output;
  auto meta = nlohmann::json::parse(pl::test::read_file(dir / "drive/meta.json"));
  meta.erase("origin");
  pl::test::write_file(dir / "drive/meta.json", meta.dump());
  auto noref = pl::test::run(map + " --poses lidar --gps --out " + (dir / "x.pcd"));
  EXPECT_NE(noref.exit_code, 0);
  EXPECT_NE(noref.output.find("cannot be placed in the world frame"), std::string::npos) << noref.output;
}
