// The world under construction: its frames on the path and the objects placed on it (see site.hpp).
#include "site.hpp"

#include <utility>

namespace pl::sim::worldgen {

void add_box(WorldObject& o, Vec2 c, float base, Vec3 half, float yaw, Material m) {
  o.shapes.push_back(make_box(Vec3(c.x(), c.y(), base + half.z()), half, yaw, 0));
  o.materials.push_back(m);
}

Site::Site(const SimTrajectory& path, double t0, double t1, const WorldConfig& cfg)
    : path(path), t0(t0), t1(t1), cfg(cfg), ground(path, t0, t1), rng(cfg.seed * 0x9E3779B97F4A7C15ull + 17) {}

Frame Site::frame_at(double s) const {
  Pose p = path.pose_at(path.time_at_distance(s));
  Vec2 pos = p.translation().head<2>().cast<float>();
  Eigen::Vector3d f = p.linear().col(0);
  Vec2 fwd = Vec2(static_cast<float>(f.x()), static_cast<float>(f.y())).normalized();
  return {pos, fwd, Vec2(-fwd.y(), fwd.x()), static_cast<float>(p.translation().z() - kLidarHeight)};
}

WorldObject& Site::new_object(ObjectClass cls, Vec2 centre, Vec2 half, float yaw, float height) {
  WorldObject o;
  o.id = next_id++;
  o.cls = cls;
  o.centre = centre;
  o.half = half;
  o.yaw = yaw;
  o.base = ground.height_at(centre.x(), centre.y());
  o.height = height;
  world.objects.push_back(std::move(o));
  return world.objects.back();
}

}  // namespace pl::sim::worldgen
