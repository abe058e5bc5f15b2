// WGS84 geodetic coordinates and a local East-North-Up frame about a double-precision origin.
#pragma once

#include <Eigen/Core>

namespace pl {

struct GeoPoint {
  double lat_deg = 0.0;
  double lon_deg = 0.0;
  double alt_m = 0.0;
};

Eigen::Vector3d geodetic_to_ecef(const GeoPoint& p);
GeoPoint ecef_to_geodetic(const Eigen::Vector3d& ecef);

// Local tangent frame: x east, y north, z up, metres from the origin.
class EnuFrame {
 public:
  explicit EnuFrame(const GeoPoint& origin);
  Eigen::Vector3d to_enu(const GeoPoint& p) const;
  GeoPoint to_geodetic(const Eigen::Vector3d& enu) const;
  const GeoPoint& origin() const { return origin_; }

 private:
  GeoPoint origin_;
  Eigen::Vector3d origin_ecef_;
  Eigen::Matrix3d enu_from_ecef_;
};

// KITTI's OXTS convention: spherical Mercator with scale = cos(lat0); x east, y north (metres).
Eigen::Vector2d kitti_mercator(double lat_deg, double lon_deg, double scale);

}  // namespace pl
