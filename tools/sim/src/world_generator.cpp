// The procedural world along a trajectory: roads, buildings, vegetation and objects placed on an
// occupancy grid (see world.hpp).
#include <algorithm>
#include <cmath>
#include <random>
#include <unordered_map>

#include "pl/common/error.hpp"
#include "pl/sim/world.hpp"

namespace pl::sim {

// ---------------------------------------------------------------------------------------------
// Generation

namespace {

using Vec2 = Eigen::Vector2f;
using Vec3 = Eigen::Vector3f;

// Occupancy of 0.5 m cells: what the road needs and what objects took.
class Occupancy {
 public:
  enum : std::uint8_t { kFree = 0, kRoad = 1, kLane = 2, kTaken = 3 };
  static constexpr float kCell = 0.5f;

  std::uint8_t at(int cx, int cy) const {
    auto it = cells_.find(key(cx, cy));
    return it == cells_.end() ? static_cast<std::uint8_t>(kFree) : it->second;
  }
  void raise(int cx, int cy, std::uint8_t v) {
    auto& c = cells_[key(cx, cy)];
    c = std::max(c, v);
  }
  void mark_disc(Vec2 c, float r, std::uint8_t v) {
    int x0 = cell(c.x() - r), x1 = cell(c.x() + r), y0 = cell(c.y() - r), y1 = cell(c.y() + r);
    for (int x = x0; x <= x1; ++x)
      for (int y = y0; y <= y1; ++y) {
        Vec2 q((x + 0.5f) * kCell, (y + 0.5f) * kCell);
        if ((q - c).norm() <= r) raise(x, y, v);
      }
  }
  // Cells whose centre lies in the rectangle (grown by `margin`); `fn(x, y)` for each.
  template <typename Fn>
  void for_rect(Vec2 centre, Vec2 half, float yaw, float margin, Fn&& fn) const {
    float c = std::cos(yaw), s = std::sin(yaw);
    float ex = std::abs(c) * (half.x() + margin) + std::abs(s) * (half.y() + margin);
    float ey = std::abs(s) * (half.x() + margin) + std::abs(c) * (half.y() + margin);
    int x0 = cell(centre.x() - ex), x1 = cell(centre.x() + ex), y0 = cell(centre.y() - ey), y1 = cell(centre.y() + ey);
    for (int x = x0; x <= x1; ++x)
      for (int y = y0; y <= y1; ++y) {
        Vec2 q = Vec2((x + 0.5f) * kCell, (y + 0.5f) * kCell) - centre;
        float u = c * q.x() + s * q.y(), v = -s * q.x() + c * q.y();
        if (std::abs(u) <= half.x() + margin && std::abs(v) <= half.y() + margin) fn(x, y);
      }
  }
  // True when no cell of the rectangle is at or above `blocking`.
  bool free(Vec2 centre, Vec2 half, float yaw, std::uint8_t blocking, float margin = 0.3f) const {
    bool ok = true;
    for_rect(centre, half, yaw, margin, [&](int x, int y) { ok = ok && at(x, y) < blocking; });
    return ok;
  }
  void take(Vec2 centre, Vec2 half, float yaw) {
    for_rect(centre, half, yaw, 0.0f, [&](int x, int y) { raise(x, y, kTaken); });
  }
  void release(Vec2 centre, Vec2 half, float yaw) {
    for_rect(centre, half, yaw, 0.0f, [&](int x, int y) {
      auto it = cells_.find(key(x, y));
      if (it != cells_.end() && it->second == kTaken) it->second = kFree;
    });
  }

 private:
  static int cell(float v) { return static_cast<int>(std::floor(v / kCell)); }
  static std::int64_t key(int x, int y) { return grid_key(x, y); }
  std::unordered_map<std::int64_t, std::uint8_t> cells_;
};

// A frame on the path: position on the road surface, forward and left directions.
struct Frame {
  Vec2 pos, fwd, left;
  float z;
};

class Generator {
 public:
  Generator(const SimTrajectory& path, double t0, double t1, const WorldConfig& cfg)
      : path_(path), t0_(t0), t1_(t1), cfg_(cfg), ground_(path, t0, t1), rng_(cfg.seed * 0x9E3779B97F4A7C15ull + 17) {}

  World run() {
    mark_roads();
    add_ground();
    if (cfg_.preset == "estate")
      estate();
    else
      town();
    world_.config = cfg_;
    if (cfg_.epoch >= 1) six_months_later();
    return std::move(world_);
  }

 private:
  // -- helpers -------------------------------------------------------------------------------
  float uniform(float a, float b) { return std::uniform_real_distribution<float>(a, b)(rng_); }
  bool chance(float p) { return uniform(0.f, 1.f) < p; }

  Frame frame_at(double s) const {
    Pose p = path_.pose_at(path_.time_at_distance(s));
    Vec2 pos = p.translation().head<2>().cast<float>();
    Eigen::Vector3d f = p.linear().col(0);
    Vec2 fwd = Vec2(static_cast<float>(f.x()), static_cast<float>(f.y())).normalized();
    return {pos, fwd, Vec2(-fwd.y(), fwd.x()), static_cast<float>(p.translation().z() - kLidarHeight)};
  }
  // A point `along` metres ahead and `lateral` to the left (negative: right) of the frame.
  static Vec2 at(const Frame& f, float along, float lateral) { return f.pos + f.fwd * along + f.left * lateral; }
  static float yaw_of(const Frame& f) { return std::atan2(f.fwd.y(), f.fwd.x()); }

  WorldObject& new_object(ObjectClass cls, Vec2 centre, Vec2 half, float yaw, float height) {
    WorldObject o;
    o.id = next_id_++;
    o.cls = cls;
    o.centre = centre;
    o.half = half;
    o.yaw = yaw;
    o.base = ground_.height_at(centre.x(), centre.y());
    o.height = height;
    world_.objects.push_back(std::move(o));
    return world_.objects.back();
  }
  static void add_box(WorldObject& o, Vec2 c, float base, Vec3 half, float yaw, Material m) {
    o.shapes.push_back(make_box(Vec3(c.x(), c.y(), base + half.z()), half, yaw, 0));
    o.materials.push_back(m);
  }

  void mark_roads() {
    double s0 = path_.distance_at(t0_), s1 = path_.distance_at(t1_);
    for (double s = s0; s <= s1; s += 1.0) {
      Frame f = frame_at(s);
      occ_.mark_disc(f.pos, static_cast<float>(cfg_.road_half_width) + 0.3f, Occupancy::kRoad);
      // The two driving lanes: the ego lane on the path and the oncoming one 3 m to its left
      // (vehicles 1.8-2.5 m wide); parked cars stand from 4.0 m out.
      occ_.mark_disc(f.pos, 3.95f, Occupancy::kLane);
    }
  }

  void add_ground() {
    // Two triangles per cell within the band; the material follows the distance to the path.
    float cell = static_cast<float>(cfg_.ground_cell), band = static_cast<float>(cfg_.ground_band);
    std::unordered_map<std::int64_t, bool> cells;
    std::vector<std::pair<int, int>> order;
    double s0 = path_.distance_at(t0_), s1 = path_.distance_at(t1_);
    int reach = static_cast<int>(std::ceil(band / cell));
    for (double s = s0; s <= s1; s += cell) {
      Frame f = frame_at(s);
      int cx = static_cast<int>(std::floor(f.pos.x() / cell)), cy = static_cast<int>(std::floor(f.pos.y() / cell));
      for (int dx = -reach; dx <= reach; ++dx)
        for (int dy = -reach; dy <= reach; ++dy) {
          if ((dx * dx + dy * dy) * cell * cell > band * band) continue;
          std::int64_t k = grid_key(cx + dx, cy + dy);
          if (cells.emplace(k, true).second) order.emplace_back(cx + dx, cy + dy);
        }
    }
    std::unordered_map<std::int64_t, float> heights;
    auto h = [&](int x, int y) {
      std::int64_t k = grid_key(x, y);
      auto it = heights.find(k);
      if (it != heights.end()) return it->second;
      float v = ground_.height_at(x * cell, y * cell);
      heights.emplace(k, v);
      return v;
    };
    new_object(ObjectClass::Ground, frame_at(s0).pos, Vec2(band, band), 0.f, 0.f);
    std::size_t gi = world_.objects.size() - 1;
    float road = static_cast<float>(cfg_.road_half_width);
    for (auto [x, y] : order) {
      Vec3 a(x * cell, y * cell, h(x, y)), b((x + 1) * cell, y * cell, h(x + 1, y));
      Vec3 c((x + 1) * cell, (y + 1) * cell, h(x + 1, y + 1)), d(x * cell, (y + 1) * cell, h(x, y + 1));
      float dist = ground_.distance_to_path((x + 0.5f) * cell, (y + 0.5f) * cell, 20.f);
      Material m = dist < road ? Material::Asphalt : dist < road + 3.5f ? Material::Pavement : Material::Grass;
      WorldObject& go = world_.objects[gi];
      go.shapes.push_back(make_triangle(a, b, c, 0));
      go.shapes.push_back(make_triangle(a, c, d, 0));
      go.materials.push_back(m);
      go.materials.push_back(m);
    }
  }

  // Walks both sides of the path, calling place(frame, side, s) where `side` is +1 (left) or -1.
  template <typename Place>
  void walk(double step_min, double step_max, Place&& place) {
    double s0 = path_.distance_at(t0_), s1 = path_.distance_at(t1_);
    for (int side : {1, -1}) {
      for (double s = s0 + uniform(0.f, static_cast<float>(step_max)); s <= s1;) {
        double used = place(frame_at(s), static_cast<float>(side), s);
        s += std::max(used, 0.0) + uniform(static_cast<float>(step_min), static_cast<float>(step_max));
      }
    }
  }

  // -- things --------------------------------------------------------------------------------
  void curbs() {
    float off = static_cast<float>(cfg_.road_half_width);
    walk(0.0, 0.0, [&](const Frame& f, float side, double) {
      Vec2 c = at(f, 1.0f, side * off);
      Vec2 half(1.05f, 0.15f);
      if (!occ_.free(c, half, yaw_of(f), Occupancy::kLane, 0.0f)) return 2.0;
      WorldObject& o = new_object(ObjectClass::Curb, c, half, yaw_of(f), 0.15f);
      add_box(o, c, o.base, Vec3(half.x(), half.y(), 0.075f), o.yaw, Material::Concrete);
      return 2.0;
    });
  }

  bool parked_vehicle(const Frame& f, float side, float along, bool truck) {
    float road = static_cast<float>(cfg_.road_half_width);
    Vec2 half = truck ? Vec2(5.0f, 1.25f) : Vec2(uniform(2.1f, 2.45f), uniform(0.86f, 0.95f));
    // Cars stand in the parking lane; trucks, 2.5 m wide, half up on the pavement.
    Vec2 c = at(f, along + half.x(), side * (truck ? road - half.y() + 1.0f : road - half.y() - 0.2f));
    float yaw = yaw_of(f) + (chance(0.5f) ? 0.0f : static_cast<float>(M_PI));
    if (!occ_.free(c, half, yaw, Occupancy::kLane, 0.0f)) return false;
    occ_.take(c, half, yaw);
    ObjectClass cls = truck ? ObjectClass::ParkedTruck : ObjectClass::ParkedCar;
    WorldObject& o = new_object(cls, c, half, yaw, truck ? 3.8f : 1.5f);
    vehicle_shapes(o, truck);
    return true;
  }

  void vehicle_shapes(WorldObject& o, bool truck) {
    Vec2 fwd(std::cos(o.yaw), std::sin(o.yaw));
    if (truck) {
      // Cab at the front, box body behind.
      add_box(o, o.centre + fwd * 3.9f, o.base + 0.4f, Vec3(1.1f, 1.2f, 1.35f), o.yaw, Material::Metal);
      add_box(o, o.centre - fwd * 1.0f, o.base + 0.9f, Vec3(3.9f, 1.25f, 1.45f), o.yaw, Material::Metal);
    } else {
      add_box(o, o.centre, o.base + 0.25f, Vec3(o.half.x(), o.half.y(), 0.38f), o.yaw, Material::Metal);
      add_box(o, o.centre - fwd * 0.25f, o.base + 1.01f, Vec3(o.half.x() * 0.55f, o.half.y() * 0.9f, 0.24f), o.yaw, Material::Glass);
    }
  }

  void container(Vec2 c, float yaw, float base_lift, bool forty) {
    Vec2 half = forty ? Vec2(6.1f, 1.22f) : Vec2(3.03f, 1.22f);
    WorldObject& o = new_object(ObjectClass::Container, c, half, yaw, 2.6f + base_lift);
    add_box(o, c, o.base + base_lift, Vec3(half.x(), half.y(), 1.3f), yaw, Material::Metal);
  }

  void tree(Vec2 c, float scale) {
    float trunk = uniform(2.0f, 3.2f) * scale, canopy = uniform(1.8f, 3.2f) * scale;
    WorldObject& o = new_object(ObjectClass::Tree, c, Vec2(canopy, canopy), 0.f, trunk + 2 * canopy);
    o.shapes.push_back(make_cylinder(Vec3(c.x(), c.y(), o.base), uniform(0.12f, 0.28f), trunk + canopy * 0.5f, 0));
    o.materials.push_back(Material::Vegetation);
    // An irregular canopy: a main ellipsoid and a few lobes.
    int lobes = 2 + static_cast<int>(uniform(0.f, 2.99f));
    o.shapes.push_back(make_ellipsoid(Vec3(c.x(), c.y(), o.base + trunk + canopy), Vec3(canopy, canopy * uniform(0.8f, 1.0f), canopy * 0.85f),
                                      uniform(0.f, 3.14f), 0));
    o.materials.push_back(Material::Vegetation);
    for (int k = 0; k < lobes; ++k) {
      float a = uniform(0.f, 6.28f), r = canopy * uniform(0.4f, 0.7f);
      Vec3 lc(c.x() + std::cos(a) * r, c.y() + std::sin(a) * r, o.base + trunk + canopy * uniform(0.7f, 1.3f));
      o.shapes.push_back(make_ellipsoid(lc, Vec3::Constant(canopy * uniform(0.45f, 0.65f)), 0.f, 0));
      o.materials.push_back(Material::Vegetation);
    }
  }

  void pole(Vec2 c, bool with_sign, float yaw) {
    float h = with_sign ? 2.6f : uniform(5.0f, 8.0f);
    ObjectClass cls = with_sign ? ObjectClass::Sign : ObjectClass::Pole;
    WorldObject& o = new_object(cls, c, Vec2(0.3f, 0.3f), yaw, h + (with_sign ? 0.7f : 0.f));
    o.shapes.push_back(make_cylinder(Vec3(c.x(), c.y(), o.base), with_sign ? 0.04f : uniform(0.07f, 0.14f), h, 0));
    o.materials.push_back(Material::Metal);
    if (with_sign) {
      add_box(o, c, o.base + h, Vec3(0.03f, 0.32f, 0.32f), yaw, Material::Retroreflector);
    } else if (chance(0.6f)) {  // a lamp arm reaching over the pavement
      Vec2 arm(std::cos(yaw) * 0.8f, std::sin(yaw) * 0.8f);
      add_box(o, c + arm, o.base + h - 0.1f, Vec3(0.8f, 0.06f, 0.06f), yaw, Material::Metal);
    }
  }

  // A building whose street facade faces the path: recesses, bays and windows.
  double building(const Frame& f, float side, bool warehouse) {
    float road = static_cast<float>(cfg_.road_half_width);
    float len = warehouse ? uniform(30.f, 70.f) : uniform(9.f, 28.f);
    float depth = warehouse ? uniform(20.f, 40.f) : uniform(10.f, 18.f);
    float height = warehouse ? uniform(8.f, 14.f) : uniform(7.f, 21.f);
    float setback = warehouse ? uniform(12.f, 30.f) : uniform(3.f, 9.f);
    Vec2 c = at(f, len * 0.5f, side * (road + setback + depth * 0.5f));
    float yaw = yaw_of(f);
    Vec2 half(len * 0.5f, depth * 0.5f);
    if (!occ_.free(c, half, yaw, Occupancy::kRoad, 0.5f)) {
      // Curves and junctions: try a shorter building before giving up.
      half.x() *= 0.5f;
      c = at(f, half.x(), side * (road + setback + depth * 0.5f));
      if (!occ_.free(c, half, yaw, Occupancy::kRoad, 0.5f)) return 3.0;
      len = half.x() * 2;
    }
    occ_.take(c, half, yaw);
    WorldObject& o = new_object(ObjectClass::Building, c, half, yaw, height);
    Material wall = warehouse ? Material::Metal : (chance(0.5f) ? Material::Brick : Material::Concrete);
    add_box(o, c, o.base, Vec3(half.x(), half.y(), height * 0.5f), yaw, wall);
    float facade = road + setback;  // lateral offset of the facade from the path
    // Bays standing out of the facade and recessed entrances (a box set back hides nothing, so a
    // recess is a gap between two bays).
    int bays = warehouse ? 0 : static_cast<int>(uniform(0.f, 2.99f));
    for (int k = 0; k < bays; ++k) {
      float bl = uniform(2.f, std::max(2.5f, len * 0.35f)), bz0 = uniform(0.f, 3.f);
      float along = uniform(bl * 0.5f, std::max(bl * 0.5f + 0.1f, len - bl * 0.5f));
      float proud = uniform(0.4f, 1.2f);
      Vec2 bc = at(f, along, side * (facade - proud * 0.5f));
      add_box(o, bc, o.base + bz0, Vec3(bl * 0.5f, proud * 0.5f, (height - bz0) * 0.5f * uniform(0.6f, 1.0f)), yaw, wall);
    }
    // Windows: glass panes 3 cm proud of the facade on a grid (loading doors on warehouses).
    float wx = warehouse ? 6.0f : 2.6f, wz = warehouse ? 100.f : 3.1f;
    for (float a = 1.5f; a < len - 1.0f; a += wx) {
      for (float z = warehouse ? 0.0f : 1.2f; z + 1.5f < height; z += wz) {
        if (chance(0.15f)) continue;
        Vec2 wc = at(f, a + 0.6f, side * (facade - 0.015f));
        Vec3 whalf = warehouse ? Vec3(2.0f, 0.02f, 2.2f) : Vec3(0.6f, 0.02f, 0.75f);
        o.shapes.push_back(make_box(Vec3(wc.x(), wc.y(), o.base + z + whalf.z()), whalf, yaw, 0));
        o.materials.push_back(warehouse ? Material::Metal : Material::Glass);
      }
    }
    return len;
  }

  // Between buildings: a wall or a fence along the pavement's back edge.
  double boundary(const Frame& f, float side, float length, bool fence_only) {
    float road = static_cast<float>(cfg_.road_half_width);
    Vec2 c = at(f, length * 0.5f, side * (road + 3.2f));
    float yaw = yaw_of(f);
    Vec2 half(length * 0.5f, 0.15f);
    if (!occ_.free(c, half, yaw, Occupancy::kRoad, 0.2f)) return 2.0;
    occ_.take(c, half, yaw);
    bool fence = fence_only || chance(0.5f);
    WorldObject& o = new_object(fence ? ObjectClass::Fence : ObjectClass::Wall, c, half, yaw, fence ? 1.8f : 2.0f);
    if (!fence) {
      add_box(o, c, o.base, Vec3(half.x(), 0.15f, uniform(0.8f, 1.2f)), yaw, Material::Concrete);
      return length;
    }
    // Posts every 2.5 m and two rails: a sparse, see-through structure.
    Vec2 fwd(std::cos(yaw), std::sin(yaw));
    for (float a = -half.x(); a <= half.x() + 1e-3f; a += 2.5f) {
      Vec2 pc = c + fwd * a;
      o.shapes.push_back(make_cylinder(Vec3(pc.x(), pc.y(), o.base), 0.05f, 1.8f, 0));
      o.materials.push_back(Material::Metal);
    }
    for (float z : {0.5f, 1.6f}) {
      add_box(o, c, o.base + z, Vec3(half.x(), 0.03f, 0.05f), yaw, Material::Metal);
    }
    return length;
  }

  void street_furniture(float tree_share) {
    float road = static_cast<float>(cfg_.road_half_width);
    // Poles and signs at the pavement's kerb side.
    walk(18.0, 40.0, [&](const Frame& f, float side, double) {
      Vec2 c = at(f, 0.f, side * (road + 0.9f));
      if (!occ_.free(c, Vec2(0.3f, 0.3f), 0.f, Occupancy::kRoad, 0.0f)) return 0.0;
      occ_.take(c, Vec2(0.3f, 0.3f), 0.f);
      pole(c, chance(0.3f), yaw_of(f) + (side > 0 ? -1.5708f : 1.5708f));
      return 0.0;
    });
    // Trees in avenue stretches.
    walk(7.0, 13.0, [&](const Frame& f, float side, double) {
      if (!chance(tree_share)) return 10.0;
      Vec2 c = at(f, 0.f, side * (road + uniform(1.6f, 2.6f)));
      if (!occ_.free(c, Vec2(0.5f, 0.5f), 0.f, Occupancy::kRoad, 0.0f)) return 0.0;
      occ_.take(c, Vec2(0.5f, 0.5f), 0.f);
      tree(c, 1.0f);
      return 0.0;
    });
  }

  void town() {
    curbs();
    // Parking lane: runs of parked cars with driveways between them.
    walk(1.0, 6.0, [&](const Frame& f, float side, double) {
      if (chance(0.25f)) return 8.0;  // a driveway or no-parking stretch
      return parked_vehicle(f, side, 0.f, chance(0.04f)) ? 4.8 : 1.0;
    });
    street_furniture(0.45f);
    // Buildings with gaps; walls, fences and the odd container in the gaps.
    walk(0.0, 6.0, [&](const Frame& f, float side, double) {
      float r = uniform(0.f, 1.f);
      if (r < 0.72f) return building(f, side, false);
      if (r < 0.92f) return boundary(f, side, uniform(6.f, 20.f), false);
      float road = static_cast<float>(cfg_.road_half_width);
      Vec2 c = at(f, 4.f, side * (road + uniform(4.f, 8.f)));
      Vec2 half(3.1f, 1.3f);
      if (occ_.free(c, half, yaw_of(f), Occupancy::kRoad)) {
        occ_.take(c, half, yaw_of(f));
        container(c, yaw_of(f), 0.f, false);
      }
      return 8.0;
    });
    gardens();
    if (cfg_.backdrop) second_row();
  }

  // The next street's houses behind the back gardens, seen over and between the first row: a real
  // town goes on behind its street. Without them a simulated scan had half the real share of returns
  // at 30-80 m and above the sensor, and two thirds of the real drive's points after preparation
  // (docs/benchmarks.md, the simulator against the street). Placed last, so the worlds before them
  // are unchanged object for object.
  void second_row() {
    const float road = static_cast<float>(cfg_.road_half_width);
    walk(1.0, 4.0, [&](const Frame& f, float side, double) {
      const float len = uniform(25.f, 60.f), depth = uniform(9.f, 15.f), height = uniform(8.f, 22.f);
      const Vec2 c = at(f, len * 0.5f, side * (road + uniform(30.f, 45.f) + depth * 0.5f));
      const float yaw = yaw_of(f);
      const Vec2 half(len * 0.5f, depth * 0.5f);
      if (!occ_.free(c, half, yaw, Occupancy::kRoad, 0.5f)) return 4.0;
      occ_.take(c, half, yaw);
      WorldObject& o = new_object(ObjectClass::Building, c, half, yaw, height);
      add_box(o, c, o.base, Vec3(half.x(), half.y(), height * 0.5f), yaw, chance(0.5f) ? Material::Brick : Material::Concrete);
      return static_cast<double>(len);
    });
  }

  // Front gardens and back gardens, as residential streets have (drive 0005's is one): hedges and
  // bushes behind the pavement where the buildings leave room, trees behind the first row. The
  // first simulator's streets were bare planes; this clutter is what a real scan's voxels and
  // conditioning come from (docs/pl-sim.md, the table against the real drive).
  void gardens() {
    const float road = static_cast<float>(cfg_.road_half_width);
    walk(0.5, 3.0, [&](const Frame& f, float side, double) {
      const float yaw = yaw_of(f);
      if (chance(0.55f)) {  // a hedge along the pavement's back edge
        const float length = uniform(3.f, 9.f), depth = uniform(0.3f, 0.5f), height = uniform(0.8f, 1.7f);
        const Vec2 c = at(f, length * 0.5f, side * (road + 3.4f + depth));
        const Vec2 half(length * 0.5f, depth);
        if (!occ_.free(c, half, yaw, Occupancy::kRoad, 0.1f)) return 1.0;
        occ_.take(c, half, yaw);
        WorldObject& o = new_object(ObjectClass::Tree, c, half, yaw, height);
        add_box(o, c, o.base, Vec3(half.x(), half.y(), height * 0.5f), yaw, Material::Vegetation);
        return static_cast<double>(length);
      }
      // A bush or two in the garden.
      const Vec2 c = at(f, 1.0f, side * (road + uniform(3.6f, 6.0f)));
      const float r = uniform(0.5f, 1.2f);
      if (!occ_.free(c, Vec2(r, r), 0.f, Occupancy::kRoad, 0.1f)) return 1.0;
      occ_.take(c, Vec2(r, r), 0.f);
      WorldObject& o = new_object(ObjectClass::Tree, c, Vec2(r, r), 0.f, 1.6f * r);
      o.shapes.push_back(make_ellipsoid(Vec3(c.x(), c.y(), o.base + 0.75f * r), Vec3(r, r * uniform(0.7f, 1.0f), 0.8f * r),
                                        uniform(0.f, 3.14f), 0));
      o.materials.push_back(Material::Vegetation);
      return 2.0 * r;
    });
    walk(4.0, 12.0, [&](const Frame& f, float side, double) {  // back gardens: trees behind the first row
      const Vec2 c = at(f, 0.f, side * (road + uniform(14.f, 30.f)));
      if (!occ_.free(c, Vec2(0.4f, 0.4f), 0.f, Occupancy::kRoad, 0.2f)) return 2.0;
      occ_.take(c, Vec2(0.4f, 0.4f), 0.f);
      tree(c, uniform(1.0f, 1.5f));
      return 4.0;
    });
  }

  void estate() {
    curbs();
    double s0 = path_.distance_at(t0_), s1 = path_.distance_at(t1_);
    double square_from = s0 + 0.55 * (s1 - s0), square_to = s0 + 0.72 * (s1 - s0);  // the open square
    auto in_square = [&](double s, float side) { return side > 0 && s > square_from && s < square_to; };
    // Trucks and cars parked in front of the loading bays.
    walk(2.0, 14.0, [&](const Frame& f, float side, double s) {
      if (in_square(s, side) || chance(0.35f)) return 10.0;
      bool truck = chance(0.45f);
      return parked_vehicle(f, side, 0.f, truck) ? (truck ? 10.0 : 4.8) : 1.0;
    });
    walk(30.0, 60.0, [&](const Frame& f, float side, double s) {
      if (in_square(s, side)) return 0.0;
      float road = static_cast<float>(cfg_.road_half_width);
      Vec2 c = at(f, 0.f, side * (road + 0.9f));
      if (!occ_.free(c, Vec2(0.3f, 0.3f), 0.f, Occupancy::kRoad, 0.0f)) return 0.0;
      occ_.take(c, Vec2(0.3f, 0.3f), 0.f);
      pole(c, chance(0.2f), yaw_of(f));
      return 0.0;
    });
    // Warehouses, fenced yards with stacked containers; the square stays open.
    walk(4.0, 15.0, [&](const Frame& f, float side, double s) {
      if (in_square(s, side)) return 20.0;
      if (chance(0.65f)) return building(f, side, true);
      float len = uniform(20.f, 45.f);
      double used = boundary(f, side, len, true);
      float road = static_cast<float>(cfg_.road_half_width);
      for (float a = 4.f; a + 6.f < len; a += uniform(6.5f, 9.f)) {
        Vec2 c = at(f, a, side * (road + uniform(7.f, 10.f)));
        float yaw = yaw_of(f) + (chance(0.3f) ? 1.5708f : 0.f);
        Vec2 half(3.1f, 1.3f);
        if (!occ_.free(c, half, yaw, Occupancy::kRoad)) continue;
        occ_.take(c, half, yaw);
        container(c, yaw, 0.f, false);
        if (chance(0.4f)) container(c, yaw, 2.6f, false);
      }
      return used;
    });
    // A few trees at the square's edge.
    walk(20.0, 40.0, [&](const Frame& f, float side, double) {
      float road = static_cast<float>(cfg_.road_half_width);
      Vec2 c = at(f, 0.f, side * (road + 2.0f));
      if (!chance(0.3f) || !occ_.free(c, Vec2(0.5f, 0.5f), 0.f, Occupancy::kRoad, 0.0f)) return 0.0;
      occ_.take(c, Vec2(0.5f, 0.5f), 0.f);
      tree(c, 1.1f);
      return 0.0;
    });
  }

  // -- epochs --------------------------------------------------------------------------------
  // Epoch 1: a share of the movable things moved, removed or grown, and new ones added, so that
  // (changed + added) / movable = change_share. Static structure is untouched.
  void six_months_later() {
    std::mt19937_64 rng(cfg_.seed * 0xD1B54A32D192ED03ull + 0xE1);
    auto u = [&rng](float a, float b) { return std::uniform_real_distribution<float>(a, b)(rng); };
    std::vector<std::size_t> movable;
    for (std::size_t i = 0; i < world_.objects.size(); ++i)
      if (is_movable(world_.objects[i].cls)) movable.push_back(i);
    std::size_t total = static_cast<std::size_t>(std::lround(cfg_.change_share * static_cast<double>(movable.size())));
    std::size_t to_add = total / 5, to_change = total - to_add;
    std::shuffle(movable.begin(), movable.end(), rng);
    std::vector<bool> remove(world_.objects.size(), false);
    for (std::size_t k = 0; k < std::min(to_change, movable.size()); ++k) {
      WorldObject& o = world_.objects[movable[k]];
      if (o.cls == ObjectClass::Tree) {  // vegetation grows
        float g = u(1.2f, 1.4f);
        if (o.shapes.size() == 1) {  // a hedge or a bush: all of it, standing where it stood
          Primitive& p = o.shapes[0];
          p.b *= g;
          p.a.z() = o.base + (p.a.z() - o.base) * g;
          o.half *= g;
          continue;
        }
        for (std::size_t j = 1; j < o.shapes.size(); ++j) {  // a tree: the canopy, not the trunk
          Primitive& p = o.shapes[j];
          p.b *= g;
          p.a.z() = o.base + (p.a.z() - o.base) * (1.0f + (g - 1.0f) * 0.5f);
        }
        o.half *= g;
        continue;
      }
      bool moved = false;
      if ((o.cls == ObjectClass::ParkedCar || o.cls == ObjectClass::ParkedTruck || o.cls == ObjectClass::Container) && u(0.f, 1.f) < 0.5f) {
        // Move along its own axis by 2-6 m, if the new place is free.
        Vec2 fwd(std::cos(o.yaw), std::sin(o.yaw));
        Vec2 shift = fwd * (u(0.f, 1.f) < 0.5f ? -1.f : 1.f) * u(2.f, 6.f);
        occ_.release(o.centre, o.half, o.yaw);
        std::uint8_t blocking = o.cls == ObjectClass::Container ? Occupancy::kRoad : Occupancy::kLane;
        if (occ_.free(o.centre + shift, o.half, o.yaw, blocking, 0.0f)) {
          occ_.take(o.centre + shift, o.half, o.yaw);
          o.centre += shift;
          for (auto& p : o.shapes) p.a.head<2>() += shift;
          moved = true;
        }
      }
      if (!moved) {
        occ_.release(o.centre, o.half, o.yaw);
        remove[movable[k]] = true;
      }
    }
    std::vector<WorldObject> kept;
    for (std::size_t i = 0; i < world_.objects.size(); ++i)
      if (!remove[i]) kept.push_back(std::move(world_.objects[i]));
    world_.objects = std::move(kept);
    // Additions: parked cars, containers, a fence and a small new building in free places.
    rng_.seed(cfg_.seed * 0x94D049BB133111EBull + 0xE2);
    std::size_t added = 0;
    double s0 = path_.distance_at(t0_), s1 = path_.distance_at(t1_);
    float road = static_cast<float>(cfg_.road_half_width);
    for (int attempt = 0; added < to_add && attempt < 2000; ++attempt) {
      double s = s0 + uniform(0.f, 1.f) * (s1 - s0);
      Frame f = frame_at(s);
      float side = chance(0.5f) ? 1.f : -1.f;
      int kind = added == 0 ? 3 : (added == 1 ? 2 : static_cast<int>(uniform(0.f, 1.99f)));
      if (kind == 0) {
        added += parked_vehicle(f, side, 0.f, false);
      } else if (kind == 1) {
        Vec2 c = at(f, 0.f, side * (road + uniform(4.f, 8.f)));
        Vec2 half(3.1f, 1.3f);
        if (!occ_.free(c, half, yaw_of(f), Occupancy::kRoad)) continue;
        occ_.take(c, half, yaw_of(f));
        container(c, yaw_of(f), 0.f, false);
        ++added;
      } else if (kind == 2) {
        double before = world_.objects.size();
        boundary(f, side, uniform(8.f, 16.f), true);
        added += world_.objects.size() > before;
      } else {
        Vec2 half(uniform(2.f, 3.f), uniform(1.5f, 2.5f));
        Vec2 c = at(f, 0.f, side * (road + 4.f + half.y()));
        if (!occ_.free(c, half, yaw_of(f), Occupancy::kRoad, 0.5f)) continue;
        occ_.take(c, half, yaw_of(f));
        WorldObject& o = new_object(ObjectClass::SmallBuilding, c, half, yaw_of(f), 3.0f);
        add_box(o, c, o.base, Vec3(half.x(), half.y(), 1.5f), o.yaw, Material::Concrete);
        ++added;
      }
    }
  }

  const SimTrajectory& path_;
  double t0_, t1_;
  WorldConfig cfg_;
  GroundModel ground_;
  std::mt19937_64 rng_;
  Occupancy occ_;
  World world_;
  std::uint32_t next_id_ = 0;
};

}  // namespace

World build_world(const SimTrajectory& path, double t0, double t1, const WorldConfig& cfg) {
  if (cfg.preset != "town" && cfg.preset != "estate") throw Error("unknown world preset \"" + cfg.preset + "\" (town or estate)");
  if (cfg.epoch < 0 || cfg.epoch > 1) throw Error("--epoch takes 0 or 1");
  if (!(cfg.change_share >= 0.0 && cfg.change_share <= 1.0)) throw Error("the change share must be between 0 and 1");
  return Generator(path, t0, t1, cfg).run();
}

}  // namespace pl::sim
