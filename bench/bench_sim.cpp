// pl-sim scan throughput on one core: HDL-64E and 16-beam scans of the built-in town loop, ray cast
// against the world's bounding-volume hierarchy; the baseline is the same rays tested against every
// shape (brute force) in the same run.
#include <cstdio>
#include <random>

#include "bench_util.hpp"
#include "pl/sim/lidar.hpp"
#include "pl/sim/traffic.hpp"
#include "pl/sim/world.hpp"

using namespace pl::sim;

int main(int argc, char** argv) {
  int scans = argc > 1 ? std::atoi(argv[1]) : 20;
  SimTrajectory route = builtin_route("loop");
  double t_build = pl::bench::now_ms();
  World world = build_world(route, route.start_time(), route.end_time(), WorldConfig{});
  Scene scene;
  scene.bvh = Bvh(world.shapes(scene.info));
  t_build = pl::bench::now_ms() - t_build;
  TrafficConfig tc;
  tc.count = 20;
  Traffic traffic(route, route.start_time(), route.end_time(), tc);
  std::printf("town loop: %zu objects, %zu shapes, %zu BVH nodes, built in %.0f ms\n", world.objects.size(),
              scene.bvh.primitives().size(), scene.bvh.node_count(), t_build);

  for (const char* name : {"hdl64", "vlp16"}) {
    LidarModel lidar = lidar_model(name);
    std::vector<double> ms;
    std::size_t points = 0;
    for (int i = 0; i < scans; ++i) {
      double t = route.end_time() * (i + 0.5) / scans;
      pl::Pose pose = route.pose_at(t);
      std::mt19937_64 rng(i);
      double t0 = pl::bench::now_ms();
      Scene moving = traffic.scene_at(t, pose.translation(), lidar.max_range);
      points += cast_scan(lidar, pose, scene, &moving, rng).size();
      ms.push_back(pl::bench::now_ms() - t0);
    }
    double med = pl::median(ms);
    double rays = static_cast<double>(lidar.vertical_deg.size()) * lidar.azimuth_steps;
    std::printf("  %-6s %2zu beams: %6.1f scans/s (median %.1f ms a scan, %.2f M rays/s), %zu points a scan; target >= %d scans/s\n",
                name, lidar.vertical_deg.size(), 1000.0 / med, med, rays / med / 1000.0, points / scans,
                lidar.vertical_deg.size() > 16 ? 5 : 20);
  }

  // Baseline: the same kind of rays against every shape, no hierarchy.
  const auto& prims = scene.bvh.primitives();
  std::mt19937_64 rng(9);
  std::uniform_real_distribution<float> u(-1.f, 1.f);
  pl::Pose pose = route.pose_at(route.end_time() * 0.3);
  Eigen::Vector3f o = pose.translation().cast<float>();
  std::vector<Ray> rays;
  for (int i = 0; i < 400; ++i) rays.push_back({o, Eigen::Vector3f(u(rng), u(rng), -0.3f + 0.35f * u(rng)).normalized(), 120.f});
  double tb = pl::bench::now_ms();
  std::size_t hits_brute = 0;
  for (const Ray& r : rays) {
    Hit best, h;
    bool any = false;
    for (const auto& p : prims)
      if (intersect(p, Ray{r.origin, r.dir, any ? best.t : r.t_max}, h)) best = h, any = true;
    hits_brute += any;
  }
  tb = pl::bench::now_ms() - tb;
  double tv = pl::bench::now_ms();
  std::size_t hits_bvh = 0;
  for (int k = 0; k < 100; ++k)
    for (const Ray& r : rays) {
      Hit h;
      hits_bvh += scene.bvh.intersect(r, h);
    }
  tv = (pl::bench::now_ms() - tv) / 100.0;
  std::printf("  closest hit, %zu rays: BVH %.3f ms vs brute force %.1f ms (%.0fx faster; %zu / %zu hits)\n", rays.size(), tv, tb,
              tb / tv, hits_bvh / 100, hits_brute);
  return 0;
}
