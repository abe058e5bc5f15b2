// The embeddable localizer (VehicleLocalizer) as a vehicle program uses it: a real map store file,
// odometry fed from one thread while scans arrive from another and a control loop reads poses from
// a third; a LiDAR mounted off the base (extrinsics), a start from a GPS fix with no heading, a start
// that finds nothing (said, not guessed), inputs refused with a reason.
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <thread>

#include "pl/client/vehicle_localizer.hpp"
#include "pl/common/error.hpp"
#include "pl/common/pose.hpp"
#include "pl/common/tile_codec.hpp"
#include "pl/schema/store.hpp"
#include "scene.hpp"
#include "test_util.hpp"

namespace {

using pl::client::VehicleLocalizer;
using pl::client::VehicleLocalizerConfig;

constexpr double kTile = 20.0;

// The street of scene.hpp as map "street" version 1 of a real map store.
std::string street_store(const pl::test::TempDir& dir) {
  const auto tiles = pl::test::surface_tiles(pl::test::street(), 0.2, kTile);
  const std::string path = dir / "maps.sqlite";
  auto store = pl::store::Store::open(path);
  store.create_map("street", pl::GeoPoint{49.0, 8.4, 110.0}, kTile, 0.2);
  const auto v = store.create_version("street", std::nullopt, "test");
  for (const auto& [key, cloud] : tiles) {
    Eigen::AlignedBox3d box;
    for (const auto& p : cloud.points) box.extend(p);
    store.put_tile("street", v.number, key, pl::encode_tile(cloud), static_cast<std::int64_t>(cloud.size()), box.min().x(),
                   box.min().y(), box.min().z(), box.max().x(), box.max().y(), box.max().z());
  }
  store.publish("street", v.number);
  return path;
}

VehicleLocalizerConfig config(const std::string& store) {
  VehicleLocalizerConfig cfg;
  cfg.store_path = store;
  cfg.tiles.map = "street";
  cfg.localizer.scan.voxel_m = 0.5;  // the synthetic scan is sparse already
  return cfg;
}

// The base drives along the street at 5 m/s from x = -20.
Eigen::Isometry3d base_at(double t) { return pl::make_pose(-20.0 + 5.0 * t, 0.5, 0.0, 0, 0, 0.02 * t); }

pl::Scan scan_from(const Eigen::Isometry3d& lidar_in_map, unsigned seed) {
  pl::Scan out;
  for (const auto& p : pl::test::scan_of(pl::test::street(), lidar_in_map, 0.5, 60.0, seed))
    out.push_back({p.x(), p.y(), p.z(), 0.5f});
  return out;
}

TEST(VehicleLocalizer, ThreeThreadsOdometryScansAndPosesWithAnOffsetLidar) {
  const pl::test::TempDir dir;
  VehicleLocalizerConfig cfg = config(street_store(dir));
  cfg.base_from_lidar = pl::make_pose(0.8, 0.0, 1.8, 0, 0, 0.15);  // forward, up and turned
  VehicleLocalizer loc(cfg);
  EXPECT_EQ(loc.tile_size(), kTile);
  EXPECT_EQ(loc.map_origin().lat_deg, 49.0);  // the store's: GPS fixes go into the map frame about it
  EXPECT_EQ(loc.map_origin().lon_deg, 8.4);
  EXPECT_EQ(loc.map_origin().alt_m, 110.0);
  EXPECT_FALSE(loc.pose_at(0.0).valid);
  // Odometry with a 3 % scale error: the LiDAR must keep correcting it.
  auto odometry = [](double t) {
    Eigen::Isometry3d o = base_at(0.0).inverse() * base_at(t);
    o.translation() *= 1.03;
    return o;
  };
  loc.add_odometry_pose(0.0, odometry(0.0));
  loc.start(base_at(0.0), 0.0);
  ASSERT_TRUE(loc.wait_idle());
  ASSERT_TRUE(loc.pose_at(0.0).valid) << loc.last_error();

  std::atomic<bool> done{false};
  std::atomic<int> reads{0};
  std::thread control([&] {  // reads poses the whole time, never waiting for registration
    while (!done) {
      const auto p = loc.pose_at(0.5);
      EXPECT_TRUE(p.valid);
      EXPECT_TRUE(p.base_in_map.matrix().allFinite());
      ++reads;
    }
  });
  std::thread driver([&] {  // 100 Hz odometry while the scans arrive
    for (int i = 1; i <= 160; ++i) loc.add_odometry_pose(0.01 * i, odometry(0.01 * i));
  });
  for (int k = 1; k <= 15; ++k) {
    const double t = 0.1 * k;
    loc.add_scan(t, scan_from(base_at(t) * cfg.base_from_lidar, 20 + k));
    ASSERT_TRUE(loc.wait_idle());
  }
  driver.join();
  loc.add_scan(1.6, scan_from(base_at(1.6) * cfg.base_from_lidar, 40));  // one with all the odometry there
  ASSERT_TRUE(loc.wait_idle());
  done = true;
  control.join();
  EXPECT_GT(reads.load(), 0);
  const auto r = loc.last_report();
  EXPECT_TRUE(r.fused_lidar) << r.note;
  const auto p = loc.pose_at(1.6);
  ASSERT_TRUE(p.valid);
  EXPECT_EQ(p.health, pl::client::Health::Ok) << p.note;
  EXPECT_LT((p.base_in_map.translation() - base_at(1.6).translation()).norm(), 0.05);
  EXPECT_LT(pl::rotation_angle(p.base_in_map.inverse() * base_at(1.6)), 0.005);
  // The covariance grows with the time since the last fused scan.
  EXPECT_GT(loc.pose_at(1.9).covariance(0, 0), p.covariance(0, 0));
}

TEST(VehicleLocalizer, StartsFromAGpsFixWithNoHeading) {
  const pl::test::TempDir dir;
  VehicleLocalizerConfig cfg = config(street_store(dir));
  cfg.start_from_gps = true;
  cfg.base_from_antenna = Eigen::Vector3d(-0.5, 0.3, 1.7);
  VehicleLocalizer loc(cfg);
  // The truth heads 40 degrees off +x; the fix is 2 m off (single-point GPS).
  const Eigen::Isometry3d truth = pl::make_pose(4.0, 1.0, 0.0, 0, 0, 40.0 * M_PI / 180.0);
  const Eigen::Vector3d antenna = truth * cfg.base_from_antenna + Eigen::Vector3d(1.5, -1.3, 0.0);
  loc.add_scan(0.0, scan_from(truth, 3));  // no fix yet: nothing to start from, the scan is dropped
  ASSERT_TRUE(loc.wait_idle());
  EXPECT_FALSE(loc.pose_at(0.0).valid);
  loc.add_gps(0.05, antenna);
  loc.add_scan(0.1, scan_from(truth, 4));
  ASSERT_TRUE(loc.wait_idle());
  const auto p = loc.pose_at(0.1);
  ASSERT_TRUE(p.valid) << loc.last_error();
  EXPECT_LT((p.base_in_map.translation() - truth.translation()).norm(), 0.05);
  EXPECT_LT(std::abs(pl::yaw_of(p.base_in_map) - pl::yaw_of(truth)), 0.01);
}

TEST(VehicleLocalizer, AStartThatFindsNothingSaysSo) {
  const pl::test::TempDir dir;
  VehicleLocalizer loc(config(street_store(dir)));
  loc.start_near(pl::make_pose(300.0, 300.0, 0.0), 0.0);  // far off the map
  // The scans search round the guess and find nothing: lost, never ok, with a reason.
  for (int i = 0; i < 3; ++i) {
    loc.add_scan(0.1 * i, scan_from(pl::make_pose(0, 0, 1.8), 5 + i));
    ASSERT_TRUE(loc.wait_idle());
    const auto p = loc.pose_at(0.1 * i);
    EXPECT_EQ(p.health, pl::client::Health::Lost) << "scan " << i << ": " << p.note;
    EXPECT_FALSE(p.note.empty());
    EXPECT_NE(loc.last_report().health, pl::client::Health::Ok);
  }
}

TEST(VehicleLocalizer, RefusesBadInputWithAReason) {
  const pl::test::TempDir dir;
  const std::string store = street_store(dir);
  VehicleLocalizer loc(config(store));
  EXPECT_THROW(loc.add_wheel_travel(0.0, 0.0, 0.0), pl::Error);  // no wheel base configured
  const pl::Scan scan = scan_from(pl::make_pose(0, 0, 1.8), 6);
  EXPECT_THROW(loc.add_scan(0.0, scan, std::vector<std::uint16_t>(3)), pl::Error);
  EXPECT_THROW(loc.add_scan(0.0, scan, {}, std::vector<float>(2)), pl::Error);
  EXPECT_THROW(loc.add_scan(NAN, scan), pl::Error);
  loc.add_odometry_pose(1.0, Eigen::Isometry3d::Identity());
  EXPECT_THROW(loc.add_odometry_pose(0.5, Eigen::Isometry3d::Identity()), pl::Error);  // time went back
  VehicleLocalizerConfig bad = config(store);
  bad.tiles.map = "nosuchmap";
  EXPECT_THROW(VehicleLocalizer{bad}, pl::Error);
  bad = config(store);
  bad.max_odometry_samples = 1;
  EXPECT_THROW(VehicleLocalizer{bad}, pl::Error);
}

TEST(VehicleLocalizer, WheelTicksTwistsAndIncrementsAgree) {
  // The same straight 2 m at 1 m/s, as wheel ticks, as twists and as increments: the same pose.
  const pl::test::TempDir dir;
  const std::string store = street_store(dir);
  std::vector<Eigen::Isometry3d> ends;
  for (int kind = 0; kind < 3; ++kind) {
    VehicleLocalizerConfig cfg = config(store);
    cfg.wheel_base_m = 1.6;
    cfg.metres_per_tick = 0.001;
    VehicleLocalizer loc(cfg);
    for (int i = 0; i <= 200; ++i) {
      const double t = 0.01 * i;
      if (kind == 0) loc.add_wheel_ticks(t, 10 * i, 10 * i);
      if (kind == 1) loc.add_twist(t, Eigen::Vector3d(1.0, 0, 0), Eigen::Vector3d::Zero());
      if (kind == 2) loc.add_odometry_increment(t, i == 0 ? Eigen::Isometry3d::Identity() : pl::make_pose(0.01, 0, 0));
      if (i == 0) {
        loc.start(base_at(0.0), 0.0);
        ASSERT_TRUE(loc.wait_idle());
      }
    }
    ends.push_back(loc.pose_at(2.0).base_in_map);
  }
  for (const auto& e : ends) EXPECT_LT((e.translation() - (base_at(0.0) * Eigen::Vector3d(2.0, 0, 0))).norm(), 1e-6);
}

}  // namespace
