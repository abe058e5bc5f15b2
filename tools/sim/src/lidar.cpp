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

std::vector<LaserError> draw_laser_errors(std::size_t lasers, double scale, std::uint64_t seed) {
  std::vector<LaserError> e(lasers);
  if (!(scale > 0)) return e;
  std::mt19937_64 rng(seed * 0xD1B54A32D192ED03ull + 0x1CE);
  std::normal_distribution<double> n(0.0, 1.0);
  for (LaserError& l : e) {
    l.elevation_deg = scale * 0.12 * n(rng);
    l.azimuth_deg = scale * 0.12 * n(rng);
    l.range_m = scale * 0.02 * n(rng);
  }
  return e;
}

Scan cast_scan(const LidarModel& lidar, const Pose& sensor, const Scene& world, const Scene* moving, std::mt19937_64& rng) {
  return cast_sweep(lidar, [&](double) { return sensor; }, world, moving, rng);
}

Scan cast_sweep(const LidarModel& lidar, const std::function<Pose(double share)>& sensor_at, const Scene& world,
                const Scene* moving, std::mt19937_64& rng, std::vector<float>* shares, std::vector<std::uint32_t>* objects) {
  const int rings = static_cast<int>(lidar.vertical_deg.size());
  const int steps = lidar.azimuth_steps;
  const double step = 2.0 * M_PI / steps;
  const double half_fov = lidar.fov_deg >= 360.0 ? M_PI + 1.0 : lidar.fov_deg * M_PI / 360.0;
  const float max_range = static_cast<float>(lidar.max_range), min_range = static_cast<float>(lidar.min_range);
  if (!lidar.laser_errors.empty() && lidar.laser_errors.size() != lidar.vertical_deg.size())
    throw Error("cast_sweep: " + std::to_string(lidar.laser_errors.size()) + " laser errors for " + std::to_string(rings) + " lasers");

  // Per firing column: the nominal azimuth, whether it is in view, its share of the sweep and the
  // sensor's pose at that moment.
  std::vector<double> az(steps), share(steps), cos_az(steps), sin_az(steps);
  std::vector<bool> seen(steps);
  std::vector<Eigen::Matrix3f> rot(steps);
  std::vector<Eigen::Vector3f> origin(steps);
  for (int k = 0; k < steps; ++k) {
    az[k] = (k + 0.5) * step;  // starts just left of straight ahead, counter-clockwise
    cos_az[k] = std::cos(az[k]);
    sin_az[k] = std::sin(az[k]);
    const double a = std::remainder(az[k], 2.0 * M_PI);
    seen[k] = std::abs(a) <= half_fov;
    share[k] = a / (2.0 * M_PI);  // registration::sweep_share_from_azimuth
    const Pose pose = sensor_at(share[k]);
    rot[k] = pose.linear().cast<float>();
    origin[k] = pose.translation().cast<float>();
  }
  Scan scan;
  scan.reserve(static_cast<std::size_t>(rings) * steps);
  if (shares) {
    shares->clear();
    shares->reserve(scan.capacity());
  }
  if (objects) objects->clear();
  for (int r = 0; r < rings; ++r) {
    const double el = lidar.vertical_deg[r] * M_PI / 180.0;
    const LaserError err = lidar.laser_errors.empty() ? LaserError{} : lidar.laser_errors[r];
    const double el_true = el + err.elevation_deg * M_PI / 180.0, daz = err.azimuth_deg * M_PI / 180.0;
    const double cos_daz = std::cos(daz), sin_daz = std::sin(daz);  // the true azimuth by angle addition
    const float ce = static_cast<float>(std::cos(el)), se = static_cast<float>(std::sin(el));
    const float ct = static_cast<float>(std::cos(el_true)), st = static_cast<float>(std::sin(el_true));
    const bool calibrated = err.elevation_deg == 0.0 && err.azimuth_deg == 0.0;
    for (int k = 0; k < steps; ++k) {
      if (!seen[k]) continue;
      const float ca = static_cast<float>(cos_az[k]), sa = static_cast<float>(sin_az[k]);
      const Eigen::Vector3f d_table(ce * ca, ce * sa, se);  // where the driver thinks the beam points
      Eigen::Vector3f d_true = d_table;                     // where it does
      if (!calibrated)
        d_true = Eigen::Vector3f(ct * static_cast<float>(cos_az[k] * cos_daz - sin_az[k] * sin_daz),
                                 ct * static_cast<float>(sin_az[k] * cos_daz + cos_az[k] * sin_daz), st);
      Ray ray{origin[k], rot[k] * d_true, max_range};
      Hit hit;
      const ShapeInfo* info = nullptr;
      bool traffic = false;
      if (world.bvh.intersect(ray, hit)) {
        info = &world.info[world.bvh.primitives()[hit.primitive].object];
        ray.t_max = hit.t;
      }
      if (moving) {
        Hit mh;
        if (moving->bvh.intersect(ray, mh)) {
          hit = mh;
          info = &moving->info[moving->bvh.primitives()[mh.primitive].object];
          traffic = true;
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
      float range = hit.t + noise + static_cast<float>(err.range_m);
      if (range >= max_range || range < min_range) continue;
      float incidence = std::abs(hit.normal.dot(ray.dir));
      float intensity = albedo(info->material) * (0.35f + 0.65f * incidence) + 0.02f * normal01(rng);
      intensity = std::min(1.0f, std::max(0.0f, intensity));
      Eigen::Vector3f p = d_table * range;
      scan.push_back({p.x(), p.y(), p.z(), intensity});
      if (shares) shares->push_back(static_cast<float>(share[k]));
      if (objects) objects->push_back(traffic ? kTraffic : info->object);
    }
  }
  return scan;
}

}  // namespace pl::sim
