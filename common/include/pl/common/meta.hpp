// meta.json: the sensor, the vehicle and the map origin of a dataset (see docs/dataset-layout.md).
#pragma once

#include <Eigen/Core>
#include <optional>
#include <string>
#include <vector>

#include "pl/common/geo.hpp"

namespace pl {

struct SensorMeta {
  std::string model = "HDL-64E";
  int beams = 64;
  std::vector<double> vertical_angles_deg;  // one per beam, beam 0 first (top laser for KITTI)
  // "laser-by-laser": points stored ring after ring, each ring one turn starting just left of ahead
  // (KITTI's order; rings are found from the azimuth wrap). "any": rings from the vertical angles.
  std::string point_order = "laser-by-laser";
  double fov_deg = 360.0;
  double rate_hz = 10.0;
  double max_range_m = 120.0;
};

struct VehicleMeta {
  double wheel_base_m = 0.0;                                 // distance between the wheels (differential drive)
  Eigen::Vector3d gps_lever_arm = Eigen::Vector3d::Zero();  // GPS antenna in the LiDAR frame, metres
};

struct DatasetMeta {
  SensorMeta sensor;
  VehicleMeta vehicle;
  std::optional<GeoPoint> origin;  // map origin of the dataset's world (ENU) frame
};

// The nominal HDL-64E table as mounted on KITTI's car: +2.0 deg to -24.9 deg, top laser first.
std::vector<double> hdl64_vertical_angles_deg();

// Throw pl::Error naming the file and the field (and the JSON parser's line/column) on bad input.
DatasetMeta read_meta(const std::string& path);
void write_meta(const std::string& path, const DatasetMeta& meta);

}  // namespace pl
