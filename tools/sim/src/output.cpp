#include "pl/sim/output.hpp"

#include <cmath>
#include <map>

#include "pl/common/svg.hpp"

namespace pl::sim {

namespace {

const char* class_colour(ObjectClass c) {
  switch (c) {
    case ObjectClass::Building: return "#8c8c8c";
    case ObjectClass::SmallBuilding: return "#b07aa1";
    case ObjectClass::Wall: return "#5f5f5f";
    case ObjectClass::Fence: return "#c49c94";
    case ObjectClass::ParkedCar: return "#1f77b4";
    case ObjectClass::ParkedTruck: return "#17becf";
    case ObjectClass::Container: return "#ff7f0e";
    case ObjectClass::Tree: return "#2ca02c";
    case ObjectClass::Pole: return "#d62728";
    case ObjectClass::Sign: return "#e377c2";
    case ObjectClass::Curb: return "#bcbd22";
    default: return "#cccccc";
  }
}

}  // namespace

void write_preview(const std::string& path, const World& world, const SimTrajectory& traj, double t0, double t1,
                   const Traffic* traffic) {
  SvgPlot plot("pl-sim world, top view (seed " + std::to_string(world.config.seed) + ", epoch " +
                   std::to_string(world.config.epoch) + ", " + world.config.preset + ")",
               "east [m]", "north [m]");
  plot.set_equal_aspect(true);
  plot.set_size(1100, 900);
  // Footprints by class, in a fixed drawing order (ground-level things first).
  const ObjectClass order[] = {ObjectClass::Curb, ObjectClass::Building, ObjectClass::SmallBuilding, ObjectClass::Wall,
                               ObjectClass::Fence, ObjectClass::Container, ObjectClass::ParkedTruck, ObjectClass::ParkedCar,
                               ObjectClass::Tree, ObjectClass::Pole, ObjectClass::Sign};
  for (ObjectClass cls : order) {
    std::vector<double> xs, ys;
    std::size_t count = 0;
    for (const WorldObject& o : world.objects) {
      if (o.cls != cls) continue;
      ++count;
      float c = std::cos(o.yaw), s = std::sin(o.yaw);
      Eigen::Vector2f half = o.half.cwiseMax(Eigen::Vector2f(0.4f, 0.4f));  // poles stay visible
      const float corners[4][2] = {{1, 1}, {-1, 1}, {-1, -1}, {1, -1}};
      for (const auto& k : corners) {
        float u = k[0] * half.x(), v = k[1] * half.y();
        xs.push_back(o.centre.x() + c * u - s * v);
        ys.push_back(o.centre.y() + s * u + c * v);
      }
      xs.push_back(NAN);
      ys.push_back(NAN);
    }
    if (count) plot.add_polygons(std::string(class_name(cls)) + " (" + std::to_string(count) + ")", xs, ys, class_colour(cls));
  }
  std::vector<double> tx, ty;
  for (double t = t0; t <= t1 + 1e-9; t += 0.1) {
    Pose p = traj.pose_at(t);
    tx.push_back(p.translation().x());
    ty.push_back(p.translation().y());
  }
  plot.add_line("trajectory", tx, ty, "#000000", 1.5);
  plot.add_points("start", {tx.front()}, {ty.front()}, "#000000", 5.0);
  if (traffic && traffic->size()) {
    std::vector<double> ax, ay;
    for (const auto& p : traffic->positions_at(t0)) ax.push_back(p.x()), ay.push_back(p.y());
    plot.add_points("traffic at the start", ax, ay, "#9467bd", 3.0);
  }
  plot.save(path);
}

Points3d sample_world(const World& world, double spacing, std::vector<float>& intensity) {
  Points3d pts;
  intensity.clear();
  const float h = static_cast<float>(spacing);
  auto emit = [&](const Eigen::Vector3f& p, Material m) {
    pts.push_back(p.cast<double>());
    intensity.push_back(albedo(m));
  };
  for (const WorldObject& o : world.objects) {
    for (std::size_t k = 0; k < o.shapes.size(); ++k) {
      const Primitive& p = o.shapes[k];
      Material m = o.materials[k];
      switch (p.shape) {
        case Shape::Triangle: {
          Eigen::Vector3f e1 = p.b - p.a, e2 = p.c - p.a;
          int n1 = std::max(1, static_cast<int>(std::ceil(e1.norm() / h))), n2 = std::max(1, static_cast<int>(std::ceil(e2.norm() / h)));
          for (int i = 0; i <= n1; ++i)
            for (int j = 0; j <= n2; ++j) {
              float u = static_cast<float>(i) / n1, v = static_cast<float>(j) / n2;
              if (u + v <= 1.0f + 1e-6f) emit(p.a + u * e1 + v * e2, m);
            }
          break;
        }
        case Shape::Box: {
          // Every face but the bottom, on a grid.
          float c = std::cos(p.yaw), s = std::sin(p.yaw);
          Eigen::Matrix3f r;
          r << c, -s, 0, s, c, 0, 0, 0, 1;
          for (int axis = 0; axis < 3; ++axis)
            for (int sign : {-1, 1}) {
              if (axis == 2 && sign < 0) continue;
              int ua = (axis + 1) % 3, va = (axis + 2) % 3;
              int nu = std::max(1, static_cast<int>(std::ceil(2 * p.b[ua] / h))), nv = std::max(1, static_cast<int>(std::ceil(2 * p.b[va] / h)));
              for (int i = 0; i <= nu; ++i)
                for (int j = 0; j <= nv; ++j) {
                  Eigen::Vector3f q;
                  q[axis] = sign * p.b[axis];
                  q[ua] = -p.b[ua] + 2 * p.b[ua] * i / nu;
                  q[va] = -p.b[va] + 2 * p.b[va] * j / nv;
                  emit(p.a + r * q, m);
                }
            }
          break;
        }
        case Shape::Cylinder: {
          float rad = p.b.x(), height = p.b.z();
          int na = std::max(6, static_cast<int>(std::ceil(2 * M_PI * rad / h))), nz = std::max(1, static_cast<int>(std::ceil(height / h)));
          for (int i = 0; i < na; ++i) {
            float a = 2.0f * static_cast<float>(M_PI) * i / na;
            for (int j = 0; j <= nz; ++j) emit(p.a + Eigen::Vector3f(rad * std::cos(a), rad * std::sin(a), height * j / nz), m);
          }
          break;
        }
        case Shape::Ellipsoid: {
          float rmax = p.b.maxCoeff();
          int nt = std::max(4, static_cast<int>(std::ceil(M_PI * rmax / h)));
          float c = std::cos(p.yaw), s = std::sin(p.yaw);
          for (int i = 0; i <= nt; ++i) {
            float th = static_cast<float>(M_PI) * i / nt;
            int np = std::max(1, static_cast<int>(std::ceil(2 * M_PI * rmax * std::sin(th) / h)));
            for (int j = 0; j < np; ++j) {
              float ph = 2.0f * static_cast<float>(M_PI) * j / np;
              Eigen::Vector3f q(p.b.x() * std::sin(th) * std::cos(ph), p.b.y() * std::sin(th) * std::sin(ph), p.b.z() * std::cos(th));
              emit(p.a + Eigen::Vector3f(c * q.x() - s * q.y(), s * q.x() + c * q.y(), q.z()), m);
            }
          }
          break;
        }
      }
    }
  }
  return pts;
}

}  // namespace pl::sim
