// LiDAR sensor models and scan casting: KITTI-like scans (laser by laser, each laser one
// counter-clockwise turn starting just left of straight ahead) in the sensor frame.
#pragma once

#include <cstdint>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include "pl/common/pose.hpp"
#include "pl/common/scan.hpp"
#include "pl/sim/raycast.hpp"
#include "pl/sim/world.hpp"

namespace pl::sim {

// How one laser of a real sensor differs from the table its driver uses: the true beam points
// `elevation_deg` higher and `azimuth_deg` further counter-clockwise than the table says, and its
// ranges read `range_m` long. The driver computes points with the table, so the errors stay in the data.
struct LaserError {
  double elevation_deg = 0.0, azimuth_deg = 0.0, range_m = 0.0;
};

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
  std::vector<LaserError> laser_errors;  // one per beam, or empty: a perfectly calibrated sensor
};
LidarModel lidar_model(const std::string& name);  // throws pl::Error for an unknown name

// Per-laser calibration errors like a factory-calibrated HDL-64E's, drawn from `seed` and scaled by
// `scale` (0: none): elevation and azimuth offsets of sigma 0.12 deg (a few tenths at most) and a
// range bias of sigma 2 cm per laser.
std::vector<LaserError> draw_laser_errors(std::size_t lasers, double scale, std::uint64_t seed);

// Shapes with what they belong to, in one hierarchy.
struct Scene {
  Bvh bvh;
  std::vector<ShapeInfo> info;
};

// One scan from `sensor` (the LiDAR pose in the world), every ray from that one pose. `moving` may be
// null. Deterministic for a given rng state.
Scan cast_scan(const LidarModel& lidar, const Pose& sensor, const Scene& world, const Scene* moving, std::mt19937_64& rng);

// The sweep of a spinning LiDAR: the head turns counter-clockwise seen from above once per sweep (the
// timing that fits KITTI's drive 0005 best, docs/benchmarks.md), and the scan's time is when it faces
// straight ahead (KITTI's convention). A firing at azimuth a (counter-clockwise from ahead, in (-180, 180] deg)
// happens at share s = a / 360 of the sweep, from -0.5 (just past the back, on the right) to +0.5
// (back, on the left); `sensor_at(s)`
// gives the LiDAR's pose then. Each point is written in the sensor frame of its own firing, as a
// driver gives it, so the vehicle's motion distorts the scan. `shares`, when not null, receives each
// point's share; `objects`, when not null, what each point hit: its index into World::objects, or
// kTraffic for a moving agent.
constexpr std::uint32_t kTraffic = 0xFFFFFFFFu;
Scan cast_sweep(const LidarModel& lidar, const std::function<Pose(double share)>& sensor_at, const Scene& world,
                const Scene* moving, std::mt19937_64& rng, std::vector<float>* shares = nullptr,
                std::vector<std::uint32_t>* objects = nullptr);

}  // namespace pl::sim
