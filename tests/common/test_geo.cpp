#include <gtest/gtest.h>

#include <cmath>

#include "pl/common/geo.hpp"

TEST(Geo, EcefRoundTrip) {
  for (double lat : {-89.0, -33.9, 0.0, 49.011212804408, 78.2}) {
    for (double lon : {-179.5, -0.1, 8.4228850417969, 151.2}) {
      for (double alt : {-50.0, 112.83, 8848.0}) {
        pl::GeoPoint g{lat, lon, alt};
        pl::GeoPoint r = pl::ecef_to_geodetic(pl::geodetic_to_ecef(g));
        EXPECT_NEAR(r.lat_deg, lat, 1e-10);
        EXPECT_NEAR(r.lon_deg, lon, 1e-10);
        EXPECT_NEAR(r.alt_m, alt, 1e-6);
      }
    }
  }
}

TEST(Geo, EcefKnownValue) {
  // On the equator at the prime meridian the ECEF x is the semi-major axis plus the height.
  Eigen::Vector3d e = pl::geodetic_to_ecef({0.0, 0.0, 100.0});
  EXPECT_NEAR(e.x(), 6378137.0 + 100.0, 1e-6);
  EXPECT_NEAR(e.y(), 0.0, 1e-6);
  EXPECT_NEAR(e.z(), 0.0, 1e-6);
}

TEST(Geo, EnuAxesAndDistances) {
  pl::GeoPoint o{49.0112128, 8.4228850, 112.8};
  pl::EnuFrame f(o);
  EXPECT_LT(f.to_enu(o).norm(), 1e-6);
  // One arc-second of latitude north is ~30.9 m at this latitude; east/up stay ~0.
  Eigen::Vector3d n = f.to_enu({o.lat_deg + 1.0 / 3600.0, o.lon_deg, o.alt_m});
  EXPECT_NEAR(n.x(), 0.0, 1e-6);
  EXPECT_NEAR(n.y(), 30.88, 0.05);
  EXPECT_NEAR(n.z(), 0.0, 1e-3);
  Eigen::Vector3d e = f.to_enu({o.lat_deg, o.lon_deg + 1.0 / 3600.0, o.alt_m});
  EXPECT_GT(e.x(), 20.0);
  EXPECT_NEAR(e.y(), 0.0, 1e-3);
  Eigen::Vector3d u = f.to_enu({o.lat_deg, o.lon_deg, o.alt_m + 10.0});
  EXPECT_NEAR(u.z(), 10.0, 1e-6);
}

TEST(Geo, EnuRoundTripFarAway) {
  pl::EnuFrame f({49.0, 8.4, 100.0});
  for (Eigen::Vector3d p : {Eigen::Vector3d(250000.0, -180000.0, 35.0), Eigen::Vector3d(-3.25, 7.5, -1.0)}) {
    Eigen::Vector3d back = f.to_enu(f.to_geodetic(p));
    EXPECT_NEAR((back - p).norm(), 0.0, 1e-6);
  }
}

TEST(Geo, KittiMercatorMatchesLocalDistances) {
  double lat0 = 49.0;
  double s = std::cos(lat0 * M_PI / 180.0);
  Eigen::Vector2d a = pl::kitti_mercator(lat0, 8.0, s), b = pl::kitti_mercator(lat0 + 0.001, 8.001, s);
  pl::EnuFrame f({lat0, 8.0, 0.0});
  Eigen::Vector3d enu = f.to_enu({lat0 + 0.001, 8.001, 0.0});
  // Near the origin the scaled Mercator agrees with ENU to a few parts in a thousand (sphere vs ellipsoid).
  EXPECT_NEAR((b - a).x(), enu.x(), 0.01 * enu.x());
  EXPECT_NEAR((b - a).y(), enu.y(), 0.01 * enu.y());
}
