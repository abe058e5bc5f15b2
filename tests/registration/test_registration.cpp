// The registration library on its own, with points and normals only (no tiles): the cell table
// against std::unordered_map, the point map's nearest neighbour against brute force far from the
// origin and its parts entering and leaving, the Gauss-Newton reduction against a double-precision
// sum, normals and line/plane fits on exact shapes, point-to-plane ICP on synthetic scenes
// (accuracy, moving objects, degenerate geometry, a scan away from the map) and the pose search.
#include <gtest/gtest.h>

#include <Eigen/Cholesky>

#include <cmath>
#include <random>
#include <unordered_map>

#include "pl/common/error.hpp"
#include "pl/common/pose.hpp"
#include "pl/registration/cell_table.hpp"
#include "pl/registration/gauss_newton.hpp"
#include "pl/registration/icp.hpp"
#include "pl/registration/normals.hpp"
#include "pl/registration/point_map.hpp"
#include "pl/registration/pose_search.hpp"
#include "scene.hpp"

namespace {

namespace reg = pl::registration;
using pl::test::scan_of;
using pl::test::street;
using pl::test::Surface;

// A point map of the surfaces sampled every `step` metres, as one part.
std::unique_ptr<reg::PointMap> map_of(const std::vector<Surface>& surfaces, double step, double cell_m = 1.0,
                                      const Eigen::Vector3d& anchor = Eigen::Vector3d::Zero()) {
  std::vector<Eigen::Vector3d> points;
  std::vector<Eigen::Vector3f> normals;
  pl::test::sample_surfaces(surfaces, step, points, normals);
  auto map = std::make_unique<reg::PointMap>(anchor, cell_m);
  map->add(1, points, normals);
  return map;
}

// --- the cell table -------------------------------------------------------------------------------

TEST(CellTable, AgreesWithAnUnorderedMapThroughInsertsAndErases) {
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> coord(-40, 40);
  reg::CellTable<std::uint32_t> table;
  std::unordered_map<std::uint64_t, std::uint32_t> truth;
  for (int step = 0; step < 200000; ++step) {
    const std::uint64_t key = reg::pack_cell(coord(rng), coord(rng), coord(rng) / 8);
    if (rng() % 3 == 0) {
      EXPECT_EQ(table.erase(key), truth.erase(key) == 1);
    } else {
      bool fresh;
      const std::uint32_t v = static_cast<std::uint32_t>(step);
      const std::uint32_t stored = *table.insert(key, v, fresh);
      const auto [it, inserted] = truth.emplace(key, v);
      ASSERT_EQ(fresh, inserted);
      ASSERT_EQ(stored, it->second);
    }
  }
  ASSERT_EQ(table.size(), truth.size());
  for (const auto& [key, value] : truth) {
    const std::uint32_t* found = table.find(key);
    ASSERT_NE(found, nullptr);
    EXPECT_EQ(*found, value);
  }
  std::size_t visited = 0;
  table.for_each([&](std::uint64_t key, std::uint32_t value) {
    ++visited;
    EXPECT_EQ(truth.at(key), value);
  });
  EXPECT_EQ(visited, truth.size());
}

TEST(CellTable, NegativeAndPositiveCellsAreDistinctKeys) {
  EXPECT_NE(reg::pack_cell(-1, 0, 0), reg::pack_cell(1, 0, 0));
  EXPECT_NE(reg::pack_cell(0, -1, 0), reg::pack_cell(0, 0, -1));
  EXPECT_NE(reg::pack_cell(-(1 << 20), 0, 0), reg::pack_cell((1 << 20) - 1, 0, 0));
  EXPECT_EQ(reg::cell_coordinate(-0.01f, 2.0f), -1);
  EXPECT_EQ(reg::cell_coordinate(0.49f, 2.0f), 0);
}

// --- the point map --------------------------------------------------------------------------------

TEST(PointMap, NearestEqualsBruteForceWithinHalfACellFarFromTheOrigin) {
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const Eigen::Vector3d far(350000.0, -4200000.0, 120.0);  // large map coordinates stay exact
  std::vector<Eigen::Vector3d> points;
  std::vector<Eigen::Vector3f> normals;
  for (int i = 0; i < 20000; ++i) {
    points.push_back(far + Eigen::Vector3d(40 * u(rng), 40 * u(rng), 3 * u(rng)));
    normals.push_back(Eigen::Vector3f::UnitZ());
  }
  reg::PointMap map(far, 1.0);
  map.add(0, points, normals);
  EXPECT_EQ(map.points(), points.size());
  int checked = 0;
  for (int q = 0; q < 3000; ++q) {
    const Eigen::Vector3d p = far + Eigen::Vector3d(40 * u(rng), 40 * u(rng), 3 * u(rng));
    double best = 1e9;
    for (const auto& c : points) best = std::min(best, (c - p).squaredNorm());
    const auto nb = map.nearest((p - map.anchor()).cast<float>(), 0.25f);
    if (best < 0.25 - 1e-4) {
      ASSERT_NE(nb.point, nullptr);
      EXPECT_NEAR(nb.dist2, best, 1e-4);
      ++checked;
    } else if (best > 0.25 + 1e-4) {
      EXPECT_EQ(nb.point, nullptr);
    }
  }
  EXPECT_GT(checked, 1000);
}

TEST(PointMap, AKeptCellBlockGivesTheSameAnswerAsAFreshLookup) {
  // ICP's use: each scan point keeps its block between iterations and moves a little each time, now
  // and then across a cell's middle or edge (a new block).
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::normal_distribution<float> step(0.0f, 0.08f);
  std::vector<Eigen::Vector3d> points;
  std::vector<Eigen::Vector3f> normals;
  for (int i = 0; i < 30000; ++i) {
    points.emplace_back(20 * u(rng), 20 * u(rng), 2 * u(rng));
    normals.push_back(Eigen::Vector3f::UnitZ());
  }
  reg::PointMap map(Eigen::Vector3d(3, -2, 0), 0.5);
  map.add(0, points, normals);
  int kept = 0, renewed = 0, found = 0, later = 0;  // later: a kept block's cell looked up only now
  for (int q = 0; q < 2000; ++q) {
    Eigen::Vector3f at(static_cast<float>(20 * u(rng) - 3), static_cast<float>(20 * u(rng) + 2), static_cast<float>(2 * u(rng)));
    reg::CellBlock block;
    for (int it = 0; it < 6; ++it) {
      const std::uint64_t before = block.own;
      const std::uint8_t side = block.side, looked = block.looked;
      const auto kept_answer = map.nearest(at, 0.2f, block);
      const bool same = block.own == before && block.side == side;
      (same ? kept : renewed)++;
      later += same && block.looked != looked;
      const auto fresh = map.nearest(at, 0.2f);
      ASSERT_EQ(kept_answer.point, fresh.point) << q << " " << it;
      ASSERT_EQ(kept_answer.dist2, fresh.dist2);
      found += fresh.point != nullptr;
      at += Eigen::Vector3f(step(rng), step(rng), step(rng));
    }
  }
  EXPECT_GT(kept, 3000);  // both paths taken often
  EXPECT_GT(renewed, 3000);
  EXPECT_GT(later, 300);
  EXPECT_GT(found, 10000);
  // A block once filled by a query that is not a number does not mislead the next finite one (the
  // cells round the anchor, where such a query's cell coordinates may land).
  reg::PointMap centred(Eigen::Vector3d(10, 10, 1), 0.5);
  centred.add(0, points, normals);
  int near_anchor = 0;
  for (int q = 0; q < 200; ++q) {
    reg::CellBlock block;
    centred.nearest(Eigen::Vector3f(std::nanf(""), 0.1f, 0.1f), 0.2f, block);
    const Eigen::Vector3f at(static_cast<float>(0.25 * u(rng)), static_cast<float>(0.25 * u(rng)), static_cast<float>(0.25 * u(rng)));
    const auto fresh = centred.nearest(at, 0.2f);
    EXPECT_EQ(centred.nearest(at, 0.2f, block).point, fresh.point) << q;
    near_anchor += fresh.point != nullptr;
  }
  EXPECT_GT(near_anchor, 150);
}

TEST(PointMap, PartsEnterAndLeaveWithoutATrace) {
  // Two parts on either side of x = 0 (the cell grid's boundary): each owns its cells.
  std::vector<Eigen::Vector3d> left, right;
  std::vector<Eigen::Vector3f> nl, nr;
  for (int i = 0; i < 400; ++i) {
    left.emplace_back(-0.05 - 0.1 * (i % 20), 0.1 * (i / 20), 0.0);
    right.emplace_back(0.05 + 0.1 * (i % 20), 0.1 * (i / 20), 0.0);
  }
  nl.assign(left.size(), Eigen::Vector3f::UnitZ());
  nr.assign(right.size(), Eigen::Vector3f::UnitZ());
  reg::PointMap map(Eigen::Vector3d::Zero(), 0.5);
  map.add(10, left, nl);
  const std::size_t left_cells = map.cells();
  map.add(20, right, nr);
  EXPECT_EQ(map.cells(), 2 * left_cells);
  EXPECT_EQ(map.points(), 800u);
  EXPECT_THROW(map.add(10, left, nl), pl::Error);                               // held already
  EXPECT_THROW(map.add(30, left, std::vector<Eigen::Vector3f>(3)), pl::Error);  // sizes differ
  EXPECT_TRUE(map.remove(10));
  EXPECT_FALSE(map.remove(10));
  EXPECT_EQ(map.cells(), left_cells);
  EXPECT_EQ(map.points(), 400u);
  EXPECT_EQ(map.nearest(left[7].cast<float>(), 1e-6f).point, nullptr);
  const auto nb = map.nearest(right[7].cast<float>(), 1e-6f);
  ASSERT_NE(nb.point, nullptr);
  EXPECT_NEAR((nb.point->p - right[7].cast<float>()).norm(), 0.0, 1e-6);
  EXPECT_EQ(map.all_points().size(), 400u);
  EXPECT_THROW(reg::PointMap(Eigen::Vector3d::Zero(), 0.0), pl::Error);
}

// --- the Gauss-Newton reduction -------------------------------------------------------------------

TEST(NormalEquations, EqualsTheDoublePrecisionSumOverManyBlocks) {
  std::mt19937 rng(11);
  std::normal_distribution<float> g(0.0f, 1.0f);
  reg::NormalEquations eq;
  reg::Matrix6d H = reg::Matrix6d::Zero();
  reg::Vector6d b = reg::Vector6d::Zero();
  double wr2 = 0, w_sum = 0;
  for (int i = 0; i < 3000; ++i) {  // 11 full blocks and a partial one
    const Eigen::Vector3f n = Eigen::Vector3f(g(rng), g(rng), g(rng)).normalized();
    const Eigen::Vector3f qr(10 * g(rng), 10 * g(rng), g(rng));
    const float r = 0.1f * g(rng), w = reg::geman_mcclure_weight(r * r, 0.01f);
    eq.add(n, qr, r, w);
    reg::Vector6d J;
    J << n.cast<double>(), qr.cast<double>().cross(n.cast<double>());
    H += w * J * J.transpose();
    b += w * r * J;
    wr2 += w * r * r;
    w_sum += w;
  }
  EXPECT_EQ(eq.rows(), 3000);
  EXPECT_LT((eq.H() - H).norm(), 1e-4 * H.norm());
  EXPECT_LT((eq.g() - b).norm(), 1e-4 * b.norm() + 1e-9);
  EXPECT_NEAR(eq.weighted_rms(), std::sqrt(wr2 / w_sum), 1e-6);
}

TEST(GaussNewton, KernelsDownWeightLargeResiduals) {
  EXPECT_FLOAT_EQ(reg::geman_mcclure_weight(0.0f, 0.04f), 1.0f);
  EXPECT_FLOAT_EQ(reg::cauchy_weight(0.0f, 0.04f), 1.0f);
  EXPECT_NEAR(reg::geman_mcclure_weight(0.04f, 0.04f), 0.25f, 1e-6);  // at the scale: (k2 / 2 k2)^2
  EXPECT_NEAR(reg::cauchy_weight(0.04f, 0.04f), 0.5f, 1e-6);
  EXPECT_LT(reg::geman_mcclure_weight(1.0f, 0.04f), reg::cauchy_weight(1.0f, 0.04f));
}

TEST(GaussNewton, TruncatedStepLeavesTheUnconstrainedDirectionAlone) {
  // Information on everything but x: the full solve is not finite, the truncated one moves
  // every other axis exactly and x not at all, and says so.
  reg::Matrix6d H = reg::Matrix6d::Identity();
  H(0, 0) = 0.0;
  reg::Vector6d g;
  g << 5, 1, -2, 0.1, 0.2, -0.3;
  bool degenerate = false;
  const reg::Vector6d step = reg::solve_step_truncated(H, g, 1e-3, degenerate);
  EXPECT_TRUE(degenerate);
  EXPECT_NEAR(step(0), 0.0, 1e-12);
  for (int i = 1; i < 6; ++i) EXPECT_NEAR(step(i), -g(i), 1e-9);
  H(0, 0) = 1.0;
  EXPECT_LT((reg::solve_step_truncated(H, g, 1e-3, degenerate) - reg::solve_step(H, g)).norm(), 1e-9);
  EXPECT_FALSE(degenerate);
}

TEST(GaussNewton, TranslationConditioningSeesACorridor) {
  reg::Matrix6d H = reg::Matrix6d::Identity();
  EXPECT_NEAR(reg::translation_conditioning(H), 1.0, 1e-12);
  H(1, 1) = 1e-4;  // nothing along y
  EXPECT_NEAR(reg::translation_conditioning(H), 1e-4, 1e-9);
  EXPECT_EQ(reg::translation_conditioning(reg::Matrix6d::Zero()), 0.0);
}

// --- normals and fits -----------------------------------------------------------------------------

TEST(Normals, PlaneAndLineFitsOnExactShapes) {
  // Five points on the plane z = 0.5 x + 2 (not all on a line).
  Eigen::Vector3f plane[5] = {{0, 0, 2}, {1, 0, 2.5}, {0, 1, 2}, {1, 1, 2.5}, {0.5, 0.3f, 2.25}};
  reg::FeatureTarget t;
  ASSERT_TRUE(reg::fit_plane(plane, 5, 0.01, t));
  EXPECT_EQ(t.rows, 1);
  const Eigen::Vector3f expected = Eigen::Vector3f(-0.5f, 0, 1).normalized();
  EXPECT_NEAR(std::abs(t.n[0].dot(expected)), 1.0f, 1e-5);
  for (const auto& p : plane) EXPECT_NEAR(t.n[0].dot(p) + t.d[0], 0.0f, 1e-5);
  EXPECT_FALSE(reg::fit_line(plane, 5, 3.0, t));  // a square patch spreads two ways
  // Five points along a line, a little noise across it.
  Eigen::Vector3f line[5] = {{0, 0, 0}, {1, 0.01f, 0}, {2, 0, 0.01f}, {3, -0.01f, 0}, {4, 0, -0.01f}};
  ASSERT_TRUE(reg::fit_line(line, 5, 3.0, t));
  EXPECT_EQ(t.rows, 2);
  for (int r = 0; r < 2; ++r) EXPECT_NEAR(t.n[r].dot(Eigen::Vector3f::UnitX()), 0.0f, 0.02f);
  // A point off the plane by more than max_dist: no plane.
  plane[4].z() += 0.2f;
  EXPECT_FALSE(reg::fit_plane(plane, 5, 0.05, t));
}

TEST(Normals, EstimatedNormalsOfAWallAndTheGround) {
  std::vector<Eigen::Vector3d> pts;
  for (int i = 0; i < 30; ++i)
    for (int j = 0; j < 30; ++j) {
      pts.emplace_back(0.1 * i, 0.1 * j, 0.0);        // ground
      pts.emplace_back(0.1 * i, 5.0, 0.1 * j + 0.5);  // a wall facing y
    }
  pts.emplace_back(100, 100, 100);  // alone: straight up
  std::vector<float> planarity;
  const auto n = reg::estimate_normals(pts, 0.3, &planarity);
  ASSERT_EQ(n.size(), pts.size());
  EXPECT_NEAR(n[0].z(), 1.0f, 1e-5);            // ground, oriented up
  EXPECT_NEAR(std::abs(n[1].y()), 1.0f, 1e-5);  // wall
  EXPECT_GT(n[1].y(), 0.0f);                    // horizontal normals point towards +x or +y
  EXPECT_GT(planarity[0], 0.9f);
  EXPECT_EQ(n.back(), Eigen::Vector3f::UnitZ());
  EXPECT_EQ(planarity.back(), 0.0f);
  EXPECT_THROW(reg::estimate_normals(pts, 0.0), pl::Error);
}

// --- ICP ------------------------------------------------------------------------------------------

TEST(Icp, RecoversAnOffsetPoseOnAStreet) {
  const auto surfaces = street();
  const auto map = map_of(surfaces, 0.2);
  const Eigen::Isometry3d truth = pl::make_pose(3.0, 0.5, 1.8, 0.0, 0.0, 0.1);
  const auto scan = scan_of(surfaces, truth, 0.5, 60.0, 1);
  ASSERT_GT(scan.size(), 2000u);
  const Eigen::Isometry3d guess = truth * pl::make_pose(0.25, -0.2, 0.1, 0.01, -0.01, 0.05);
  const auto r = reg::register_scan(*map, scan, guess);
  EXPECT_TRUE(r.accepted) << r.reject_reason;
  EXPECT_TRUE(r.converged);
  EXPECT_LT((r.pose.translation() - truth.translation()).norm(), 0.02);
  EXPECT_LT(pl::rotation_angle(r.pose.inverse() * truth), 0.002);
  EXPECT_GT(r.inlier_share, 0.9);
  // The covariance proxy is a covariance: symmetric, positive definite.
  EXPECT_LT((r.covariance - r.covariance.transpose()).norm(), 1e-9 * r.covariance.norm());
  EXPECT_EQ(r.covariance.llt().info(), Eigen::Success);
}

TEST(Icp, ExactFarFromTheOrigin) {
  // The same street 400 km from the map frame's origin, anchored near it: the same accuracy.
  const Eigen::Vector3d far(412345.0, -5123456.0, 250.0);
  const auto surfaces = street();
  std::vector<Surface> moved = surfaces;
  for (Surface& s : moved) s.origin += far;
  const auto map = map_of(moved, 0.2, 1.0, far + Eigen::Vector3d(7, -3, 0));
  const Eigen::Isometry3d local = pl::make_pose(3.0, 0.5, 1.8, 0.0, 0.0, 0.1);
  Eigen::Isometry3d truth = local;
  truth.translation() += far;
  const auto scan = scan_of(surfaces, local, 0.5, 60.0, 1);
  const auto r = reg::register_scan(*map, scan, truth * pl::make_pose(0.25, -0.2, 0.1, 0.01, -0.01, 0.05));
  EXPECT_TRUE(r.accepted) << r.reject_reason;
  EXPECT_LT((r.pose.translation() - truth.translation()).norm(), 0.02);
}

TEST(Icp, PairsFartherThanDeltaAreDropped) {
  // A third of the scan hits things the map does not have (a truck beside the sensor, people).
  const auto surfaces = street();
  const auto map = map_of(surfaces, 0.2);
  const Eigen::Isometry3d truth = pl::make_pose(-5.0, -1.0, 1.8, 0, 0, -0.05);
  auto scan = scan_of(surfaces, truth, 0.5, 60.0, 2);
  const std::size_t static_points = scan.size();
  std::vector<Surface> truck = {{{-8, 1.5, 0.3}, {12, 0, 0}, {0, 0, 3.5}}, {{-8, 1.5, 3.8}, {12, 0, 0}, {0, 2.5, 0}}};
  for (int k = 0; k < 3; ++k) {
    const auto extra = scan_of(truck, truth, 0.12, 60.0, 10 + k);
    scan.insert(scan.end(), extra.begin(), extra.end());
  }
  ASSERT_GT(scan.size(), static_points * 4 / 3);
  const auto r = reg::register_scan(*map, scan, truth * pl::make_pose(0.2, 0.15, 0, 0, 0, 0.03));
  EXPECT_TRUE(r.accepted) << r.reject_reason;
  EXPECT_LT((r.pose.translation() - truth.translation()).norm(), 0.03);
  EXPECT_LT(r.inlier_share, 0.8);  // the truck's points found no pair
}

TEST(Icp, DegenerateCorridorIsRejected) {
  // Ground and two endless parallel walls: nothing fixes the position along the corridor.
  std::vector<Surface> corridor = {
      {{-60, -6, 0}, {120, 0, 0}, {0, 12, 0}}, {{-60, -6, 0}, {120, 0, 0}, {0, 0, 6}}, {{-60, 6, 0}, {120, 0, 0}, {0, 0, 6}}};
  const auto map = map_of(corridor, 0.2);
  const Eigen::Isometry3d truth = pl::make_pose(0, 0, 1.8);
  const auto r = reg::register_scan(*map, scan_of(corridor, truth, 0.5, 40.0, 3), truth);
  EXPECT_FALSE(r.accepted);
  EXPECT_STREQ(r.reject_reason, "degenerate geometry");
  EXPECT_LT(r.conditioning, 0.02);
}

TEST(Icp, ScanAwayFromTheMapIsRejected) {
  const auto surfaces = street();
  const auto map = map_of(surfaces, 0.2);
  const Eigen::Isometry3d truth = pl::make_pose(0, 0, 1.8);
  const auto r = reg::register_scan(*map, scan_of(surfaces, truth, 0.5, 40.0, 4), pl::make_pose(0, 0, 30.0));
  EXPECT_FALSE(r.accepted);
  EXPECT_STRNE(r.reject_reason, "");
}

// --- the pose search ------------------------------------------------------------------------------

TEST(PoseSearch, FindsAPoseFiveMetresAndThirtyDegreesOff) {
  const auto surfaces = street();
  const auto fine = map_of(surfaces, 0.2, 0.5);
  const auto coarse = map_of(surfaces, 0.2, 2.0);
  const Eigen::Isometry3d truth = pl::make_pose(2.0, 0.5, 1.8, 0, 0, 0.05);
  const auto scan = scan_of(surfaces, truth, 0.5, 60.0, 5);
  const Eigen::Isometry3d guess = truth * pl::make_pose(3.0, -4.0, 0.0, 0, 0, 30.0 * M_PI / 180.0);
  reg::IcpConfig icp;
  icp.kernel_m = 0.3;
  icp.max_iterations = 50;
  // Plain ICP from the guess does not get there; the search does.
  const auto direct = reg::register_scan(*fine, scan, guess, icp);
  EXPECT_GT((direct.pose.translation() - truth.translation()).norm(), 0.5);
  Eigen::Isometry3d found;
  ASSERT_TRUE(reg::search_pose(*coarse, *fine, scan, guess, {}, icp, found));
  EXPECT_LT((found.translation() - truth.translation()).norm(), 0.05);
  EXPECT_LT(pl::rotation_angle(found.inverse() * truth), 0.01);
  // With a grid too small to reach the truth it says so instead of returning a wrong pose.
  reg::PoseSearch tiny;
  tiny.radius_m = 0.0;
  tiny.yaw_range_deg = 0.0;
  Eigen::Isometry3d none = Eigen::Isometry3d::Identity();
  const bool ok = reg::search_pose(*coarse, *fine, scan, guess, tiny, icp, none);
  if (ok) {
    EXPECT_LT((none.translation() - truth.translation()).norm(), 0.05);  // accepted only if right
  }
}

}  // namespace
