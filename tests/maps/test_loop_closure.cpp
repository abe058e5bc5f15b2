// Loop closure: the place descriptor (same place turned: near zero and the right heading; another
// place: far), loop edges in the pose graph, close_loops on a simulated town loop whose estimate has
// drifted (by position, and by place when the drift is too large for the position search), and
// `pl-map build --poses lidar --loops --report` against the ground truth.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>

#include <nlohmann/json.hpp>

#include "pl/common/error.hpp"
#include "pl/maps/loop_closure.hpp"
#include "pl/maps/pose_graph.hpp"
#include "pl/recordings/dataset.hpp"
#include "pl/registration/place_descriptor.hpp"
#include "test_util.hpp"

using pl::maps::Information6;
using pl::maps::PoseList;

namespace {

constexpr double kDeg = M_PI / 180.0;

// A little world of walls on flat ground (world frame).
std::vector<Eigen::Vector3d> world(int seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-60.0, 60.0), h(1.0, 8.0);
  std::vector<Eigen::Vector3d> pts;
  for (int k = 0; k < 40; ++k) {
    const Eigen::Vector2d a(u(rng), u(rng));
    const double yaw = u(rng), len = 4.0 + std::abs(u(rng)) / 6.0, height = h(rng);
    const Eigen::Vector2d dir(std::cos(yaw), std::sin(yaw));
    for (double s = 0; s < len; s += 0.2)
      for (double z = 0; z < height; z += 0.2) pts.emplace_back(a.x() + s * dir.x(), a.y() + s * dir.y(), z - 1.7);
  }
  for (double x = -80; x <= 80; x += 0.5)
    for (double y = -80; y <= 80; y += 0.5) pts.emplace_back(x, y, -1.7);
  return pts;
}

// The world as a scan sees it: walls within 80 m, the ground within `ground_m` (the loop tests: 40 m,
// where a LiDAR's rings reach it: a keyframe has less than half the points).
std::vector<Eigen::Vector3f> seen_from(const std::vector<Eigen::Vector3d>& w, const pl::Pose& sensor, double ground_m = 80.0) {
  std::vector<Eigen::Vector3f> out;
  const pl::Pose inv = sensor.inverse();
  for (const Eigen::Vector3d& p : w) {
    const Eigen::Vector3d q = inv * p;
    const double range = q.head<2>().norm();
    if (range < 80.0 && (p.z() > -1.65 || range < ground_m)) out.push_back(q.cast<float>());
  }
  return out;
}

// A ring road: 0.5 m a scan round a circle of radius 40 m, back to the start and 30 m on.
PoseList ring_road(std::size_t n) {
  PoseList out;
  for (std::size_t i = 0; i < n; ++i) {
    const double a = static_cast<double>(i) * 0.5 / 40.0;
    out.push_back(pl::make_pose(40.0 * std::sin(a), 40.0 - 40.0 * std::cos(a), 0.0, 0, 0, a));
  }
  return out;
}

// The truth's scan-to-scan motions with a yaw bias of `deg_per_scan`, chained from the first pose.
PoseList drifted(const PoseList& truth, double deg_per_scan) {
  PoseList out{truth[0]};
  for (std::size_t i = 1; i < truth.size(); ++i)
    out.push_back(out.back() * (truth[i - 1].inverse() * truth[i]) * pl::make_pose(0, 0, 0, 0, 0, deg_per_scan * kDeg));
  return out;
}

double mean_error(const PoseList& a, const PoseList& b) {
  double sum = 0;
  for (std::size_t i = 0; i < a.size(); ++i) sum += (a[i].translation() - b[i].translation()).norm();
  return sum / static_cast<double>(a.size());
}

// The keyframe of the first half of the drive nearest (truly) to keyframe `k`: its revisit.
std::size_t nearest_on_first_half(const PoseList& truth, const std::vector<std::size_t>& kf, std::size_t k) {
  std::size_t match = 0;
  for (std::size_t j = 0; j < kf.size() / 2; ++j)
    if ((truth[kf[j]].translation() - truth[kf[k]].translation()).norm() <
        (truth[kf[match]].translation() - truth[kf[k]].translation()).norm())
      match = j;
  return match;
}

// A loop edge as tight as close_loops makes one: 5 mm, 0.005 deg.
Information6 tight_information() {
  Information6 info = Information6::Identity() * 4e4;
  info.bottomRightCorner<3, 3>() *= 3e3;
  return info;
}

}  // namespace

TEST(PlaceDescriptor, SamePlaceTurnedMatchesWithItsHeadingAnotherPlaceDoesNot) {
  const auto w = world(3);
  const pl::Pose a_pose = pl::make_pose(2.0, 1.0, 0, 0, 0, 0.0);
  const pl::Pose b_pose = pl::make_pose(2.3, 0.8, 0, 0, 0, 50.0 * kDeg);
  const auto a = pl::registration::make_place_descriptor(seen_from(w, a_pose));
  const auto b = pl::registration::make_place_descriptor(seen_from(w, b_pose));
  const auto other = pl::registration::make_place_descriptor(seen_from(world(4), a_pose));
  const pl::registration::DescriptorMatch same = pl::registration::compare_descriptors(b, a);
  EXPECT_LT(same.distance, 0.2);
  // b's heading relative to a's: +50 deg, to within a sector (6 deg).
  EXPECT_NEAR(same.yaw_rad, 50.0 * kDeg, 6.5 * kDeg);
  EXPECT_NEAR(pl::registration::compare_descriptors(a, b).yaw_rad, -50.0 * kDeg, 6.5 * kDeg);
  EXPECT_GT(pl::registration::compare_descriptors(other, a).distance, 2.0 * same.distance + 0.1);
  // The ring key ignores the heading; another place's differs more.
  EXPECT_LT(pl::registration::ring_key_distance(a, b), pl::registration::ring_key_distance(a, other));
  EXPECT_THROW(pl::registration::compare_descriptors(a, pl::registration::make_place_descriptor({}, {10, 30, 80.0, 2.0})), pl::Error);
}

TEST(PoseGraph, ALoopEdgeTakesOutTheDriftAroundTheLoop) {
  const PoseList truth = ring_road(560);  // 280 m: once round (251 m) and on
  const PoseList odo = drifted(truth, 0.02);
  pl::maps::PoseGraph graph(odo, {}, {}, Eigen::Vector3d::Zero(), {});
  graph.optimize();
  EXPECT_NEAR(mean_error(graph.poses(), odo), 0.0, 1e-9);  // nothing to solve: the chain as it came
  const auto& kf = graph.keyframes();
  // The revisit: the last keyframe against the one nearest it on the first lap.
  const std::size_t last = kf.size() - 1;
  const std::size_t match = nearest_on_first_half(truth, kf, last);
  const Information6 info = tight_information();
  graph.add_loop(match, last, truth[kf[match]].inverse() * truth[kf[last]], info);
  graph.optimize();
  const double before = mean_error(odo, truth), after = mean_error(graph.poses(), truth);
  EXPECT_GT(before, 3.0);
  EXPECT_LT(after, before / 4.0);
  EXPECT_EQ(graph.report().loop_edges, 1u);
  EXPECT_THROW(graph.add_loop(0, kf.size(), pl::Pose::Identity(), info), pl::Error);
  EXPECT_THROW(graph.add_loop(0, 1, pl::Pose::Identity(), Information6::Zero()), pl::Error);
}

TEST(PoseGraph, GpsCostTellsATrueLoopFromAFalseOneAndSaveRestoreUndoesATrial) {
  // A good GPS along the ring road: a true loop leaves the fixes' cost alone, a loop 4 m off raises it.
  const PoseList truth = ring_road(560);
  const PoseList odo = drifted(truth, 0.002);
  std::vector<pl::maps::GpsEdge> gps;
  for (std::size_t i = 0; i < truth.size(); i += 2) {
    pl::maps::GpsEdge g;
    g.scan = i;
    g.antenna_world = truth[i].translation();
    g.std_m = 0.05;
    g.status = pl::kGpsFixed;
    gps.push_back(g);
  }
  std::vector<Information6> info(odo.size(), Information6::Identity() * 1e4);
  pl::maps::PoseGraph graph(odo, info, gps, Eigen::Vector3d::Zero(), {});
  graph.optimize();
  const auto& kf = graph.keyframes();
  const std::size_t last = kf.size() - 1;
  const std::size_t match = nearest_on_first_half(truth, kf, last);
  const Information6 tight = tight_information();
  const pl::Pose truth_rel = truth[kf[match]].inverse() * truth[kf[last]];
  const double base = graph.gps_cost();
  const std::vector<double> saved = graph.save();
  const PoseList before = graph.poses();

  const std::size_t bad = graph.add_loop(match, last, truth_rel * pl::make_pose(4.0, 0, 0, 0, 0, 0), tight);
  graph.optimize(20);
  EXPECT_GT(graph.gps_cost() - base, 10.0);
  graph.remove_loop(bad);
  graph.restore(saved);
  const PoseList back = graph.poses();
  for (std::size_t i = 0; i < back.size(); ++i) ASSERT_LT((back[i].translation() - before[i].translation()).norm(), 1e-12);
  EXPECT_NEAR(graph.gps_cost(), base, 1e-9);

  graph.add_loop(match, last, truth_rel, tight);
  graph.optimize(20);
  EXPECT_LT(graph.gps_cost() - base, 1.0);
  EXPECT_EQ(graph.report().loop_edges, 1u);
  EXPECT_THROW(graph.remove_loop(bad), pl::Error);  // already out
  EXPECT_THROW(graph.restore({1.0, 2.0}), pl::Error);
}

TEST(LoopClosure, FindsTheRevisitByPositionAndByPlaceAndTakesOutTheDrift) {
  const auto w = world(7);
  const PoseList truth = ring_road(560);
  for (double drift_deg : {0.004, 0.015}) {
    SCOPED_TRACE("yaw drift " + std::to_string(drift_deg) + " deg a scan");
    const PoseList odo = drifted(truth, drift_deg);
    pl::maps::PoseGraph graph(odo, {}, {}, Eigen::Vector3d::Zero(), {});
    std::vector<std::vector<Eigen::Vector3f>> clouds;
    for (std::size_t s : graph.keyframes()) clouds.push_back(seen_from(w, truth[s], 40.0));
    graph.optimize();
    std::size_t calls = 0;
    const pl::maps::LoopReport rep = pl::maps::close_loops(graph, clouds, {}, [&](std::size_t, std::size_t) { ++calls; });
    EXPECT_EQ(calls, graph.keyframes().size());
    ASSERT_GE(rep.accepted, 1u);
    for (const pl::maps::LoopRecord& l : rep.loops) {
      if (!l.accepted) continue;
      // A true revisit: the two keyframes really are close.
      const auto& kf = graph.keyframes();
      EXPECT_LT((truth[kf[l.query]].translation() - truth[kf[l.match]].translation()).norm(), 12.0);
      EXPECT_GT(l.overlap, 0.6);
    }
    const double before = mean_error(odo, truth), after = mean_error(graph.poses(), truth);
    EXPECT_LT(after, before / 3.0) << "before " << before << " after " << after;
    EXPECT_GT(rep.residual_before_m, 0.5);
    EXPECT_LT(rep.residual_after_m, rep.residual_before_m / 4.0);
    // 0.015 deg a scan: the end has drifted some 20 m, out of the position search's reach.
    if (drift_deg > 0.01) {
      EXPECT_GE(rep.proposed_by_descriptor, 1u);
      bool by_place = false;
      for (const auto& l : rep.loops) by_place |= l.accepted && l.by_descriptor;
      EXPECT_TRUE(by_place);
    }
  }
}

// Out along a road and back the other way: the revisits face the other way (yaw 180 deg). Found by
// position, and with the position search switched off by place alone (the descriptor's heading must
// come out near 180 deg for the search round it to register).
TEST(LoopClosure, ClosesARevisitDrivenTheOtherWay) {
  const auto w = world(9);
  PoseList truth;
  for (int i = 0; i < 200; ++i) truth.push_back(pl::make_pose(-50.0 + 0.5 * i, -1.5, 0, 0, 0, 0));  // east, 100 m
  for (int i = 1; i <= 10; ++i) {  // a U-turn of radius 1.5 m
    const double a = M_PI * i / 10.0;
    truth.push_back(pl::make_pose(50.0 + 1.5 * std::sin(a), -1.5 * std::cos(a), 0, 0, 0, a));
  }
  for (int i = 1; i < 200; ++i) truth.push_back(pl::make_pose(50.0 - 0.5 * i, 1.5, 0, 0, 0, M_PI));  // back west
  const PoseList odo = drifted(truth, 0.01);
  for (bool place_only : {false, true}) {
    SCOPED_TRACE(place_only ? "by place only" : "by position and place");
    pl::maps::LoopClosureConfig cfg;
    if (place_only) cfg.position_radius_m = 0.0;
    pl::maps::PoseGraph graph(odo, {}, {}, Eigen::Vector3d::Zero(), {});
    std::vector<std::vector<Eigen::Vector3f>> clouds;
    for (std::size_t s : graph.keyframes()) clouds.push_back(seen_from(w, truth[s], 40.0));
    const pl::maps::LoopReport rep = pl::maps::close_loops(graph, clouds, cfg);
    ASSERT_GE(rep.accepted, 1u);
    bool by_place = false;
    for (const pl::maps::LoopRecord& l : rep.loops) {
      if (!l.accepted) continue;
      const auto& kf = graph.keyframes();
      EXPECT_LT((truth[kf[l.query]].translation() - truth[kf[l.match]].translation()).norm(), 12.0);
      by_place |= l.by_descriptor;
    }
    const double before = mean_error(odo, truth), after = mean_error(graph.poses(), truth);
    EXPECT_LT(after, before / 2.0) << "before " << before << " after " << after;
    if (place_only) {
      EXPECT_TRUE(by_place);
      EXPECT_EQ(rep.proposed_by_position, 0u);
    }
  }
}

TEST(LoopClosure, RejectsCloudsThatDoNotMatchTheKeyframes) {
  const PoseList truth = ring_road(100);
  pl::maps::PoseGraph graph(truth, {}, {}, Eigen::Vector3d::Zero(), {});
  EXPECT_THROW(pl::maps::close_loops(graph, {}, {}), pl::Error);
}

// `pl-map build --poses lidar --loops` on a simulated town loop (16 beams, so that the odometry
// drifts a few metres over the 600 m): the loop closes, the trajectory gets closer to the truth.
TEST(LoopClosure, PlMapBuildClosesTheTownLoop) {
  const pl::test::TempDir dir;
  // The first simulator (every ray from one pose, perfectly calibrated, the street alone): this tests
  // that the loop is found and closed. With the swept, miscalibrated sensor the 16-beam odometry drifts
  // 6 m and the loop takes out only a third of it (docs/benchmarks.md, G-LOAM: a miss, said there);
  // with the town behind the street it took out 48 % (the target is half).
  auto sim = pl::test::run(pl::test::tool("pl-sim") + " --route loop --lidar vlp16 --sweep off --calibration-error 0 --backdrop off --out " +
                           (dir / "drive"));
  ASSERT_EQ(sim.exit_code, 0) << sim.output;
  const std::string build = pl::test::tool("pl-map") + " build --dataset " + (dir / "drive") + " --poses lidar --loops --out " +
                            (dir / "map.pcd") + " --traj-out " + (dir / "poses.txt") + " --report " + (dir / "report.json");
  auto r = pl::test::run(build);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("loop closure:"), std::string::npos) << r.output;
  std::ifstream f(dir / "report.json");
  const nlohmann::json rep = nlohmann::json::parse(f);
  const auto& loops = rep.at("loops");
  EXPECT_GE(loops.at("accepted").get<int>(), 1);
  EXPECT_EQ(loops.at("edges").size(), loops.at("accepted").get<std::size_t>() + loops.at("rejected").get<std::size_t>());
  EXPECT_EQ(rep.at("pose_graph").at("loop_edges").get<int>(), loops.at("accepted").get<int>());
  const double before = rep.at("mean_error_before_m").get<double>(), after = rep.at("mean_error_after_m").get<double>();
  EXPECT_GT(before, 0.5);
  EXPECT_LT(after, before / 2.0) << r.output;
  // Every accepted loop joins two scans that really are near each other.
  pl::Dataset ds = pl::open_dataset(dir / "drive");
  for (const auto& e : loops.at("edges")) {
    if (!e.at("accepted").get<bool>()) continue;
    const auto q = e.at("query_scan").get<std::size_t>(), m = e.at("match_scan").get<std::size_t>();
    EXPECT_LT((ds.ground_truth.poses[q].translation() - ds.ground_truth.poses[m].translation()).norm(), 12.0);
  }
  // --traj-out FILE.tum: the same poses as TUM lines with the scan times.
  r = pl::test::run(pl::test::tool("pl-map") + " build --dataset " + (dir / "drive") + " --poses gt --every 100 --out " +
                    (dir / "gt.pcd") + " --traj-out " + (dir / "gt.tum"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  std::ifstream tum(dir / "gt.tum");
  std::string line;
  std::size_t lines = 0;
  while (std::getline(tum, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream in(line);
    double v[8];
    for (double& x : v) ASSERT_TRUE(in >> x) << line;
    EXPECT_NEAR(v[0], ds.times[lines], 1e-6);
    EXPECT_NEAR(v[1], ds.ground_truth.poses[lines].translation().x(), 1e-4);
    ++lines;
  }
  EXPECT_EQ(lines, ds.size());
  // --loops corrects LiDAR odometry: with ground-truth poses it is an error naming the fix.
  r = pl::test::run(pl::test::tool("pl-map") + " build --dataset " + (dir / "drive") + " --loops --out " + (dir / "x.pcd"));
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.output.find("--loops needs --poses lidar"), std::string::npos) << r.output;
}
