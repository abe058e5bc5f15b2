// Writes a map store of a generated courtyard (four walls, the ground, two boxes) with the installed
// library, then localizes ten scans of a drive through it with VehicleLocalizer. Exit 0 when every
// scan is fused and the last pose is within 5 cm; prints the error either way.
#include <pl/client/vehicle_localizer.hpp>
#include <pl/common/pose.hpp>
#include <pl/common/tile_codec.hpp>
#include <pl/schema/store.hpp>

#include <cmath>
#include <cstdio>
#include <map>
#include <random>

namespace {

struct Plane {
  Eigen::Vector3d origin, u, v;
};

// The ground, four walls and a grid of 2 m x 1 m x 3 m blocks every 8 m (vertical structure in
// every direction, as a street has).
std::vector<Plane> courtyard() {
  std::vector<Plane> p = {{{-30, -20, 0}, {60, 0, 0}, {0, 40, 0}}, {{-30, -20, 0}, {60, 0, 0}, {0, 0, 6}},
                          {{-30, 20, 0}, {60, 0, 0}, {0, 0, 6}},   {{-30, -20, 0}, {0, 40, 0}, {0, 0, 6}},
                          {{30, -20, 0}, {0, 40, 0}, {0, 0, 6}}};
  for (double x = -26; x < 28; x += 8)
    for (double y = -16; y < 18; y += 8) {
      if (std::abs(y + 3.0 - 1.0 * (x + 15.0) / 4.0) < 3.0) continue;  // keep the drive's path free
      p.push_back({{x, y, 0}, {2, 0, 0}, {0, 0, 3}});
      p.push_back({{x, y + 1, 0}, {2, 0, 0}, {0, 0, 3}});
      p.push_back({{x, y, 0}, {0, 1, 0}, {0, 0, 3}});
      p.push_back({{x + 2, y, 0}, {0, 1, 0}, {0, 0, 3}});
    }
  return p;
}
const std::vector<Plane> kCourtyard = courtyard();

// Points every `step` metres on the planes; `sensor`: a noisy scan in that frame within 40 m.
std::vector<Eigen::Vector3d> sample(double step, const Eigen::Isometry3d* sensor, std::vector<Eigen::Vector3f>* normals, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, 0.01);
  std::vector<Eigen::Vector3d> out;
  for (const Plane& pl : kCourtyard) {
    const int nu = static_cast<int>(pl.u.norm() / step), nv = static_cast<int>(pl.v.norm() / step);
    for (int i = 0; i <= nu; ++i)
      for (int j = 0; j <= nv; ++j) {
        const Eigen::Vector3d p = pl.origin + pl.u * (double(i) / nu) + pl.v * (double(j) / nv);
        if (normals) normals->push_back(pl.u.cross(pl.v).normalized().cast<float>());
        if (!sensor) {
          out.push_back(p);
        } else if ((p - sensor->translation()).norm() < 40.0) {
          out.push_back(sensor->inverse() * p + Eigen::Vector3d(noise(rng), noise(rng), noise(rng)));
        }
      }
  }
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) return 2;
  const std::string db = argv[1];
  {
    std::vector<Eigen::Vector3f> normals;
    const auto points = sample(0.2, nullptr, &normals, 0);
    std::map<pl::TileKey, pl::TileCloud> tiles;
    const pl::TileGrid grid(20.0);
    for (std::size_t i = 0; i < points.size(); ++i) {
      auto& t = tiles[grid.key_of(points[i].x(), points[i].y())];
      t.points.push_back(points[i]);
      t.normals.push_back(normals[i]);
    }
    auto store = pl::store::Store::open(db);
    store.create_map("yard", pl::GeoPoint{48.1, 11.6, 520.0}, 20.0, 0.2);
    const auto v = store.create_version("yard", std::nullopt, "consumer");
    for (const auto& [key, cloud] : tiles) {
      Eigen::AlignedBox3d box;
      for (const auto& p : cloud.points) box.extend(p);
      store.put_tile("yard", v.number, key, pl::encode_tile(cloud), static_cast<std::int64_t>(cloud.size()), box.min().x(), box.min().y(),
                     box.min().z(), box.max().x(), box.max().y(), box.max().z());
    }
    store.publish("yard", v.number);
  }
  pl::client::VehicleLocalizerConfig cfg;
  cfg.store_path = db;
  cfg.tiles.map = "yard";
  cfg.localizer.scan.voxel_m = 0.5;
  pl::client::VehicleLocalizer loc(cfg);
  auto truth = [](double t) { return pl::make_pose(-15.0 + 4.0 * t, -3.0 + 1.0 * t, 1.8, 0, 0, 0.05 * t); };
  loc.start(truth(0.0), 0.0);
  int fused = 0;
  for (int k = 1; k <= 10; ++k) {
    const double t = 0.1 * k;
    const Eigen::Isometry3d sensor = truth(t);
    pl::Scan scan;
    for (const auto& p : sample(0.4, &sensor, nullptr, static_cast<unsigned>(k)))
      scan.push_back({static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z()), 0.5f});
    loc.add_scan(t, scan);
    loc.wait_idle();
    fused += loc.last_report().fused_lidar;
    if (!loc.last_report().fused_lidar) std::printf("scan %d: %s (%zu points, %zu map tiles)\n", k, loc.last_report().note.c_str(), loc.last_report().scan_points, loc.last_report().map_tiles);
  }
  const double err = (loc.pose_at(1.0).base_in_map.translation() - truth(1.0).translation()).norm();
  std::printf("consumer: %d of 10 scans fused, last pose %.4f m off (%s)\n", fused, err, loc.last_error().c_str());
  return fused == 10 && err < 0.05 ? 0 : 1;
}
