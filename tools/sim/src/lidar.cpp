#include "pl/sim/lidar.hpp"

#include <cmath>

#include "pl/common/error.hpp"
#include "pl/common/meta.hpp"

namespace pl::sim {

LidarModel lidar_model(const std::string& name) {
  LidarModel m;
  m.name = name;
  if (name == "hdl64") {
    m.model = "HDL-64E";
    m.vertical_deg = hdl64_vertical_angles_deg();  // +2.0 .. -24.3 deg, KITTI's mounting
    m.azimuth_steps = 2083;                        // 0.173 deg at 10 Hz
    m.max_range = 120.0;
  } else if (name == "vlp16" || name == "rs16") {
    m.model = name == "vlp16" ? "VLP-16" : "RS-LiDAR-16";
    for (int i = 0; i < 16; ++i) m.vertical_deg.push_back(15.0 - 2.0 * i);  // +15 .. -15 deg, top first
    m.azimuth_steps = 1800;                                                  // 0.2 deg at 10 Hz
    m.max_range = name == "vlp16" ? 100.0 : 150.0;
  } else {
    throw Error("unknown LiDAR \"" + name + "\" (hdl64, vlp16 or rs16)");
  }
  return m;
}

namespace {

inline float normal01(std::mt19937_64& rng) {
  // Sum of uniforms (Irwin-Hall, 4 terms) scaled to unit variance: cheap and plenty for sensor noise.
  constexpr float kScale = 1.0f / 18446744073709551616.0f;
  float s = 0.f;
  for (int i = 0; i < 4; ++i) s += static_cast<float>(rng()) * kScale;
  return (s - 2.0f) * 1.7320508f;
}
inline float uniform01(std::mt19937_64& rng) { return static_cast<float>(rng() >> 40) * (1.0f / 16777216.0f); }

}  // namespace

Scan cast_scan(const LidarModel& lidar, const Pose& sensor, const Scene& world, const Scene* moving, std::mt19937_64& rng) {
  const int rings = static_cast<int>(lidar.vertical_deg.size());
  const int steps = lidar.azimuth_steps;
  const double step = 2.0 * M_PI / steps;
  const double half_fov = lidar.fov_deg >= 360.0 ? M_PI + 1.0 : lidar.fov_deg * M_PI / 360.0;
  const Eigen::Matrix3f rot = sensor.linear().cast<float>();
  const Eigen::Vector3f origin = sensor.translation().cast<float>();
  const float max_range = static_cast<float>(lidar.max_range), min_range = static_cast<float>(lidar.min_range);

  // Unit directions of one turn in the sensor frame (azimuth only; elevation per ring below).
  std::vector<float> cos_az(steps), sin_az(steps);
  std::vector<bool> seen(steps);
  for (int k = 0; k < steps; ++k) {
    double az = (k + 0.5) * step;  // starts just left of straight ahead, counter-clockwise
    cos_az[k] = static_cast<float>(std::cos(az));
    sin_az[k] = static_cast<float>(std::sin(az));
    seen[k] = std::abs(std::remainder(az, 2.0 * M_PI)) <= half_fov;
  }
  Scan scan;
  scan.reserve(static_cast<std::size_t>(rings) * steps);
  for (int r = 0; r < rings; ++r) {
    double el = lidar.vertical_deg[r] * M_PI / 180.0;
    float ce = static_cast<float>(std::cos(el)), se = static_cast<float>(std::sin(el));
    for (int k = 0; k < steps; ++k) {
      if (!seen[k]) continue;
      Eigen::Vector3f d_sensor(ce * cos_az[k], ce * sin_az[k], se);
      Ray ray{origin, rot * d_sensor, max_range};
      Hit hit;
      const ShapeInfo* info = nullptr;
      if (world.bvh.intersect(ray, hit)) {
        info = &world.info[world.bvh.primitives()[hit.primitive].object];
        ray.t_max = hit.t;
      }
      if (moving) {
        Hit mh;
        if (moving->bvh.intersect(ray, mh)) {
          hit = mh;
          info = &moving->info[moving->bvh.primitives()[mh.primitive].object];
        }
      }
      if (!info || hit.t < min_range) continue;
      float drop = uniform01(rng);
      float noise = static_cast<float>(lidar.range_noise) * normal01(rng);
      if (drop < lidar.dropout) continue;
      if (info->material == Material::Glass && drop < 0.85f) continue;  // glass mostly returns nothing
      if (info->material == Material::Vegetation) {                      // leaves: ragged returns
        if (drop < 0.12f) continue;
        noise += 0.05f * normal01(rng);
      }
      float range = hit.t + noise;
      if (range >= max_range) continue;
      float incidence = std::abs(hit.normal.dot(ray.dir));
      float intensity = albedo(info->material) * (0.35f + 0.65f * incidence) + 0.02f * normal01(rng);
      intensity = std::min(1.0f, std::max(0.0f, intensity));
      Eigen::Vector3f p = d_sensor * range;
      scan.push_back({p.x(), p.y(), p.z(), intensity});
    }
  }
  return scan;
}

}  // namespace pl::sim
