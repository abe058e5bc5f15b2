// A whole simulated drive, written in the dataset layout (velodyne/*.bin, times.txt, poses.txt,
// encoder.csv, gps.csv, meta.json): what pl-sim runs.
#pragma once

#include <string>

#include "pl/common/geo.hpp"
#include "pl/sim/sensors.hpp"
#include "pl/sim/traffic.hpp"
#include "pl/sim/world.hpp"

namespace pl::sim {

struct SimOptions {
  std::string route;            // built-in route, or
  std::string trajectory_path;  // a KITTI pose file
  std::string times_path;       // its times (found beside it when empty)
  bool lidar_poses = false;     // the file holds LiDAR poses (else KITTI cam0 poses)
  double speed_scale = 1.0;     // the route driven this many times as fast (scans stay at 10 Hz)
  // The stretch the other options drive, driven from its end back to its start through the same
  // world (built along the forward path, so the direction cannot change it).
  bool reverse = false;
  std::string out_dir;
  long long frames = 0;  // 0: the whole route
  WorldConfig world;
  // The drive's own randomness (traffic, sensor noise, GPS and truth errors): another vehicle in
  // the same world. < 0: the world's seed.
  long long drive_seed = -1;
  TrafficConfig traffic;
  std::string lidar = "hdl64";
  double fov_deg = 360.0;
  // Each scan swept over 0.1 s while the vehicle moves (points in the sensor frame of their own
  // firing, their times written to point_times/); false: every ray from the scan time's pose.
  bool sweep = true;
  double calibration_error = 1.0;  // per-laser errors like a real HDL-64E's, times this (0: none)
  TruthErrorConfig truth;          // the ground truth written: exact (scale 0) or as an INS's
  std::string gnss_profile;
  GeoPoint origin{49.011212804, 8.422885042, 112.83};
  EncoderConfig encoder;
  GpsConfig gps;
  std::string preview, map_out;
  double map_spacing = 0.1;
  int threads = 0;  // 0: all cores
  bool force = false;
};

struct SimReport {
  std::size_t frames = 0, objects = 0, movable = 0;
  std::size_t changes = 0;  // epoch 1: the things changed since epoch 0 (changes.csv)
  std::size_t points_min = 0, points_max = 0;
  double points_median = 0;  // pl::median of the scans' point counts
  std::size_t encoder_samples = 0, gps_fixes = 0, map_points = 0;
  std::string gps_mix;
  double length_m = 0, duration_s = 0, seconds = 0;
  double max_speed_mps = 0;
  int threads = 1;
};

// The trajectory the options describe, and the scan times on it, forward (the world is built along
// it; simulate() turns it round for `reverse`).
SimTrajectory load_trajectory(const SimOptions& o, std::vector<double>& scan_times);

// Writes the dataset into o.out_dir (through a sibling folder renamed into place at the end, so an
// interrupted run never leaves a half-written dataset behind), with objects.csv (the world's things
// and the returns each gave this drive) and, in epoch 1, changes.csv (what changed since epoch 0:
// the ground truth of a map update, with the rays of this drive that see each change: probe rays
// from every 5th scan's pose, every 4th beam, every 0.5 deg, up to 40 m, cast into both epochs'
// worlds, counting a return on a changed thing with no surface of the other epoch within 0.5 m
// along its normal; changes_seen.csv: the same per thing and 1 m cell of the world).
SimReport simulate(const SimOptions& o);

}  // namespace pl::sim
