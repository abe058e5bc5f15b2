#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <map>
#include <random>

#include "pl/common/error.hpp"
#include "pl/common/voxel.hpp"

namespace {

// Reference: std::map keyed by the voxel index, centroids averaged in long double.
std::map<std::array<long long, 3>, std::array<long double, 4>> reference(const pl::Points3d& pts, double voxel) {
  std::map<std::array<long long, 3>, std::array<long double, 4>> m;
  for (const auto& p : pts) {
    std::array<long long, 3> k = {static_cast<long long>(std::floor(p.x() * (1.0 / voxel))),
                                  static_cast<long long>(std::floor(p.y() * (1.0 / voxel))),
                                  static_cast<long long>(std::floor(p.z() * (1.0 / voxel)))};
    auto& a = m[k];
    a[0] += p.x(), a[1] += p.y(), a[2] += p.z(), a[3] += 1;
  }
  return m;
}

pl::Points3d random_cloud(std::size_t n, double extent, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-extent, extent);
  pl::Points3d pts(n);
  for (auto& p : pts) p = Eigen::Vector3d(u(rng), u(rng), 0.2 * u(rng));
  return pts;
}

}  // namespace

TEST(Voxel, CentroidPerVoxelInFirstSeenOrder) {
  pl::Scan scan = {{0.05f, 0.05f, 0.05f, 1.f}, {1.05f, 0.f, 0.f, 5.f}, {0.15f, 0.15f, 0.15f, 3.f}, {-0.05f, 0.f, 0.f, 7.f}};
  pl::Scan out = pl::voxel_downsample(scan, 0.2);
  ASSERT_EQ(out.size(), 3u);
  EXPECT_NEAR(out[0].x, 0.1f, 1e-6);
  EXPECT_NEAR(out[0].intensity, 2.0f, 1e-6);
  EXPECT_NEAR(out[1].x, 1.05f, 1e-6);
  EXPECT_NEAR(out[2].x, -0.05f, 1e-6);  // negative coordinates floor into their own voxel
  EXPECT_THROW(pl::voxel_downsample(scan, 0.0), pl::Error);
  EXPECT_TRUE(pl::voxel_downsample(pl::Scan{}, 0.2).empty());
}

TEST(Voxel, MatchesReferenceOnRandomCloud) {
  pl::Points3d pts = random_cloud(50000, 30.0, 11);
  auto out = pl::voxel_downsample(pts, 0.5);
  auto ref = reference(pts, 0.5);
  ASSERT_EQ(out.size(), ref.size());
  std::size_t checked = 0;
  for (const auto& p : out) {
    std::array<long long, 3> k = {static_cast<long long>(std::floor(p.x() * 2.0)), static_cast<long long>(std::floor(p.y() * 2.0)),
                                  static_cast<long long>(std::floor(p.z() * 2.0))};
    auto it = ref.find(k);
    ASSERT_NE(it, ref.end());
    auto& a = it->second;
    EXPECT_NEAR(p.x(), static_cast<double>(a[0] / a[3]), 1e-9);
    EXPECT_NEAR(p.y(), static_cast<double>(a[1] / a[3]), 1e-9);
    ++checked;
  }
  EXPECT_EQ(checked, ref.size());
}

TEST(Voxel, DeterministicAcrossRuns) {
  pl::Points3d pts = random_cloud(20000, 10.0, 5);
  auto a = pl::voxel_downsample(pts, 0.3), b = pl::voxel_downsample(pts, 0.3);
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) ASSERT_EQ(a[i], b[i]);
}

TEST(Voxel, HundredsOfKilometresAwayGivesTheSameResult) {
  // 0.25 m voxels and an offset that is a whole number of voxels: the result must be the same cloud,
  // shifted. float32 would lose ~3 cm at 400 km; the double path loses nothing measurable.
  pl::Points3d near = random_cloud(30000, 25.0, 9);
  Eigen::Vector3d offset(409600.0, 5324800.0, 256.0);
  pl::Points3d far = near;
  for (auto& p : far) p += offset;
  auto a = pl::voxel_downsample(near, 0.25), b = pl::voxel_downsample(far, 0.25);
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) ASSERT_NEAR((b[i] - offset - a[i]).norm(), 0.0, 1e-8) << i;
}

TEST(Voxel, VeryWideCloudUsesTheGeneralPath) {
  // 2^21 voxels of 0.05 m is ~105 km: a cloud spanning 300 km takes the fallback and must agree with the reference.
  pl::Points3d pts = random_cloud(4000, 1.0, 2);
  for (std::size_t i = 0; i < pts.size(); i += 2) pts[i].x() += 300000.0;
  auto out = pl::voxel_downsample(pts, 0.05);
  EXPECT_EQ(out.size(), reference(pts, 0.05).size());
}

TEST(Voxel, ValuesAveraged) {
  pl::Points3d pts = {Eigen::Vector3d(0.1, 0.1, 0.1), Eigen::Vector3d(0.2, 0.2, 0.2), Eigen::Vector3d(5, 5, 5)};
  std::vector<float> vals = {1.f, 3.f, 10.f}, out_vals;
  auto out = pl::voxel_downsample(pts, vals, 1.0, out_vals);
  ASSERT_EQ(out.size(), 2u);
  EXPECT_FLOAT_EQ(out_vals[0], 2.f);
  EXPECT_FLOAT_EQ(out_vals[1], 10.f);
  EXPECT_THROW(pl::voxel_downsample(pts, std::vector<float>{1.f}, 1.0, out_vals), pl::Error);
}
