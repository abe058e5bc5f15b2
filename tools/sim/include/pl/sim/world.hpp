// The procedural world the simulator scans: deterministic from a seed, built along the trajectory.
// Static structure (ground, curbs, buildings, walls, poles, signs) never changes between epochs;
// movable things (parked cars and trucks, containers, vegetation, fences, small buildings) change by
// a set share from epoch 0 to epoch 1 ("six months later").
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "pl/sim/raycast.hpp"
#include "pl/sim/trajectory.hpp"

namespace pl::sim {

enum class ObjectClass : std::uint8_t {
  Ground, Curb, Building, Wall, Fence, ParkedCar, ParkedTruck, Pole, Sign, Tree, Container, SmallBuilding,
};
const char* class_name(ObjectClass c);
bool is_movable(ObjectClass c);

enum class Material : std::uint8_t { Asphalt, Pavement, Grass, Concrete, Brick, Metal, Glass, Vegetation, Retroreflector };
// Diffuse reflectance used for the intensity channel.
float albedo(Material m);

struct WorldObject {
  std::uint32_t id = 0;         // stable across epochs: the same thing has the same id
  ObjectClass cls = ObjectClass::Building;
  Eigen::Vector2f centre = Eigen::Vector2f::Zero();  // footprint centre (x, y)
  Eigen::Vector2f half = Eigen::Vector2f::Zero();    // footprint half extents along its yaw
  float yaw = 0.0f;
  float base = 0.0f;    // ground height under it
  float height = 0.0f;  // top above the base
  std::vector<Primitive> shapes;    // in world coordinates
  std::vector<Material> materials;  // one per shape
};

struct WorldConfig {
  std::uint64_t seed = 1;
  std::string preset = "town";  // town | estate
  int epoch = 0;                // 0, or 1 = six months later
  double change_share = 0.15;   // share of movable things changed in epoch 1
  double road_half_width = 6.0;
  double ground_band = 80.0;    // ground modelled within this distance of the path
  double ground_cell = 4.0;
  // The town: the next street's houses behind the back gardens (the town goes on behind the street:
  // a real scan's returns at 30-80 m). Off: the street alone, as the first simulator's world was.
  bool backdrop = true;
};

// What a shape of the scene belongs to: `Primitive::object` indexes a table of these.
struct ShapeInfo {
  std::uint32_t object;  // index into World::objects
  Material material;
};

struct World {
  std::vector<WorldObject> objects;
  WorldConfig config;

  // Every shape of the world, each with `object` = its index in `info`, for a Bvh.
  std::vector<Primitive> shapes(std::vector<ShapeInfo>& info) const;
};

// Builds the world along the part of the trajectory from t0 to t1.
World build_world(const SimTrajectory& path, double t0, double t1, const WorldConfig& cfg);

// A thing's footprint on the ground: a rectangle turned by yaw.
struct Footprint {
  Eigen::Vector2f centre = Eigen::Vector2f::Zero();
  Eigen::Vector2f half = Eigen::Vector2f::Zero();
  float yaw = 0.0f;
};

// One thing that differs between two epochs of a world (matched by id): the ground truth of a map
// update.
struct ObjectChange {
  enum class Kind : std::uint8_t { Moved, Removed, Added, Grown };
  Kind kind = Kind::Moved;
  std::uint32_t id = 0;
  ObjectClass cls = ObjectClass::Building;
  bool has_before = false, has_after = false;
  Footprint before, after;  // where it stood, and where it stands (each when it exists)
};
const char* change_name(ObjectChange::Kind k);

// What changed from `before` to `after`, in id order: things gone, new, moved (footprint centre) or
// grown (footprint extents or any shape's size).
std::vector<ObjectChange> changes_between(const World& before, const World& after);

// CSV texts (a header line, then a row per thing; metres and radians in the world frame):
//   objects.csv: id,class,x,y,half_x,half_y,yaw,base,height,returns,returns_40m
//                (the drive's points on it, and those within 40 m of the sensor)
//   changes.csv: id,class,change,x0,y0,half_x0,half_y0,yaw0,x1,y1,half_x1,half_y1,yaw1,rays_seeing
//                (the before columns empty for an added thing, the after ones for a removed thing;
//                rays_seeing: the drive's rays that see the change, see simulate.hpp)
std::string objects_csv(const World& world, const std::vector<std::uint64_t>& returns, const std::vector<std::uint64_t>& near);
std::string changes_csv(const std::vector<ObjectChange>& changes, const std::vector<std::uint64_t>& rays_seeing);

// Key of a 2-D grid cell, for hash maps over cells.
inline std::int64_t grid_key(int x, int y) {
  return static_cast<std::int64_t>(static_cast<std::uint64_t>(static_cast<std::uint32_t>(x)) << 32 | static_cast<std::uint32_t>(y));
}

// Ground height (road surface) at (x, y): from the path's height near that point.
class GroundModel {
 public:
  GroundModel(const SimTrajectory& path, double t0, double t1);
  float height_at(float x, float y) const;
  // Distance in the xy plane to the nearest sampled path point (metres), capped at `cap`.
  float distance_to_path(float x, float y, float cap) const;
  const std::vector<Eigen::Vector3f>& samples() const { return samples_; }  // road surface along the path

 private:
  template <typename Fn>
  void for_samples_near(float x, float y, int reach, Fn&& fn) const;  // fn(sample, squared xy distance)
  std::vector<Eigen::Vector3f> samples_;
  float cell_ = 10.0f;
  std::vector<std::pair<std::int64_t, std::uint32_t>> index_;  // sorted (cell key, sample)
  static std::int64_t key(int cx, int cy) { return grid_key(cx, cy); }
};

}  // namespace pl::sim
