// The free-space filter on a street cast in the test: ground, two walls, a car parked for the whole
// drive and a car driving the other way through it, scanned from a sensor driving along the street.
// Every point knows its object, so each test measures the share of each object's merged points removed.
#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <array>
#include <cmath>
#include <functional>
#include <iostream>
#include <optional>
#include <string>
#include <unordered_map>
#include <vector>

#include "pl/common/error.hpp"
#include "pl/common/voxel.hpp"
#include "pl/maps/free_space.hpp"
#include "pl/registration/normals.hpp"
#include "ray_box.hpp"

namespace {

using pl::maps::FreeSpaceConfig;
using pl::maps::FreeSpaceFilter;
using pl::maps::FreeSpaceReport;

enum Label { kGround, kWall, kParked, kMoving, kLead, kBarrier, kTruck, kPost, kLabels };

struct Box {
  Eigen::Vector3d lo, hi;
  Label label;
};

// The ground z = 0 and boxes; far from the world origin, as a real map frame is.
const Eigen::Vector3d kAt(3.5e5, 5.8e6, 120.0);

struct Hit {
  double t;
  Label label;
};

std::optional<Hit> cast(const std::vector<Box>& boxes, const Eigen::Vector3d& o, const Eigen::Vector3d& d) {
  std::optional<Hit> best;
  double limit = 60.0;
  if (d.z() < -1e-9) {
    const double t = -o.z() / d.z();
    if (t > 0 && t < limit) best = Hit{t, kGround}, limit = t;
  }
  for (const Box& b : boxes) {
    if (const auto t = pl::test::ray_enters_box(o, d, b.lo, b.hi, limit)) best = Hit{*t, b.label}, limit = *t;
  }
  return best;
}

struct Scan {
  pl::Pose pose;                          // the sensor in the world (kAt added)
  std::vector<Eigen::Vector3f> points;    // sensor frame
  std::vector<Label> labels;
};

// A scan from a sensor 1.7 m up at (x, y), its frame turned by `yaw` (the scan is given in it): by
// default 32 beams from -25 to +6 deg, every 0.4 deg of azimuth.
struct Beams {
  int count = 32;
  double lowest_deg = -25.0, step_deg = 1.0, azimuth_deg = 0.4;
};
Scan scan_at(const std::vector<Box>& boxes, double x, double y, double yaw, const Beams& beams = {}) {
  Scan s;
  const Eigen::Vector3d o(x, y, 1.7);
  s.pose = Eigen::Translation3d(kAt + o) * Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ());
  const Eigen::Matrix3d to_sensor = s.pose.linear().transpose();
  const int steps = static_cast<int>(std::lround(360.0 / beams.azimuth_deg));
  for (int b = 0; b < beams.count; ++b) {
    const double el = (beams.lowest_deg + b * beams.step_deg) * M_PI / 180.0;
    for (int a = 0; a < steps; ++a) {
      const double az = a * beams.azimuth_deg * M_PI / 180.0;
      const Eigen::Vector3d d(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el));
      if (const auto h = cast(boxes, o, d)) {
        s.points.push_back((to_sensor * (d * h->t)).cast<float>());
        s.labels.push_back(h->label);
      }
    }
  }
  return s;
}

// The scans merged into 0.2 m voxels: centroids, normals, the scans that returned from each voxel,
// and each voxel's object (the one most of its points came from).
struct Merged {
  pl::Points3d points;
  std::vector<Eigen::Vector3f> normals;
  std::vector<std::uint32_t> seen;
  std::vector<Label> labels;
};

constexpr double kVoxel = 0.2;

Merged merge(const std::vector<Scan>& scans) {
  struct Acc {
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    std::uint32_t n = 0, seen = 0, last = 0;
    std::array<std::uint32_t, kLabels> labels{};
  };
  std::unordered_map<pl::VoxelIndex, std::size_t, pl::VoxelIndexHash> index;
  std::vector<Acc> accs;
  for (std::size_t k = 0; k < scans.size(); ++k)
    for (std::size_t i = 0; i < scans[k].points.size(); ++i) {
      const Eigen::Vector3d p = scans[k].pose * scans[k].points[i].cast<double>();
      const auto [it, fresh] = index.try_emplace(pl::voxel_index(p, 1.0 / kVoxel), accs.size());
      if (fresh) accs.emplace_back();
      Acc& a = accs[it->second];
      a.sum += p - kAt;
      ++a.n;
      ++a.labels[scans[k].labels[i]];
      if (a.last != k + 1) a.last = static_cast<std::uint32_t>(k + 1), ++a.seen;
    }
  Merged m;
  for (const Acc& a : accs) {
    m.points.push_back(kAt + a.sum / a.n);
    m.seen.push_back(a.seen);
    m.labels.push_back(static_cast<Label>(std::max_element(a.labels.begin(), a.labels.end()) - a.labels.begin()));
  }
  m.normals = pl::registration::estimate_normals(m.points, 0.5);
  return m;
}

// The street: walls at y = +-8 m (6 m high) from x = -20 to 130 m, the ground, extra boxes.
std::vector<Box> street(const std::vector<Box>& extra) {
  std::vector<Box> boxes{{{-20, 8, 0}, {130, 9, 6}, kWall}, {{-20, -9, 0}, {130, -8, 6}, kWall}};
  boxes.insert(boxes.end(), extra.begin(), extra.end());
  return boxes;
}
const Box kParkedCar{{48, 5.6, 0.3}, {52.5, 7.4, 1.6}, kParked};

// A car 4.5 x 1.8 x 1.3 m in the other lane (y 2 .. 3.8), its middle at x.
Box car_at(double x, Label label, double y0 = 2.0) { return {{x - 2.25, y0, 0.3}, {x + 2.25, y0 + 1.8, 1.6}, label}; }

struct Shares {
  std::array<std::size_t, kLabels> points{}, removed{};
  double share(Label l) const { return points[l] ? static_cast<double>(removed[l]) / points[l] : 0.0; }
};

Shares shares_of(const Merged& m, const std::vector<bool>& moving) {
  Shares s;
  for (std::size_t i = 0; i < m.points.size(); ++i) {
    ++s.points[m.labels[i]];
    if (moving[i]) ++s.removed[m.labels[i]];
  }
  return s;
}

void print(const char* what, const Shares& s, const FreeSpaceReport& r) {
  std::cout << what << ": removed ground " << s.share(kGround) * 100 << " %, walls " << s.share(kWall) * 100 << " %, parked car "
            << s.share(kParked) * 100 << " % (" << s.points[kParked] << " points), moving car " << s.share(kMoving) * 100 << " % ("
            << s.points[kMoving] << "), lead car " << s.share(kLead) * 100 << " % (" << s.points[kLead] << "), barrier "
            << s.share(kBarrier) * 100 << " %; " << r.points << " points, " << r.scans << " scans, " << r.rays << " rays, "
            << r.removed_by_rays << " removed by rays, " << r.removed_by_corridor << " by the corridor, "
            << r.ms / std::max<std::size_t>(1, r.walked) << " ms a walked scan\n";
}

// The drive: 90 scans 1 m apart along y = -2 m; the moving car drives the other way at 1.5 m a scan.
std::vector<Scan> drive_with_traffic() {
  std::vector<Scan> scans;
  for (int k = 0; k < 90; ++k)
    scans.push_back(scan_at(street({kParkedCar, car_at(100.0 - 1.5 * k, kMoving)}), 5.0 + k, -2.0, 0.3 + 0.01 * k));
  return scans;
}

struct Result {
  Merged merged;
  std::vector<bool> moving;
  std::vector<std::uint32_t> passes;
  FreeSpaceReport report;
};

Result run(const std::vector<Scan>& scans, const FreeSpaceConfig& cfg, bool with_origins = false) {
  Result r;
  r.merged = merge(scans);
  FreeSpaceFilter f(r.merged.points, r.merged.normals, r.merged.seen, kVoxel, cfg);
  f.begin_drive();
  for (const Scan& s : scans) {
    if (with_origins)
      f.add_scan(s.pose, s.points, std::vector<Eigen::Vector3f>(s.points.size(), Eigen::Vector3f::Zero()));
    else
      f.add_scan(s.pose, s.points);
  }
  r.moving = f.moving();
  r.passes = f.passes();
  r.report = f.report();
  return r;
}

TEST(FreeSpace, TheMovingCarIsRemovedAndTheStreetAndTheParkedCarKept) {
  const std::vector<Scan> scans = drive_with_traffic();
  const Result r = run(scans, FreeSpaceConfig{});
  const Shares s = shares_of(r.merged, r.moving);
  print("traffic", s, r.report);
  ASSERT_GT(s.points[kMoving], 500u);
  ASSERT_GT(s.points[kParked], 300u);
  // Its sides, front and back are crossed by later rays; its roof, 0.1 m below the sensor, only by
  // rays too grazing to count (|cos| < 0.4), so it mostly stays (the rule's known gap).
  std::size_t faces = 0, faces_removed = 0;
  for (std::size_t i = 0; i < r.moving.size(); ++i)
    if (r.merged.labels[i] == kMoving && std::abs(r.merged.normals[i].z()) < 0.7) ++faces, faces_removed += r.moving[i];
  std::cout << "moving car without its roof: " << 100.0 * static_cast<double>(faces_removed) / static_cast<double>(faces) << " % of "
            << faces << " removed\n";
  EXPECT_GE(static_cast<double>(faces_removed) / static_cast<double>(faces), 0.9);  // 93 %
  EXPECT_GE(s.share(kMoving), 0.8);
  EXPECT_LE(s.share(kWall), 0.01);
  EXPECT_LE(s.share(kGround), 0.01);
  EXPECT_LE(s.share(kParked), 0.015);  // 0.4 % (its roof's edge); 2.2 % without the confirmation rule
  EXPECT_EQ(r.report.scans, 90u);
  EXPECT_EQ(r.report.walked, 90u);
  EXPECT_GT(r.report.rays, 90u * 1000u);

  // The same drive with no traffic: almost nothing is removed.
  std::vector<Scan> quiet;
  for (int k = 0; k < 90; ++k) quiet.push_back(scan_at(street({kParkedCar}), 5.0 + k, -2.0, 0.3 + 0.01 * k));
  const Result q = run(quiet, FreeSpaceConfig{});
  const Shares qs = shares_of(q.merged, q.moving);
  print("no traffic", qs, q.report);
  EXPECT_LE(static_cast<double>(q.report.removed_by_rays + q.report.removed_by_corridor) / static_cast<double>(q.report.points), 0.005);

  // Every ray fired from the sensor itself: the same answer as no origins.
  const Result o = run(scans, FreeSpaceConfig{}, true);
  EXPECT_EQ(o.passes, r.passes);
}

TEST(FreeSpace, TheRuleNeedsEnoughScansAndShare) {
  const std::vector<Scan> scans = drive_with_traffic();
  FreeSpaceConfig strict;
  strict.min_passes = 1000;  // no point is crossed by that many scans
  strict.corridor_m = 0;
  const Result r = run(scans, strict);
  EXPECT_EQ(r.report.removed_by_rays, 0u);
  EXPECT_EQ(r.report.removed_by_corridor, 0u);
  EXPECT_GT(r.report.passed, 0u);
  // Every scan's crossing counted and one scan enough: the parked car loses more at its edges.
  FreeSpaceConfig loose;
  loose.min_passes = 1;
  loose.pass_share = 0;
  const Result l = run(scans, loose);
  const Result d = run(scans, FreeSpaceConfig{});
  EXPECT_GT(l.report.removed_by_rays, d.report.removed_by_rays);
  // Walking every third scan's rays (min_travel 2.5 m): fewer rays, the car still mostly removed.
  FreeSpaceConfig sparse;
  sparse.min_travel_m = 2.5;
  const Result p = run(scans, sparse);
  EXPECT_EQ(p.report.walked, 30u);
  EXPECT_GE(shares_of(p.merged, p.moving).share(kMoving), 0.6);
}

TEST(FreeSpace, ALeadCarInTheLaneIsRemovedByTheCorridor) {
  // A car keeping 10 m ahead in the sensor's own lane for 50 scans, then turning off: the sensor's
  // rays never see through it, but the sensor drives through every place it was.
  std::vector<Scan> scans;
  for (int k = 0; k < 60; ++k) {
    const double x = 5.0 + k;
    std::vector<Box> extra{kParkedCar};
    if (k < 50) extra.push_back(car_at(x + 10.0, kLead, -2.9));
    scans.push_back(scan_at(street(extra), x, -2.0, 0.0));
  }
  FreeSpaceConfig no_rays;
  no_rays.min_passes = 1000;
  const Result r = run(scans, no_rays);
  const Shares s = shares_of(r.merged, r.moving);
  print("lead car, corridor only", s, r.report);
  ASSERT_GT(s.points[kLead], 200u);
  EXPECT_GE(s.share(kLead), 0.9);
  EXPECT_LE(s.share(kGround), 0.001);
  EXPECT_LE(s.share(kWall), 0.001);
  EXPECT_LE(s.share(kParked), 0.001);
  FreeSpaceConfig none = no_rays;
  none.corridor_m = 0;
  const Result n = run(scans, none);
  EXPECT_EQ(shares_of(n.merged, n.moving).removed[kLead], 0u);
}

TEST(FreeSpace, TheCorridorIsNotDrawnAcrossDrives) {
  // A barrier in the lane between the end of one drive (x 5..40) and the start of the next (x 49..80).
  const Box barrier{{43, -2.5, 0.3}, {46, -1.5, 1.2}, kBarrier};
  std::vector<Scan> first, second;
  for (int k = 0; k <= 35; ++k) first.push_back(scan_at(street({barrier}), 5.0 + k, -2.0, 0.0));
  for (int k = 0; k <= 31; ++k) second.push_back(scan_at(street({barrier}), 49.0 + k, -2.0, 0.0));
  std::vector<Scan> all = first;
  all.insert(all.end(), second.begin(), second.end());
  const Merged m = merge(all);
  FreeSpaceConfig cfg;
  cfg.min_passes = 1000;
  auto removed_barrier = [&](bool new_drive) {
    FreeSpaceFilter f(m.points, m.normals, m.seen, kVoxel, cfg);
    f.begin_drive();
    for (const Scan& s : first) f.add_scan(s.pose, s.points);
    if (new_drive) f.begin_drive();
    for (const Scan& s : second) f.add_scan(s.pose, s.points);
    return shares_of(m, f.moving());
  };
  const Shares apart = removed_barrier(true), joined = removed_barrier(false);
  ASSERT_GT(apart.points[kBarrier], 50u);
  EXPECT_EQ(apart.removed[kBarrier], 0u);
  EXPECT_GE(joined.share(kBarrier), 0.5);  // one drive across it: the vehicle would have driven through it
}

TEST(FreeSpace, TimePerScanOf64Beams) {
  // 64 beams from -24.8 to +2 deg, every 0.2 deg of azimuth (115,000 returns a scan, as an HDL-64).
  const Beams hdl64{64, -24.8, 26.8 / 63, 0.2};
  std::vector<Scan> scans;
  for (int k = 0; k < 30; ++k)
    scans.push_back(scan_at(street({kParkedCar, car_at(60.0 - 1.5 * k, kMoving)}), 20.0 + k, -2.0, 0.0, hdl64));
  const Result r = run(scans, FreeSpaceConfig{});
  const Shares s = shares_of(r.merged, r.moving);
  print("64 beams", s, r.report);
  std::cout << r.report.rays / r.report.walked << " rays a scan of " << scans[0].points.size() << " returns\n";
  EXPECT_LE(s.share(kWall), 0.01);
  EXPECT_LE(s.share(kGround), 0.01);
  // The drive ends beside the parked car: its roof's edge, seen by the last scan alone and
  // passed close over by earlier rays (edge normals tilted), goes (20 of 307 points, 6.5 %, with
  // crossings down to |cos| 0.2; 12 at 0.4).
  EXPECT_LE(s.share(kParked), 0.08);
  EXPECT_GE(s.share(kMoving), 0.8);
  EXPECT_LT(r.report.ms / static_cast<double>(r.report.walked), 1000.0);  // a bound for a loaded machine; typical figure in the log
}

TEST(FreeSpace, SkyRaysClearWhatStoodAboveTheSensor) {
  // An open street: a truck (to 3.5 m, above the 1.7 m sensor) parked in the other lane for the
  // first 20 scans, then gone; a post stays. 64 beams up to +2 deg: only rays from 15 m or more pass
  // where the truck's upper part was, and those return nothing (the sky).
  const Beams hdl64{64, -24.8, 26.8 / 63, 0.4};
  const Box truck{{60, 2, 0.3}, {68, 4.5, 3.5}, kTruck}, post{{70, -5, 0}, {70.3, -4.7, 5}, kPost};
  std::vector<Scan> scans;
  for (int k = 0; k < 60; ++k) {
    std::vector<Box> boxes{post};
    if (k < 20) boxes.push_back(truck);
    scans.push_back(scan_at(boxes, 5.0 + k, -2.0, 0.0, hdl64));
  }
  const Merged m = merge(scans);
  auto removed = [&](const FreeSpaceConfig& cfg, const std::vector<double>& beams, std::size_t& above, std::size_t& above_removed) {
    FreeSpaceFilter f(m.points, m.normals, m.seen, kVoxel, cfg);
    f.begin_drive(beams);
    for (const Scan& s : scans) f.add_scan(s.pose, s.points);
    const std::vector<bool> moving = f.moving();
    above = above_removed = 0;  // the truck above 2.2 m
    for (std::size_t i = 0; i < m.points.size(); ++i)
      if (m.labels[i] == kTruck && m.points[i].z() - kAt.z() > 2.2) ++above, above_removed += moving[i];
    print("sky rays", shares_of(m, moving), f.report());
    return shares_of(m, moving);
  };
  std::vector<double> beams;
  for (int b = 0; b < hdl64.count; ++b) beams.push_back(hdl64.lowest_deg + b * hdl64.step_deg);
  FreeSpaceConfig sky, no_sky;
  sky.sky_range_m = 50;  // within this scene's 60 m range: a bin without a return is free that far
  no_sky.sky_range_m = 0;
  std::size_t above = 0, with = 0, without = 0;
  const Shares s = removed(sky, beams, above, with);
  const Shares n = removed(no_sky, beams, above, without);
  std::cout << "post: " << s.points[kPost] << " points, removed " << s.removed[kPost] << " with sky rays, " << n.removed[kPost] << " without\n";
  std::cout << "truck above 2.2 m: " << above << " points, removed " << with << " with sky rays, " << without << " without\n";
  ASSERT_GT(above, 20u);
  // 24 %: what the later scans' rays reach (from 35 m at most, below 2.9 m); its ends by the
  // tangent-plane test, its roof and sides, which they graze, by sky_near_deg.
  EXPECT_GE(static_cast<double>(with) / static_cast<double>(above), 0.2);
  FreeSpaceConfig tangent_only = sky;
  tangent_only.sky_near_deg = 0;
  std::size_t tangent = 0;
  removed(tangent_only, beams, above, tangent);
  EXPECT_LT(tangent, with);
  EXPECT_EQ(without, 0u);
  EXPECT_EQ(s.removed[kPost], 0u);
  EXPECT_LE(s.share(kGround), 0.01);
  // Without the beam table (begin_drive()) there are no sky rays.
  std::size_t none = 0;
  removed(sky, {}, above, none);
  EXPECT_EQ(none, without) << "sky rays without a beam table";
}

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const pl::Error& e) {
    return e.what();
  }
  return {};
}

TEST(FreeSpace, ChecksItsSettingsAndInputs) {
  const pl::Points3d points{kAt, kAt + Eigen::Vector3d(1, 0, 0)};
  const std::vector<Eigen::Vector3f> normals(2, Eigen::Vector3f::UnitZ());
  const std::vector<std::uint32_t> seen(2, 1);
  auto with = [&](auto change) {
    FreeSpaceConfig c;
    change(c);
    return error_of([&] { FreeSpaceFilter f(points, normals, seen, kVoxel, c); });
  };
  EXPECT_EQ(with([](FreeSpaceConfig&) {}), "");
  EXPECT_NE(with([](FreeSpaceConfig& c) { c.max_range_m = 2; }).find("max_range_m"), std::string::npos);
  EXPECT_NE(with([](FreeSpaceConfig& c) { c.ray_voxel_m = 0; }).find("ray_voxel_m"), std::string::npos);
  EXPECT_NE(with([](FreeSpaceConfig& c) { c.min_travel_m = -1; }).find("min_travel_m"), std::string::npos);
  EXPECT_NE(with([](FreeSpaceConfig& c) { c.min_passes = 0; }).find("min_passes"), std::string::npos);
  EXPECT_NE(with([](FreeSpaceConfig& c) { c.pass_share = 1.5; }).find("pass_share"), std::string::npos);
  EXPECT_NE(with([](FreeSpaceConfig& c) { c.corridor_m = -1; }).find("corridor_m"), std::string::npos);
  EXPECT_NE(with([](FreeSpaceConfig& c) { c.corridor_below_m = std::nan(""); }).find("corridor_below_m"), std::string::npos);
  EXPECT_NE(with([](FreeSpaceConfig& c) { c.ray.step_m = 0; }).find("step_m"), std::string::npos);
  EXPECT_NE(error_of([&] { FreeSpaceFilter f(points, normals, std::vector<std::uint32_t>{1}, kVoxel, {}); }).find("seen"), std::string::npos);
  EXPECT_NE(error_of([&] { FreeSpaceFilter f(points, normals, seen, 0.0, {}); }).find("voxel_m"), std::string::npos);

  FreeSpaceFilter f(points, normals, seen, kVoxel, {});
  const pl::Pose at = pl::Pose(Eigen::Translation3d(kAt));
  const std::vector<Eigen::Vector3f> two{Eigen::Vector3f(5, 0, 0), Eigen::Vector3f(6, 0, 0)};
  EXPECT_NE(error_of([&] { f.add_scan(at, two, std::vector<Eigen::Vector3f>(1, Eigen::Vector3f::Zero())); }).find("origins"),
            std::string::npos);
  EXPECT_EQ(error_of([&] { f.add_scan(at, two, std::vector<Eigen::Vector3f>(2, Eigen::Vector3f::Zero())); }), "");
  EXPECT_EQ(f.report().scans, 1u);  // the refused scan was not counted
}

}  // namespace
