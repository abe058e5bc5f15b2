// Change evidence on generated scenes: a street (ground, a wall, a parked car) mapped, then scanned
// again after something changed. Scans are cast here against boxes, so each test knows exactly what
// changed.
#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <cmath>
#include <optional>
#include <vector>

#include "pl/client/change_evidence.hpp"
#include "pl/common/error.hpp"
#include "ray_box.hpp"

namespace {

using pl::client::ChangeEvidence;
using pl::client::ChangeEvidenceConfig;
using pl::schema::ChangeCell;
using pl::schema::TileChangeEvidence;

struct Box {
  Eigen::Vector3d lo, hi;
};

// The scene: the ground z = 0 and boxes.
struct Scene {
  std::vector<Box> boxes;

  // The first return along a ray from `o` in direction `d` (unit), within 60 m.
  std::optional<double> cast(const Eigen::Vector3d& o, const Eigen::Vector3d& d) const {
    double best = 60.0;
    bool hit = false;
    if (d.z() < -1e-9) {
      const double t = -o.z() / d.z();
      if (t > 0 && t < best) best = t, hit = true;
    }
    for (const Box& b : boxes) {
      if (const auto t = pl::test::ray_enters_box(o, d, b.lo, b.hi, best)) best = *t, hit = true;
    }
    if (!hit) return std::nullopt;
    return best;
  }

  // A 360 deg scan from a sensor at `at` (1.7 m up): 24 beams from -20 to +3 deg, every 0.5 deg.
  std::vector<Eigen::Vector3f> scan(const Eigen::Vector3d& at) const {
    std::vector<Eigen::Vector3f> out;
    for (int b = 0; b < 24; ++b) {
      const double el = (-20.0 + b) * M_PI / 180.0;
      for (int a = 0; a < 720; ++a) {
        const double az = a * 0.5 * M_PI / 180.0;
        const Eigen::Vector3d d(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el));
        if (const auto t = cast(at, d)) out.push_back((d * *t).cast<float>());
      }
    }
    return out;
  }
};

// Map points on the ground (a 140 m square round the origin: beyond every return kept) and on every face of the boxes, every
// 0.2 m, with their normals.
void add_map(pl::registration::PointMap& map, const Scene& scene) {
  std::vector<Eigen::Vector3d> p;
  std::vector<Eigen::Vector3f> n;
  for (double x = -70; x < 70; x += 0.2)
    for (double y = -70; y < 70; y += 0.2) {
      p.emplace_back(x + 0.1, y + 0.1, 0.0);
      n.emplace_back(0, 0, 1);
    }
  for (const Box& b : scene.boxes)
    for (int k = 0; k < 3; ++k)
      for (int side = 0; side < 2; ++side) {
        const int u = (k + 1) % 3, v = (k + 2) % 3;
        for (double s = b.lo[u]; s <= b.hi[u] + 1e-9; s += 0.2)
          for (double t = b.lo[v]; t <= b.hi[v] + 1e-9; t += 0.2) {
            Eigen::Vector3d q;
            q[k] = side ? b.hi[k] : b.lo[k];
            q[u] = s;
            q[v] = t;
            if (q.z() <= 0) continue;
            Eigen::Vector3f normal = Eigen::Vector3f::Zero();
            normal[k] = side ? 1.0f : -1.0f;
            p.push_back(q);
            n.push_back(normal);
          }
      }
  map.add(1, p, n);
}

const Box kWall{{15, -20, 0}, {15.5, 20, 4}};
const Box kCar{{7, 2, 0}, {11.5, 3.8, 1.5}};

Eigen::Isometry3d sensor_at(double x, double y) {
  Eigen::Isometry3d s = Eigen::Isometry3d::Identity();
  s.translation() = Eigen::Vector3d(x, y, 1.7);
  return s;
}

struct Counts {
  std::uint32_t added = 0, free = 0, seen = 0, passed = 0;
  std::size_t added_cells = 0, removed_cells = 0;
};

// The evidence summed over the voxels inside `box` (grown by half a voxel).
Counts inside(const std::vector<TileChangeEvidence>& tiles, const Box& box, double voxel) {
  Counts c;
  for (const auto& t : tiles)
    for (const ChangeCell& cell : t.cells) {
      const Eigen::Vector3d centre((cell.x + 0.5) * voxel, (cell.y + 0.5) * voxel, (cell.z + 0.5) * voxel);
      if (((centre - box.lo).array() < -voxel).any() || ((centre - box.hi).array() > voxel).any()) continue;
      c.added += cell.added, c.free += cell.free, c.seen += cell.seen, c.passed += cell.passed;
      c.added_cells += cell.added >= 2;
      c.removed_cells += cell.passed >= 2 && cell.passed >= 2 * cell.seen;
    }
  return c;
}

// Drives past on y = -3, one scan every 2 m from x = -6 to 24.
std::vector<TileChangeEvidence> drive_past(const Scene& world, const pl::registration::PointMap& map, ChangeEvidenceConfig cfg = {}) {
  cfg.min_travel_m = 0;
  ChangeEvidence ev(cfg, 20.0);
  for (double x = -6; x <= 24; x += 2) {
    const Eigen::Isometry3d s = sensor_at(x, -3);
    ev.add(s, world.scan(s.translation()), map);
  }
  EXPECT_EQ(ev.scans_used(), 16u);
  return ev.tiles();
}

TEST(ChangeEvidence, AParkedCarGoneIsPassedThrough) {
  pl::registration::PointMap map(Eigen::Vector3d::Zero(), 0.5);
  add_map(map, Scene{{kWall, kCar}});
  const auto tiles = drive_past(Scene{{kWall}}, map);
  const Counts car = inside(tiles, kCar, 0.5), wall = inside(tiles, kWall, 0.5);
  EXPECT_GE(car.removed_cells, 10u) << "passed " << car.passed << ", seen " << car.seen;
  EXPECT_EQ(car.added_cells, 0u);
  // The wall, still there, is neither removed nor added.
  EXPECT_EQ(wall.removed_cells, 0u) << "passed " << wall.passed;
  EXPECT_EQ(wall.added_cells, 0u);
}

TEST(ChangeEvidence, AStillParkedCarIsNoChange) {
  pl::registration::PointMap map(Eigen::Vector3d::Zero(), 0.5);
  add_map(map, Scene{{kWall, kCar}});
  const auto tiles = drive_past(Scene{{kWall, kCar}}, map);
  std::size_t added = 0, removed = 0;
  for (const auto& t : tiles)
    for (const ChangeCell& c : t.cells) {
      added += c.added >= 2;
      removed += c.passed >= 2 && c.passed >= 2 * c.seen;
    }
  // Rays grazing the car's roof and ends pass near its edge points without passing through them.
  EXPECT_EQ(added, 0u);
  EXPECT_EQ(removed, 0u);
  EXPECT_GT(tiles.size(), 1u);
  for (const auto& t : tiles) EXPECT_GT(t.scans, 0u);
}

TEST(ChangeEvidence, ANewThingIsAddedAndStaysOpaque) {
  pl::registration::PointMap map(Eigen::Vector3d::Zero(), 0.5);
  add_map(map, Scene{{kWall}});
  const Box container{{4, 4, 0}, {10, 6.5, 2.6}};
  const auto tiles = drive_past(Scene{{kWall, container}}, map);
  const Counts c = inside(tiles, container, 0.5);
  EXPECT_GE(c.added_cells, 10u);
  EXPECT_LE(c.free * 4, c.added) << "a parked thing is not seen through";
  // The sample of what was added lies on the container's faces the vehicle saw (y = 4 and x = 4/10,
  // the roof), and nowhere else: enough points to rebuild it on the map's 0.2 m grid.
  std::size_t points = 0, on_faces = 0;
  for (const auto& t : tiles)
    for (const auto& q : t.points) {
      ++points;
      const Eigen::Vector3d p(q[0] / 100.0, q[1] / 100.0, q[2] / 100.0);
      const bool inside_grown = (p.array() >= container.lo.array() - 0.15).all() && (p.array() <= container.hi.array() + 0.15).all();
      const double to_face = std::min({std::abs(p.y() - container.lo.y()), std::abs(p.x() - container.lo.x()),
                                       std::abs(p.x() - container.hi.x()), std::abs(p.z() - container.hi.z())});
      on_faces += inside_grown && to_face < 0.15;
    }
  EXPECT_GE(points, 100u);
  EXPECT_EQ(on_faces, points);
}

TEST(ChangeEvidence, AMovingTruckIsSeenThroughOnceItHasGone) {
  pl::registration::PointMap map(Eigen::Vector3d::Zero(), 0.5);
  add_map(map, Scene{{kWall}});
  ChangeEvidenceConfig cfg;
  cfg.min_travel_m = 0;
  ChangeEvidence ev(cfg, 20.0);
  const Box truck{{6, 1, 0}, {8.5, 8, 3}};
  for (int k = 0; k < 12; ++k) {
    const Eigen::Isometry3d s = sensor_at(-4 + 2 * k, -3);
    // The truck stands there for the first two scans only.
    const Scene world = k < 2 ? Scene{{kWall, truck}} : Scene{{kWall}};
    ev.add(s, world.scan(s.translation()), map);
  }
  const Counts c = inside(ev.tiles(), truck, 0.5);
  ASSERT_GT(c.added, 0u);
  EXPECT_GT(c.free, c.added) << "the scans after it left saw through where it stood";
}

TEST(ChangeEvidence, ATruckFollowingInTheLaneIsNoChange) {
  // A truck 8 m behind, stopping when the vehicle stops at a light for six scans: never seen through
  // (it hides where it stood), but it stands only where the vehicle drove a moment before. Evidence
  // from every scan (min_travel_m 0), so that only the corridor can tell.
  pl::registration::PointMap map(Eigen::Vector3d::Zero(), 0.5);
  add_map(map, Scene{{kWall}});
  auto lane_added = [&](double corridor) {
    ChangeEvidenceConfig cfg;
    cfg.corridor_m = corridor;
    cfg.min_travel_m = 0;
    ChangeEvidence ev(cfg, 20.0);
    std::vector<double> stops;
    for (double x = -10; x <= 12; x += 2) {
      stops.push_back(x);
      if (x == 0)
        for (int k = 0; k < 5; ++k) stops.push_back(x);
    }
    for (double x : stops) {
      const Box truck{{x - 18, -1.2, 0}, {x - 8, 1.2, 3.5}};
      ev.add(sensor_at(x, 0), Scene{{kWall, truck}}.scan(Eigen::Vector3d(x, 0, 1.7)), map);
    }
    std::size_t n = 0;
    for (const auto& t : ev.tiles())
      for (const ChangeCell& c : t.cells) n += c.added >= 2 && std::abs((c.y + 0.5) * 0.5) < 1.0;
    return n;
  };
  EXPECT_GT(lane_added(0), 10u) << "without the corridor the truck's trail stays";
  EXPECT_EQ(lane_added(1.0), 0u);
}

TEST(ChangeEvidence, KeepsItsBoundsAndChecksItsSettings) {
  pl::registration::PointMap map(Eigen::Vector3d::Zero(), 0.5);
  add_map(map, Scene{{kWall, kCar}});
  ChangeEvidenceConfig cfg;
  cfg.max_cells_per_tile = 3;
  for (const auto& t : drive_past(Scene{{kWall}}, map, cfg)) {
    EXPECT_LE(t.cells.size(), 3u);
    for (const ChangeCell& c : t.cells) EXPECT_TRUE(c.added >= 2 || c.passed >= 2) << "one scan's word is not reported";
    for (std::size_t i = 1; i < t.cells.size(); ++i)
      EXPECT_TRUE(std::tie(t.cells[i - 1].x, t.cells[i - 1].y, t.cells[i - 1].z) < std::tie(t.cells[i].x, t.cells[i].y, t.cells[i].z));
  }
  // min_travel_m: a scan every 0.5 m, evidence from one in four; none while standing.
  cfg = {};
  ChangeEvidence ev(cfg, 20.0);
  const Scene world{{kWall}};
  int used = 0;
  for (int k = 0; k < 16; ++k) used += ev.add(sensor_at(0.5 * k, -3), world.scan(Eigen::Vector3d(0.5 * k, -3, 1.7)), map);
  EXPECT_EQ(used, 4);
  for (int k = 0; k < 10; ++k) used += ev.add(sensor_at(7.5, -3), world.scan(Eigen::Vector3d(7.5, -3, 1.7)), map);
  EXPECT_EQ(used, 4);
  cfg = {};
  cfg.voxel_m = 0;
  EXPECT_THROW(ChangeEvidence(cfg, 20.0), pl::Error);
  cfg = {};
  cfg.max_range_m = cfg.min_range_m;
  EXPECT_THROW(ChangeEvidence(cfg, 20.0), pl::Error);
  EXPECT_THROW(ev.add(sensor_at(0, 0), {Eigen::Vector3f(5, 0, 0)}, map, {Eigen::Vector3f::Zero(), Eigen::Vector3f::Zero()}), pl::Error);
}

}  // namespace
