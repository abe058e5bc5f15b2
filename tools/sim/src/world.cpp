// The world's classes and materials, its shapes for the ray caster, and the ground model (the
// procedural generation is in world_generator.cpp).
#include "pl/sim/world.hpp"

#include <algorithm>
#include <cmath>
#include <random>
#include <unordered_map>

#include "pl/common/error.hpp"

namespace pl::sim {

const char* class_name(ObjectClass c) {
  switch (c) {
    case ObjectClass::Ground: return "ground";
    case ObjectClass::Curb: return "curb";
    case ObjectClass::Building: return "building";
    case ObjectClass::Wall: return "wall";
    case ObjectClass::Fence: return "fence";
    case ObjectClass::ParkedCar: return "parked car";
    case ObjectClass::ParkedTruck: return "parked truck";
    case ObjectClass::Pole: return "pole";
    case ObjectClass::Sign: return "sign";
    case ObjectClass::Tree: return "tree";
    case ObjectClass::Container: return "container";
    case ObjectClass::SmallBuilding: return "small building";
  }
  return "?";
}

bool is_movable(ObjectClass c) {
  switch (c) {
    case ObjectClass::ParkedCar:
    case ObjectClass::ParkedTruck:
    case ObjectClass::Container:
    case ObjectClass::Tree:
    case ObjectClass::Fence:
    case ObjectClass::SmallBuilding: return true;
    default: return false;
  }
}

float albedo(Material m) {
  switch (m) {
    case Material::Asphalt: return 0.08f;
    case Material::Pavement: return 0.25f;
    case Material::Grass: return 0.30f;
    case Material::Concrete: return 0.35f;
    case Material::Brick: return 0.28f;
    case Material::Metal: return 0.45f;
    case Material::Glass: return 0.05f;
    case Material::Vegetation: return 0.40f;
    case Material::Retroreflector: return 0.95f;
  }
  return 0.2f;
}

std::vector<Primitive> World::shapes(std::vector<ShapeInfo>& info) const {
  std::vector<Primitive> out;
  info.clear();
  for (std::size_t o = 0; o < objects.size(); ++o) {
    const WorldObject& obj = objects[o];
    for (std::size_t k = 0; k < obj.shapes.size(); ++k) {
      Primitive p = obj.shapes[k];
      p.object = static_cast<std::uint32_t>(info.size());
      info.push_back({static_cast<std::uint32_t>(o), obj.materials[k]});
      out.push_back(p);
    }
  }
  return out;
}

// ---------------------------------------------------------------------------------------------
// Ground model

GroundModel::GroundModel(const SimTrajectory& path, double t0, double t1) {
  double s0 = path.distance_at(t0), s1 = path.distance_at(t1);
  for (double s = s0; s <= s1 + 1e-9; s += 1.0) {
    Pose p = path.pose_at(path.time_at_distance(s));
    Eigen::Vector3d road = p.translation() - p.linear() * Eigen::Vector3d(0, 0, kLidarHeight);
    samples_.push_back(road.cast<float>());
  }
  if (samples_.empty()) {
    Pose p = path.pose_at(t0);
    samples_.push_back((p.translation() - Eigen::Vector3d(0, 0, kLidarHeight)).cast<float>());
  }
  index_.reserve(samples_.size());
  for (std::uint32_t i = 0; i < samples_.size(); ++i) {
    int cx = static_cast<int>(std::floor(samples_[i].x() / cell_)), cy = static_cast<int>(std::floor(samples_[i].y() / cell_));
    index_.emplace_back(key(cx, cy), i);
  }
  std::sort(index_.begin(), index_.end());
}

template <typename Fn>
void GroundModel::for_samples_near(float x, float y, int reach, Fn&& fn) const {
  int cx = static_cast<int>(std::floor(x / cell_)), cy = static_cast<int>(std::floor(y / cell_));
  for (int dx = -reach; dx <= reach; ++dx)
    for (int dy = -reach; dy <= reach; ++dy) {
      auto k = key(cx + dx, cy + dy);
      auto it = std::lower_bound(index_.begin(), index_.end(), std::make_pair(k, 0u));
      for (; it != index_.end() && it->first == k; ++it) {
        const auto& s = samples_[it->second];
        fn(s, static_cast<double>(s.x() - x) * (s.x() - x) + static_cast<double>(s.y() - y) * (s.y() - y));
      }
    }
}

float GroundModel::distance_to_path(float x, float y, float cap) const {
  double best = static_cast<double>(cap) * cap;
  for_samples_near(x, y, static_cast<int>(std::ceil(cap / cell_)), [&](const Eigen::Vector3f&, double d2) { best = std::min(best, d2); });
  return static_cast<float>(std::sqrt(best));
}

float GroundModel::height_at(float x, float y) const {
  // Inverse-distance weights over the path samples within 15 m; the nearest sample further out.
  double wsum = 0.0, hsum = 0.0, best = INFINITY, best_h = samples_.front().z();
  for (int reach = 2; reach <= 64 && wsum == 0.0; reach *= 4) {
    for_samples_near(x, y, reach, [&](const Eigen::Vector3f& s, double d2) {
      if (d2 < best) best = d2, best_h = s.z();
      if (d2 < 225.0) {
        double w = 1.0 / (d2 + 4.0);
        wsum += w;
        hsum += w * s.z();
      }
    });
  }
  return wsum > 0.0 ? static_cast<float>(hsum / wsum) : static_cast<float>(best_h);
}

}  // namespace pl::sim
