#include "pl/common/geo.hpp"

#include <cmath>

namespace pl {
namespace {
constexpr double kA = 6378137.0;                 // WGS84 semi-major axis
constexpr double kF = 1.0 / 298.257223563;       // WGS84 flattening
constexpr double kE2 = kF * (2.0 - kF);          // first eccentricity squared
constexpr double kDeg = M_PI / 180.0;
constexpr double kEarthRadiusKitti = 6378137.0;  // the sphere KITTI's Mercator uses
}  // namespace

Eigen::Vector3d geodetic_to_ecef(const GeoPoint& p) {
  double lat = p.lat_deg * kDeg, lon = p.lon_deg * kDeg;
  double s = std::sin(lat), c = std::cos(lat);
  double n = kA / std::sqrt(1.0 - kE2 * s * s);
  return {(n + p.alt_m) * c * std::cos(lon), (n + p.alt_m) * c * std::sin(lon), (n * (1.0 - kE2) + p.alt_m) * s};
}

GeoPoint ecef_to_geodetic(const Eigen::Vector3d& e) {
  double p = std::hypot(e.x(), e.y());
  double lon = std::atan2(e.y(), e.x());
  double lat = std::atan2(e.z(), p * (1.0 - kE2));
  double h = 0.0;
  for (int i = 0; i < 12; ++i) {  // converges to far below a millimetre within a few iterations
    double s = std::sin(lat);
    double n = kA / std::sqrt(1.0 - kE2 * s * s);
    h = p / std::cos(lat) - n;
    double next = std::atan2(e.z(), p * (1.0 - kE2 * n / (n + h)));
    bool done = std::abs(next - lat) < 1e-15;
    lat = next;
    if (done) break;
  }
  double s = std::sin(lat);
  double n = kA / std::sqrt(1.0 - kE2 * s * s);
  h = std::abs(std::cos(lat)) > 1e-9 ? p / std::cos(lat) - n : std::abs(e.z()) - n * (1.0 - kE2);
  return {lat / kDeg, lon / kDeg, h};
}

EnuFrame::EnuFrame(const GeoPoint& origin) : origin_(origin), origin_ecef_(geodetic_to_ecef(origin)) {
  double lat = origin.lat_deg * kDeg, lon = origin.lon_deg * kDeg;
  double sl = std::sin(lat), cl = std::cos(lat), so = std::sin(lon), co = std::cos(lon);
  enu_from_ecef_ << -so, co, 0.0,  //
      -sl * co, -sl * so, cl,      //
      cl * co, cl * so, sl;
}

Eigen::Vector3d EnuFrame::to_enu(const GeoPoint& p) const { return enu_from_ecef_ * (geodetic_to_ecef(p) - origin_ecef_); }

GeoPoint EnuFrame::to_geodetic(const Eigen::Vector3d& enu) const {
  return ecef_to_geodetic(origin_ecef_ + enu_from_ecef_.transpose() * enu);
}

Eigen::Vector2d kitti_mercator(double lat_deg, double lon_deg, double scale) {
  double x = scale * lon_deg * kDeg * kEarthRadiusKitti;
  double y = scale * kEarthRadiusKitti * std::log(std::tan((90.0 + lat_deg) * kDeg / 2.0));
  return {x, y};
}

}  // namespace pl
