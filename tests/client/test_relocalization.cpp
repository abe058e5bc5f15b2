// Relocalization by the map's places, on a generated town: a kidnapping onto a cross street (a new
// heading, no hint), a start with no pose at all, a start from a rough pose, and a scan from a place
// the map does not have, which must never be reported found.
#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <random>
#include <vector>

#include "pl/client/localizer.hpp"
#include "pl/common/error.hpp"
#include "pl/common/pose.hpp"
#include "map_tiles.hpp"
#include "scene.hpp"

namespace {

using pl::client::Health;
using pl::client::Localizer;
using pl::client::LocalizerConfig;
using pl::client::ScanReport;
using pl::registration::Place;
using pl::registration::PlaceIndex;
using pl::test::Surface;

constexpr double kDeg = M_PI / 180.0;

// Blocks of buildings of random sizes and heights round two crossing roads (along x at y = 0 and
// along y at x = 0, 12 m wide), 160 m square, with kiosks and poles on the pavements.
std::vector<Surface> town(unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> h(3.0, 16.0), setback(0.0, 3.0), gap(1.0, 5.0), len(6.0, 18.0), u01(0.0, 1.0);
  std::vector<Surface> s;
  s.push_back({{-80, -80, 0}, {160, 0, 0}, {0, 160, 0}});
  auto box = [&](double x, double y, double w, double d, double height) {
    s.push_back({{x, y, 0}, {w, 0, 0}, {0, 0, height}});
    s.push_back({{x, y + d, 0}, {w, 0, 0}, {0, 0, height}});
    s.push_back({{x, y, 0}, {0, d, 0}, {0, 0, height}});
    s.push_back({{x + w, y, 0}, {0, d, 0}, {0, 0, height}});
  };
  // Buildings along each side of each road, leaving the crossing free.
  for (int side : {-1, 1}) {
    for (double x = -78; x < 70;) {
      const double w = len(rng);
      if (std::abs(x + w / 2) > 12) box(x, side > 0 ? 6 + setback(rng) : -6 - setback(rng) - 8, w, 8, h(rng));
      x += w + gap(rng);
    }
    for (double y = -78; y < 70;) {
      const double d = len(rng);
      if (std::abs(y + d / 2) > 12) box(side > 0 ? 6 + setback(rng) : -6 - setback(rng) - 8, y, 8, d, h(rng));
      y += d + gap(rng);
    }
  }
  for (int k = 0; k < 24; ++k) {  // poles and kiosks on the pavements
    const double along = -70 + 140 * u01(rng), off = (u01(rng) < 0.5 ? -1 : 1) * (4.5 + u01(rng));
    const bool on_x = k % 2 == 0;
    box(on_x ? along : off, on_x ? off : along, k % 3 == 0 ? 1.5 : 0.3, k % 3 == 0 ? 1.5 : 0.3, k % 3 == 0 ? 2.5 : 5.0);
  }
  return s;
}

Eigen::Isometry3d at(double x, double y, double yaw_deg) { return pl::make_pose(x, y, 1.8, 0, 0, yaw_deg * kDeg); }

std::vector<Eigen::Vector3f> scan_at(const std::vector<Surface>& surfaces, const Eigen::Isometry3d& pose, unsigned seed) {
  // About as many points as the localizer registers of a real 16-beam scan (~2,700).
  return pl::registration::subsample(pl::test::scan_of(surfaces, pose, 1.0, 70.0, seed), 3000);
}

// The places a mapping drive along both roads would leave: every 4 m, heading along the road.
std::shared_ptr<const PlaceIndex> places_of(const std::vector<Surface>& surfaces) {
  std::vector<Place> places;
  unsigned seed = 500;
  for (double v = -60; v <= 60; v += 4.0)
    for (const Eigen::Isometry3d& p : {at(v, 0.5, 0.0), at(-0.5, v, 90.0)}) {
      Place place;
      place.position = p.translation();
      place.yaw = pl::registration::heading_of(p);
      place.descriptor = pl::registration::make_place_descriptor(scan_at(surfaces, p, seed++));
      places.push_back(place);
    }
  return std::make_shared<const PlaceIndex>(pl::registration::PlaceDescriptorConfig{}, places);
}

double error_of(const ScanReport& r, const Eigen::Isometry3d& truth) {
  return (r.fused.translation() - truth.translation()).head<2>().norm();
}

LocalizerConfig test_config() {
  LocalizerConfig cfg;
  cfg.motion.max_seeds = 400;  // test time: a coarser search round the prediction
  return cfg;
}

struct Town {
  std::vector<Surface> surfaces = town(7);
  std::vector<pl::client::MapTile> tiles = pl::test::map_tiles(surfaces, 0.4);
  std::shared_ptr<const PlaceIndex> places = places_of(surfaces);
  pl::client::TileProvider provider() const {
    return [this](const Eigen::Vector2d&, double) { return tiles; };
  }
};

const Town& the_town() {
  static const Town t;
  return t;
}

TEST(Relocalization, AKidnappingOntoACrossStreetIsReportedAndFoundAgain) {
  const Town& w = the_town();
  Localizer loc(test_config(), 20.0, w.provider());
  loc.set_places(w.places);
  std::vector<Eigen::Isometry3d> truth;
  for (int i = 0; i < 6; ++i) truth.push_back(at(-40.0 + 1.0 * i, 0.0, 0.0));
  // Carried 40 m on, onto the cross street, facing north: the clock does not show it.
  for (int i = 0; i < 7; ++i) truth.push_back(at(0.0, 22.0 + 1.0 * i, 90.0));
  loc.start(truth.front(), 0.0, nullptr);
  std::vector<ScanReport> reports;
  for (std::size_t i = 0; i < truth.size(); ++i) {
    reports.push_back(loc.process_prepared(0.1 * static_cast<double>(i), scan_at(w.surfaces, truth[i], 30u + static_cast<unsigned>(i))));
  }
  EXPECT_EQ(reports[5].health, Health::Ok) << reports[5].note;
  EXPECT_NE(reports[6].health, Health::Ok) << "the jump must be reported on the first scan after it";
  EXPECT_GT(reports[6].protection_m, 20.0);
  int back = -1;
  for (std::size_t i = 6; i < 11 && back < 0; ++i)
    if (error_of(reports[i], truth[i]) < 0.2) back = static_cast<int>(i);
  EXPECT_GE(back, 0) << "not back within five scans";
  if (back >= 0) {
    EXPECT_GT(reports[static_cast<std::size_t>(back)].place_proposals, 0) << "found without the places";
  }
  EXPECT_LT(error_of(reports.back(), truth.back()), 0.1);
  EXPECT_EQ(reports.back().health, Health::Ok) << reports.back().note;
  for (std::size_t i = 0; i < reports.size(); ++i)
    if (reports[i].health == Health::Ok) {
      EXPECT_LT(error_of(reports[i], truth[i]), 0.5) << "scan " << i << " ok while off";
      EXPECT_LE(error_of(reports[i], truth[i]), reports[i].protection_m) << "scan " << i;
    }
}

TEST(Relocalization, AGlobalStartFindsTheVehicleOrSaysItHasNot) {
  const Town& w = the_town();
  // Spread over the town, between places, off the places' line, any heading.
  const std::vector<Eigen::Isometry3d> starts = {at(-33.0, -1.0, 10.0), at(1.2, 45.0, -95.0), at(27.0, 1.0, 180.0),
                                                 at(0.8, -21.0, 60.0)};
  int found = 0;
  for (std::size_t k = 0; k < starts.size(); ++k) {
    Localizer loc(test_config(), 20.0, w.provider());
    loc.set_places(w.places);
    loc.start_global(0.0, nullptr);
    EXPECT_TRUE(loc.searching());
    // Standing still: three scans.
    for (int i = 0; i < 3; ++i) {
      const ScanReport r = loc.process_prepared(0.1 * i, scan_at(w.surfaces, starts[k], 70u + 10u * static_cast<unsigned>(k) + i));
      const double e = error_of(r, starts[k]);
      if (i == 0) {
        EXPECT_NE(r.health, Health::Ok) << "a search result is confirmed by the next scan first";
      }
      if (r.health == Health::Ok) {
        EXPECT_LT(e, 0.2) << "start " << k << " reported found " << e << " m off";
      }
      if (i == 2 && r.health == Health::Ok) ++found;
    }
  }
  EXPECT_GE(found, 3) << "of " << starts.size() << " global starts";
}

TEST(Relocalization, AScanOfAnotherTownIsNeverFound) {
  const Town& w = the_town();
  const auto elsewhere = town(99);
  Localizer loc(test_config(), 20.0, w.provider());
  loc.set_places(w.places);
  loc.start_global(0.0, nullptr);
  for (int i = 0; i < 3; ++i) {
    const ScanReport r = loc.process_prepared(0.1 * i, scan_at(elsewhere, at(-20.0, 0.0, 0.0), 90u + i));
    EXPECT_EQ(r.health, Health::Lost) << "scan " << i << ": " << r.note;
    EXPECT_FALSE(r.integrity);
  }
}

TEST(Relocalization, ARoughStartIsSearchedWithinItsRadius) {
  const Town& w = the_town();
  Localizer loc(test_config(), 20.0, w.provider());
  loc.set_places(w.places);
  const Eigen::Isometry3d truth = at(-25.0, 0.5, 3.0);
  loc.start_search(at(-21.0, -1.5, 20.0), 0.0, nullptr, 6.0, 30.0);  // 4.5 m and 17 deg off
  ScanReport r;
  for (int i = 0; i < 3; ++i) r = loc.process_prepared(0.1 * i, scan_at(w.surfaces, truth, 120u + i));
  EXPECT_EQ(r.health, Health::Ok) << r.note;
  EXPECT_LT(error_of(r, truth), 0.1);
  EXPECT_FALSE(loc.searching());
}

TEST(Relocalization, AGlobalStartNeedsPlaces) {
  const Town& w = the_town();
  Localizer loc(test_config(), 20.0, w.provider());
  try {
    loc.start_global(0.0, nullptr);
    FAIL() << "started with no places";
  } catch (const pl::Error& e) {
    EXPECT_NE(std::string(e.what()).find("pl-map build"), std::string::npos) << e.what();
  }
}

}  // namespace
