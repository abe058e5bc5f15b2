#include "pl/sim/traffic.hpp"

#include <cmath>
#include <random>

namespace pl::sim {

Traffic::Traffic(const SimTrajectory& path, double t0, double t1, const TrafficConfig& cfg)
    : path_(path), t0_(t0), s_min_(path.distance_at(t0)), s_max_(path.distance_at(t1)) {
  std::mt19937_64 rng(cfg.seed * 0xBF58476D1CE4E5B9ull + 0x7AFF1C);
  auto u = [&rng](double a, double b) { return std::uniform_real_distribution<double>(a, b)(rng); };
  int leads = 0;
  for (int i = 0; i < cfg.count; ++i) {
    Agent a{};
    a.phase = u(0, 2 * M_PI);
    if (u(0, 1) < cfg.pedestrian_share) {
      a.kind = Kind::Pedestrian;
      a.mode = Mode::Walk;
      a.lateral = (u(0, 1) < 0.5 ? 1 : -1) * (cfg.road_half_width + u(1.0, 2.8));
      a.s0 = u(s_min_, s_max_);
      a.speed = (u(0, 1) < 0.5 ? 1 : -1) * u(1.0, 1.7);
    } else {
      a.kind = u(0, 1) < cfg.truck_share ? Kind::Truck : Kind::Car;
      // One vehicle in four (at most three in all) drives in the ego lane close ahead or behind.
      if (leads < 3 && u(0, 1) < 0.25) {
        ++leads;
        a.mode = Mode::Lead;
        a.lateral = 0.0;
        // Gap between centres: a truck's rear ends up 3-10 m ahead of the LiDAR at the closest.
        a.s0 = (u(0, 1) < 0.7 ? 1 : -1) * (a.kind == Kind::Truck ? u(13.0, 20.0) : u(8.0, 15.0));
      } else {
        a.mode = Mode::Oncoming;
        a.lateral = 3.0;
        a.s0 = u(s_min_, s_max_);
        a.speed = -u(6.0, 12.0);
      }
    }
    agents_.push_back(a);
  }
}

bool Traffic::place(const Agent& a, double t, Eigen::Vector2f& centre, float& yaw, float& base) const {
  double span = s_max_ - s_min_;
  if (span <= 1.0) return false;
  double s = 0.0;
  bool reverse = false;
  if (a.mode == Mode::Lead) {
    double gap = a.s0 * (1.0 + 0.3 * std::sin(0.15 * (t - t0_) + a.phase));
    s = path_.distance_at(t) + gap;
    if (s < s_min_ || s > s_max_) return false;
  } else {
    s = s_min_ + std::fmod(std::fmod(a.s0 - s_min_ + a.speed * (t - t0_), span) + span, span);
    reverse = a.speed < 0;
  }
  Pose p = path_.pose_at(path_.time_at_distance(s));
  Eigen::Vector3d fwd = p.linear().col(0);
  Eigen::Vector2d f2 = Eigen::Vector2d(fwd.x(), fwd.y()).normalized(), left(-f2.y(), f2.x());
  Eigen::Vector2d c = p.translation().head<2>() + left * a.lateral;
  centre = c.cast<float>();
  yaw = static_cast<float>(std::atan2(f2.y(), f2.x()) + (reverse ? M_PI : 0.0));
  base = static_cast<float>(p.translation().z() - kLidarHeight);
  return true;
}

Scene Traffic::scene_at(double t, const Eigen::Vector3d& near, double radius) const {
  Scene scene;
  std::vector<Primitive> prims;
  for (const Agent& a : agents_) {
    Eigen::Vector2f c;
    float yaw = 0, base = 0;
    if (!place(a, t, c, yaw, base)) continue;
    if ((c.cast<double>() - near.head<2>()).norm() > radius + 12.0) continue;
    Eigen::Vector2f fwd(std::cos(yaw), std::sin(yaw));
    auto box = [&](Eigen::Vector2f bc, float z0, Eigen::Vector3f half, Material m) {
      prims.push_back(make_box(Eigen::Vector3f(bc.x(), bc.y(), base + z0 + half.z()), half, yaw,
                               static_cast<std::uint32_t>(scene.info.size())));
      scene.info.push_back({0, m});
    };
    switch (a.kind) {
      case Kind::Car:
        box(c, 0.25f, {2.2f, 0.9f, 0.38f}, Material::Metal);
        box(c - fwd * 0.25f, 1.01f, {1.2f, 0.8f, 0.24f}, Material::Glass);
        break;
      case Kind::Truck:  // 2.5 m x 10 m: cab and box body
        box(c + fwd * 3.9f, 0.4f, {1.1f, 1.2f, 1.35f}, Material::Metal);
        box(c - fwd * 1.0f, 0.9f, {3.9f, 1.25f, 1.45f}, Material::Metal);
        break;
      case Kind::Pedestrian:
        prims.push_back(make_cylinder(Eigen::Vector3f(c.x(), c.y(), base), 0.25f, 1.75f, static_cast<std::uint32_t>(scene.info.size())));
        scene.info.push_back({0, Material::Concrete});
        break;
    }
  }
  scene.bvh = Bvh(std::move(prims));
  return scene;
}

std::vector<Eigen::Vector2f> Traffic::positions_at(double t) const {
  std::vector<Eigen::Vector2f> out;
  for (const Agent& a : agents_) {
    Eigen::Vector2f c;
    float yaw, base;
    if (place(a, t, c, yaw, base)) out.push_back(c);
  }
  return out;
}

}  // namespace pl::sim
