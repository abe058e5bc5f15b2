// A vehicle moves to a newer map version mid-drive: a real pl-server serves map "street" v1, the
// vehicle localizes along it following the map's versions, v2 (one tile rebuilt, as pl-map update
// makes them) is published halfway; the vehicle takes it between two scans, with the tiles the
// versions share taken from what it holds, and its pose goes on without a jump.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

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

pl::Scan scan_from(const Eigen::Isometry3d& lidar_in_map, unsigned seed) {
  pl::Scan out;
  for (const auto& p : pl::test::scan_of(pl::test::street(), lidar_in_map, 0.5, 60.0, seed)) out.push_back({p.x(), p.y(), p.z(), 0.5f});
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

  // The tile the vehicle drives through at x = 0..20, rebuilt: every other point (another hash).
  const pl::TileKey changed{0, 0};
  ASSERT_TRUE(tiles.count(changed));
  pl::TileCloud thinned;
  const pl::TileCloud& full = tiles.at(changed);
  for (std::size_t i = 0; i < full.size(); i += 2) {
    thinned.points.push_back(full.points[i]);
    if (!full.normals.empty()) thinned.normals.push_back(full.normals[i]);
    if (!full.intensity.empty()) thinned.intensity.push_back(full.intensity[i]);
  }

  double max_error = 0, max_step_error = 0;
  Eigen::Isometry3d previous = base_at(0.0);
  int moved_at = -1;
  for (int k = 1; k <= 40; ++k) {
    const double t = 0.1 * k;
    for (int i = 1; i <= 10; ++i) loc.add_odometry_pose(t - 0.1 + 0.01 * i, odometry(t - 0.1 + 0.01 * i));
    if (k == 12) {  // v2 is published (by pl-map update on the service, here straight into the store)
      auto store = pl::store::Store::open(db, false);
      store.create_version("street", 1, "update");
      put(store, 2, changed, thinned);
      store.publish("street", 2);
    }
    loc.add_scan(t, scan_from(base_at(t), 100 + static_cast<unsigned>(k)));
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
  // The ROI map holds the rebuilt tile's new bytes.
  const std::string v2_hash = pl::store::Store::open(db, false).find_tile("street", 2, changed)->hash;
  bool held = false;
  for (const auto& t : loc.map_tiles()) held |= t.key == changed && t.hash == v2_hash;
  EXPECT_TRUE(held);
}
