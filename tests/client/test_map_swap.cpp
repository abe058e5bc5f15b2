// A vehicle moves to a newer map version mid-drive: a real pl-server serves map "street" v1, the
// vehicle localizes along it following the map's versions; halfway the street changes (a parked van
// gone, a container put down) and v2, its changed tiles rebuilt as pl-map update makes them, is
// published. The vehicle takes v2 between two scans, with the tiles the versions share taken from
// what it holds, and its pose goes on without a jump.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <map>
#include <vector>

#include "pl/client/vehicle_localizer.hpp"
#include "pl/common/pose.hpp"
#include "pl/common/tile_codec.hpp"
#include "pl/schema/store.hpp"
#include "scene.hpp"
#include "server_process.hpp"
#include "test_util.hpp"

namespace {

using pl::client::VehicleLocalizer;
using pl::client::VehicleLocalizerConfig;

constexpr double kTile = 20.0;

void put(pl::store::Store& store, std::int64_t version, const pl::TileKey& key, const pl::TileCloud& cloud) {
  Eigen::AlignedBox3d box;
  for (const auto& p : cloud.points) box.extend(p);
  store.put_tile("street", version, key, pl::encode_tile(cloud), static_cast<std::int64_t>(cloud.size()), box.min().x(), box.min().y(),
                 box.min().z(), box.max().x(), box.max().y(), box.max().z());
}

Eigen::Isometry3d base_at(double t) { return pl::make_pose(-20.0 + 5.0 * t, 0.5, 0.0, 0, 0, 0.02 * t); }

// The street "six months later": the van parked at x = 7..11 is gone, a container stands at x = 10..16.
std::vector<pl::test::Surface> street_later() {
  std::vector<pl::test::Surface> s;
  for (const auto& surface : pl::test::street())
    if (surface.origin.x() != 7.0 && surface.origin.x() != 11.0) s.push_back(surface);
  const Eigen::Vector3d o{10.0, 2.0, 0.0}, along{6.0, 0.0, 0.0}, across{0.0, 2.4, 0.0}, up{0.0, 0.0, 2.6};
  s.push_back({o, along, up});
  s.push_back({o + across, along, up});
  s.push_back({o, across, up});
  s.push_back({o + along, across, up});
  s.push_back({o + up, along, across});
  return s;
}

pl::Scan scan_from(const std::vector<pl::test::Surface>& world, const Eigen::Isometry3d& lidar_in_map, unsigned seed) {
  pl::Scan out;
  for (const auto& p : pl::test::scan_of(world, lidar_in_map, 0.5, 60.0, seed)) out.push_back({p.x(), p.y(), p.z(), 0.5f});
  return out;
}

}  // namespace

TEST(MapSwap, ANewVersionMovesInMidDriveWithoutAJump) {
  const pl::test::TempDir dir;
  const std::string db = dir / "maps.sqlite";
  const auto tiles = pl::test::surface_tiles(pl::test::street(), 0.2, kTile);
  {
    auto store = pl::store::Store::open(db);
    store.create_map("street", pl::GeoPoint{49.0, 8.4, 110.0}, kTile, 0.2);
    store.create_version("street", std::nullopt, "v1");
    for (const auto& [key, cloud] : tiles) put(store, 1, key, cloud);
    store.publish("street", 1);
  }
  pl::test::ServerProcess server(db);

  VehicleLocalizerConfig cfg;
  cfg.tiles.server = server.url();
  cfg.tiles.map = "street";
  cfg.tiles.follow_s = 0.05;
  cfg.localizer.scan.voxel_m = 0.5;
  VehicleLocalizer loc(cfg);
  ASSERT_EQ(loc.map_version(), 1);
  auto odometry = [](double t) { return base_at(0.0).inverse() * base_at(t); };
  loc.add_odometry_pose(0.0, odometry(0.0));
  loc.start(base_at(0.0), 0.0);
  ASSERT_TRUE(loc.wait_idle());

  // v2: the tiles the change touched, rebuilt from the street as it is now.
  std::map<pl::TileKey, pl::TileCloud> rebuilt;
  for (const auto& [key, cloud] : pl::test::surface_tiles(street_later(), 0.2, kTile))
    if (!tiles.count(key) || tiles.at(key).points != cloud.points) rebuilt.emplace(key, cloud);
  ASSERT_EQ(rebuilt.size(), 2u) << "the van's tile and the container's";

  double max_error = 0, max_step_error = 0;
  Eigen::Isometry3d previous = base_at(0.0);
  int moved_at = -1;
  for (int k = 1; k <= 40; ++k) {
    const double t = 0.1 * k;
    for (int i = 1; i <= 10; ++i) loc.add_odometry_pose(t - 0.1 + 0.01 * i, odometry(t - 0.1 + 0.01 * i));
    if (k == 12) {  // v2 is published (by pl-map update on the service, here straight into the store)
      auto store = pl::store::Store::open(db, false);
      store.create_version("street", 1, "update");
      for (const auto& [key, cloud] : rebuilt) put(store, 2, key, cloud);
      store.publish("street", 2);
    }
    loc.add_scan(t, scan_from(k < 12 ? pl::test::street() : street_later(), base_at(t), 100 + static_cast<unsigned>(k)));
    ASSERT_TRUE(loc.wait_idle());
    if (moved_at < 0 && loc.map_version() == 2) moved_at = k;
    const auto p = loc.pose_at(t);
    ASSERT_TRUE(p.valid);
    EXPECT_EQ(p.health, pl::client::Health::Ok) << "scan " << k << ": " << p.note;
    max_error = std::max(max_error, (p.base_in_map.translation() - base_at(t).translation()).norm());
    // The fused pose's step against the true step: a jump at the move would show here.
    const Eigen::Vector3d step = p.base_in_map.translation() - previous.translation();
    const Eigen::Vector3d truth = base_at(t).translation() - base_at(t - 0.1).translation();
    if (k > 1) max_step_error = std::max(max_step_error, (step - truth).norm());
    previous = p.base_in_map;
    if (moved_at > 0 && k >= moved_at + 5) break;
  }
  ASSERT_GT(moved_at, 12) << "the vehicle never moved to version 2: " << loc.last_error();
  EXPECT_EQ(loc.version_moves(), 1u);
  std::printf("moved to v2 at scan %d (published before scan 12); max position error %.4f m, max step error %.4f m\n", moved_at,
              max_error, max_step_error);
  EXPECT_LT(max_error, 0.05);
  EXPECT_LT(max_step_error, 0.03);
  const auto st = loc.tile_status();
  EXPECT_EQ(st.version, 2);
  EXPECT_GT(st.seeded, 0u) << "the tiles both versions share come from what the vehicle held";
  // The ROI map holds the rebuilt tiles' new bytes.
  const auto store = pl::store::Store::open(db, false);
  for (const auto& [key, cloud] : rebuilt) {
    const auto v1 = store.find_tile("street", 1, key), v2 = store.find_tile("street", 2, key);
    ASSERT_TRUE(v1 && v2);
    const std::string v2_hash = v2->hash;
    EXPECT_NE(v2_hash, v1->hash);
    bool held = false;
    for (const auto& t : loc.map_tiles()) held |= t.key == key && t.hash == v2_hash;
    EXPECT_TRUE(held) << "tile " << key.tx << "/" << key.ty;
  }
}
