// LiDAR sensor models and scan casting: KITTI-like scans (laser by laser, each laser one
// counter-clockwise turn starting just left of straight ahead) in the sensor frame.
#pragma once

#include <random>
#include <string>
#include <vector>

#include "pl/common/pose.hpp"
#include "pl/common/scan.hpp"
#include "pl/sim/raycast.hpp"
#include "pl/sim/world.hpp"

namespace pl::sim {

struct LidarModel {
  std::string name;                 // hdl64 | vlp16 | rs16
  std::string model;                // as written to meta.json
  std::vector<double> vertical_deg;  // beam 0 first
  int azimuth_steps = 2083;         // firings per turn
  double max_range = 120.0;
  double min_range = 1.0;
  double range_noise = 0.02;   // sigma, metres
  double dropout = 0.01;       // share of returns lost at random
  double fov_deg = 360.0;      // 180: the rear half is blocked by the vehicle body
};
LidarModel lidar_model(const std::string& name);  // throws pl::Error for an unknown name

// Shapes with what they belong to, in one hierarchy.
struct Scene {
  Bvh bvh;
  std::vector<ShapeInfo> info;
};

// One scan from `sensor` (the LiDAR pose in the world). `moving` may be null. Deterministic for a
// given rng state.
Scan cast_scan(const LidarModel& lidar, const Pose& sensor, const Scene& world, const Scene* moving, std::mt19937_64& rng);

}  // namespace pl::sim
