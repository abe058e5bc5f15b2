// Map accuracy against a reference cloud: the exact nearest-neighbour index, the statistics, and the
// built pl-eval map on real PCD files.
#include "pl/eval/map_accuracy.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>
#include <random>

#include "eval_test_util.hpp"
#include "pl/common/cloud_io.hpp"
#include "pl/common/error.hpp"
#include "pl/eval/nearest.hpp"

namespace pl::eval {
namespace {

using test::expect_usage_errors;
using test::run;
using test::UsageCase;
using test::RunResult;
using test::TempDir;

double brute_force_nearest(const Points3d& points, const Eigen::Vector3d& q, std::size_t exclude = NearestIndex::kNone) {
  double best = INFINITY;
  for (std::size_t i = 0; i < points.size(); ++i)
    if (i != exclude) best = std::min(best, (points[i] - q).norm());
  return best;
}

TEST(EvalNearest, MatchesBruteForceOnClusteredPointsWithDuplicates) {
  std::mt19937 rng(11);
  std::normal_distribution<double> cluster(0.0, 0.3);
  std::uniform_real_distribution<double> u(-50.0, 50.0);
  Points3d points;
  for (int c = 0; c < 20; ++c) {
    const Eigen::Vector3d centre(u(rng), u(rng), 0.1 * u(rng));
    for (int k = 0; k < 150; ++k) points.push_back(centre + Eigen::Vector3d(cluster(rng), cluster(rng), cluster(rng)));
  }
  for (int k = 0; k < 40; ++k) points.push_back(points[static_cast<std::size_t>(k * 7)]);  // exact duplicates
  for (int k = 0; k < 30; ++k) points.emplace_back(5.0, 5.0, 5.0);  // a pile of identical points (one big leaf)
  const NearestIndex index(points);
  ASSERT_EQ(index.size(), points.size());
  // Queries near the clusters and far away from everything (tens of metres off).
  for (int k = 0; k < 400; ++k) {
    const Eigen::Vector3d q = k % 2 ? points[static_cast<std::size_t>(k * 5)] + Eigen::Vector3d(0.05, -0.02, 0.01)
                                    : Eigen::Vector3d(3.0 * u(rng), 3.0 * u(rng), u(rng));
    const NearestIndex::Hit hit = index.nearest(q);
    EXPECT_NEAR(hit.distance, brute_force_nearest(points, q), 1e-12) << k;
    EXPECT_NEAR((points[hit.index] - q).norm(), hit.distance, 1e-12) << k;
    const double r = hit.distance;
    EXPECT_TRUE(index.any_within(q, r + 1e-9)) << k;
    EXPECT_FALSE(index.any_within(q, r * 0.999)) << k;
  }
  // Excluding a member finds its nearest other point (0 for a duplicate).
  EXPECT_NEAR(index.nearest(points[3], 3).distance, brute_force_nearest(points, points[3], 3), 1e-12);
  EXPECT_EQ(index.nearest(points[0], 0).distance, 0.0);  // points[0] is duplicated at the end

  const NearestIndex empty{Points3d{}};
  EXPECT_LT(empty.nearest(Eigen::Vector3d::Zero()).distance, 0.0);
  EXPECT_FALSE(empty.any_within(Eigen::Vector3d::Zero(), 1.0));
  const NearestIndex single(Points3d{Eigen::Vector3d(1, 2, 3)});
  EXPECT_NEAR(single.nearest(Eigen::Vector3d(1, 2, 0)).distance, 3.0, 1e-15);
  EXPECT_LT(single.nearest(Eigen::Vector3d(1, 2, 0), 0).distance, 0.0);  // its only point left out
}

// A reference "room corner": a 12 m x 12 m floor (z = 0) and a 12 m x 4 m wall (x = 12), points
// `spacing` apart.
Points3d reference_corner(double spacing) {
  Points3d ref;
  const int n = static_cast<int>(std::lround(12.0 / spacing));
  for (int i = 0; i <= n; ++i)
    for (int j = 0; j <= n; ++j) ref.emplace_back(i * spacing, j * spacing, 0.0);
  const int h = static_cast<int>(std::lround(4.0 / spacing));
  for (int j = 0; j <= n; ++j)
    for (int k = 1; k <= h; ++k) ref.emplace_back(12.0, j * spacing, k * spacing);
  return ref;
}

// 1000 map points on reference points away from the corner's edge, moved off their surface along its
// normal: 900 by 1 cm, 100 by 30 cm. Points over x < 6 only (the floor) and the wall.
Points3d offset_map(const Points3d& ref) {
  Points3d map;
  std::mt19937 rng(5);
  std::vector<std::size_t> candidates;
  for (std::size_t i = 0; i < ref.size(); ++i) {
    const Eigen::Vector3d& p = ref[i];
    const bool floor = p.z() == 0.0 && p.x() >= 1.0 && p.x() <= 6.0 && p.y() >= 1.0 && p.y() <= 11.0;
    const bool wall = p.x() == 12.0 && p.z() >= 1.0 && p.z() <= 3.0 && p.y() >= 1.0 && p.y() <= 11.0;
    if (floor || wall) candidates.push_back(i);
  }
  std::shuffle(candidates.begin(), candidates.end(), rng);
  for (std::size_t k = 0; k < 1000; ++k) {
    const Eigen::Vector3d& p = ref[candidates[k]];
    const Eigen::Vector3d normal = p.z() == 0.0 ? Eigen::Vector3d(0, 0, 1) : Eigen::Vector3d(-1, 0, 0);
    map.push_back(p + (k % 10 == 9 ? 0.30 : 0.01) * normal);
  }
  return map;
}

TEST(EvalMapAccuracy, SharesAndStatisticsOfKnownOffsets) {
  const Points3d ref = reference_corner(0.1);
  const Points3d map = offset_map(ref);
  MapAccuracyOptions options;
  options.within = 0.05;
  const MapAccuracy r = compute_map_accuracy(map, ref, options);
  EXPECT_EQ(r.map_points, 1000u);
  EXPECT_EQ(r.reference_points, ref.size());
  ASSERT_EQ(r.shares.size(), 4u);  // 0.02, 0.05 (= within), 0.10, 0.20
  for (const auto& s : r.shares) {
    EXPECT_EQ(s.points, 900u) << s.distance;
    EXPECT_DOUBLE_EQ(s.share, 0.9) << s.distance;
  }
  EXPECT_NEAR(r.distance.mean, 0.9 * 0.01 + 0.1 * 0.30, 1e-12);
  EXPECT_NEAR(r.distance.median, 0.01, 1e-12);
  // 900 distances of 0.01 m, then 100 of 0.30 m: p90 is h = 899.1, a tenth of the way from the
  // last 0.01 to the first 0.30 (interpolated percentiles, pl/common/stats.hpp).
  EXPECT_NEAR(r.p90, 0.01 + 0.1 * 0.29, 1e-12);
  EXPECT_NEAR(r.p95, 0.30, 1e-12);
  EXPECT_NEAR(r.p99, 0.30, 1e-12);
  EXPECT_NEAR(r.distance.max, 0.30, 1e-12);
  EXPECT_NEAR(r.reference_spacing, 0.1, 1e-9);

  // Coverage, brute force: reference points with a map point within 0.5 m.
  std::size_t covered = 0;
  for (const auto& p : ref) covered += brute_force_nearest(map, p) <= 0.5 ? 1 : 0;
  EXPECT_EQ(r.reference_covered, covered);
  EXPECT_NEAR(r.reference_coverage, static_cast<double>(covered) / static_cast<double>(ref.size()), 1e-15);
  EXPECT_GT(r.reference_coverage, 0.2);
  EXPECT_LT(r.reference_coverage, 0.8);  // the floor beyond x = 6.5 m has no map points

  // A threshold of its own is added in order.
  options.within = 0.5;
  const MapAccuracy wide = compute_map_accuracy(map, ref, options);
  ASSERT_EQ(wide.shares.size(), 5u);
  EXPECT_DOUBLE_EQ(wide.shares.back().distance, 0.5);
  EXPECT_EQ(wide.shares.back().points, 1000u);

  EXPECT_THROW(compute_map_accuracy({}, ref), pl::Error);
  EXPECT_THROW(compute_map_accuracy(map, {}), pl::Error);
  options.within = 0.0;
  EXPECT_THROW(compute_map_accuracy(map, ref, options), pl::Error);
}

// Map points on the surface but between the reference's samples: the surface metric sees them on it,
// the point metric sees the sampling gap. Points off the floor by 3 cm stay 3 cm in both.
TEST(EvalMapAccuracy, SurfaceMetricIsNotFooledByTheReferenceSpacing) {
  const Points3d ref = reference_corner(0.2);
  Points3d map;
  for (double x = 1.1; x < 6.0; x += 0.4)
    for (double y = 1.1; y < 11.0; y += 0.4) map.emplace_back(x, y, (map.size() % 2) ? 0.03 : 0.0);  // mid-cell: 0.14 m from any sample
  MapAccuracyOptions options;
  const MapAccuracy surface = compute_map_accuracy(map, ref, options);
  options.surface = false;
  const MapAccuracy point = compute_map_accuracy(map, ref, options);
  EXPECT_EQ(surface.surface_points, map.size());
  for (std::size_t i = 0; i < map.size(); ++i) {
    EXPECT_NEAR(surface.distances[i], map[i].z(), 1e-9) << i;
    EXPECT_GT(point.distances[i], 0.14) << i;
  }
  EXPECT_NEAR(surface.shares[1].share, 1.0, 1e-12);  // within 5 cm
  EXPECT_EQ(point.shares[1].points, 0u);

  // The radius search behind it finds exactly the points within the radius.
  const NearestIndex index(ref);
  std::vector<std::size_t> found;
  const Eigen::Vector3d q(3.05, 4.0, 0.1);
  index.radius_search(q, 0.5, found);
  std::size_t brute = 0;
  for (const auto& p : ref) brute += (p - q).norm() <= 0.5;
  EXPECT_EQ(found.size(), brute);
  for (std::size_t i : found) EXPECT_LE((index.point(i) - q).norm(), 0.5);
}

TEST(EvalMapAccuracy, OriginsMustAgreeWhenBothAreRecorded) {
  Cloud a, b;
  EXPECT_NO_THROW(check_same_origin(a, "a.pcd", b, "b.pcd"));
  a.origin = GeoPoint{49.0, 8.4, 100.0};
  EXPECT_NO_THROW(check_same_origin(a, "a.pcd", b, "b.pcd"));  // only one records one
  b.origin = GeoPoint{49.0, 8.4, 100.0};
  EXPECT_NO_THROW(check_same_origin(a, "a.pcd", b, "b.pcd"));
  b.origin = GeoPoint{49.0001, 8.4, 100.0};  // ~11 m north
  try {
    check_same_origin(a, "a.pcd", b, "b.pcd");
    FAIL() << "different origins were accepted";
  } catch (const pl::Error& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("a.pcd"), std::string::npos) << m;
    EXPECT_NE(m.find("b.pcd"), std::string::npos) << m;
    EXPECT_NE(m.find("lat 49.0000000000"), std::string::npos) << m;
    EXPECT_NE(m.find("lat 49.0001000000"), std::string::npos) << m;
    EXPECT_NE(m.find("11.1"), std::string::npos) << m;  // metres apart
  }
}

nlohmann::json run_json(const std::vector<std::string>& argv, const TempDir& dir) {
  const RunResult r = run(argv, dir);
  EXPECT_EQ(r.exit_code, 0) << r.err;
  try {
    return nlohmann::json::parse(r.out);
  } catch (const std::exception& e) {
    ADD_FAILURE() << "not JSON: " << e.what() << "\n" << r.out;
    return nlohmann::json::object();
  }
}

TEST(EvalMapCli, SharesFromRealPcdFiles) {
  TempDir dir;
  const Points3d ref = reference_corner(0.05);
  const Points3d map = offset_map(ref);
  const GeoPoint origin{49.011212804, 8.422885042, 112.83};
  write_pcd(dir.file("ref.pcd"), ref, std::vector<float>(ref.size(), 0.5f), origin);
  write_pcd(dir.file("map.pcd"), map, std::vector<float>(map.size(), 0.5f), origin);
  const std::string exe = test::pl_eval_exe();

  const auto j = run_json({exe, "map", "--map", dir.file("map.pcd"), "--ref", dir.file("ref.pcd"), "--json"}, dir);
  EXPECT_EQ(j.at("map_points"), 1000);
  EXPECT_EQ(j.at("reference_points"), ref.size());
  EXPECT_NEAR(j.at("within_m").get<double>(), 0.05, 1e-15);
  EXPECT_NEAR(j.at("share_within").get<double>(), 0.9, 1e-12);
  ASSERT_EQ(j.at("shares").size(), 4u);
  for (const auto& s : j.at("shares")) EXPECT_NEAR(s.at("share").get<double>(), 0.9, 1e-12) << s.dump();
  // float32 coordinates in the PCD: 1e-5 m.
  EXPECT_NEAR(j.at("mean").get<double>(), 0.039, 1e-5);
  EXPECT_NEAR(j.at("median").get<double>(), 0.01, 1e-5);
  EXPECT_NEAR(j.at("p95").get<double>(), 0.30, 1e-5);
  EXPECT_NEAR(j.at("max").get<double>(), 0.30, 1e-5);
  EXPECT_NEAR(j.at("reference_spacing_m").get<double>(), 0.05, 1e-5);
  EXPECT_NEAR(j.at("origin").at("lat").get<double>(), origin.lat_deg, 1e-9);

  // --within 0.5 takes in the 30 cm points too; the table says so.
  const RunResult text =
      run({exe, "map", "--map", dir.file("map.pcd"), "--ref", dir.file("ref.pcd"), "--within", "0.5"}, dir);
  ASSERT_EQ(text.exit_code, 0) << text.err;
  EXPECT_NE(text.out.find("within 0.500 m  100.00 % of the map points"), std::string::npos) << text.out;
  EXPECT_NE(text.out.find("reference coverage"), std::string::npos) << text.out;
  EXPECT_EQ(text.out.find("note:"), std::string::npos) << text.out;  // the 5 cm reference resolves 0.5 m

  // A reference without an origin is taken to be in the map's frame, and the table says so.
  write_pcd(dir.file("bare.pcd"), ref, std::vector<float>(ref.size(), 0.5f));
  const RunResult bare = run({exe, "map", "--map", dir.file("map.pcd"), "--ref", dir.file("bare.pcd")}, dir);
  ASSERT_EQ(bare.exit_code, 0) << bare.err;
  EXPECT_NE(bare.out.find("note: only " + dir.file("map.pcd") + " records a geodetic origin"), std::string::npos)
      << bare.out;
}

TEST(EvalMapCli, BadInputNamesTheProblem) {
  TempDir dir;
  const Points3d ref = reference_corner(0.5);
  write_pcd(dir.file("ref.pcd"), ref, std::vector<float>(ref.size(), 0.f), GeoPoint{49.0, 8.4, 100.0});
  write_pcd(dir.file("other.pcd"), ref, std::vector<float>(ref.size(), 0.f), GeoPoint{48.0, 11.5, 520.0});
  write_pcd(dir.file("empty.pcd"), {}, {});
  const std::string exe = test::pl_eval_exe();
  const std::vector<UsageCase> cases = {
      {{exe, "map", "--map", dir.file("other.pcd"), "--ref", dir.file("ref.pcd")}, "records the geodetic origin"},
      {{exe, "map", "--map", dir.file("nope.pcd"), "--ref", dir.file("ref.pcd")}, "nope.pcd"},
      {{exe, "map", "--map", dir.file("empty.pcd"), "--ref", dir.file("ref.pcd")}, "empty.pcd: the map cloud has no points"},
      {{exe, "map", "--map", dir.file("ref.pcd"), "--ref", dir.file("ref.pcd"), "--within", "0"}, "--within takes"},
      {{exe, "map", "--map", dir.file("ref.pcd"), "--ref", dir.file("ref.pcd"), "--within", "5cm"}, "--within takes a number"},
      {{exe, "map", "--map", dir.file("ref.pcd")}, "--ref is required"},
      {{exe, "map", "--map", dir.file("ref.pcd"), "--ref", dir.file("ref.pcd"), "--cell", "1"}, "--cell"},
  };
  expect_usage_errors(cases, dir);
  // The origin message names both files and both origins.
  const RunResult r = run({exe, "map", "--map", dir.file("other.pcd"), "--ref", dir.file("ref.pcd")}, dir);
  EXPECT_NE(r.err.find(dir.file("other.pcd")), std::string::npos) << r.err;
  EXPECT_NE(r.err.find(dir.file("ref.pcd")), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("lat 48.0000000000"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("lat 49.0000000000"), std::string::npos) << r.err;
}

}  // namespace
}  // namespace pl::eval
