#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <map>

#include "pl/common/dataset.hpp"
#include "pl/common/error.hpp"
#include "pl/common/stats.hpp"
#include "pl/sim/lidar.hpp"
#include "pl/sim/sensors.hpp"
#include "pl/sim/simulate.hpp"
#include "pl/sim/world.hpp"
#include "test_util.hpp"

using namespace pl::sim;
using pl::test::TempDir;

namespace {

// A straight street: ground, a wall 10 m to the left, and the ego LiDAR 1.73 m up.
Scene street() {
  Scene s;
  std::vector<Primitive> prims;
  prims.push_back(make_triangle({-100, -100, 0}, {100, -100, 0}, {100, 100, 0}, 0));
  prims.push_back(make_triangle({-100, -100, 0}, {100, 100, 0}, {-100, 100, 0}, 0));
  prims.push_back(make_box({0, 10.25f, 5}, {60, 0.25f, 5}, 0, 1));
  s.info = {{0, Material::Asphalt}, {0, Material::Concrete}};
  s.bvh = Bvh(std::move(prims));
  return s;
}

const SimTrajectory& loop() {
  static SimTrajectory t = builtin_route("loop");
  return t;
}

}  // namespace

TEST(SimLidar, BeamTables) {
  LidarModel h = lidar_model("hdl64");
  ASSERT_EQ(h.vertical_deg.size(), 64u);
  EXPECT_DOUBLE_EQ(h.vertical_deg.front(), 2.0);
  EXPECT_NEAR(h.vertical_deg.back(), -24.33, 0.01);
  for (std::size_t i = 1; i < 64; ++i) EXPECT_LT(h.vertical_deg[i], h.vertical_deg[i - 1]);
  for (const char* name : {"vlp16", "rs16"}) {
    LidarModel v = lidar_model(name);
    ASSERT_EQ(v.vertical_deg.size(), 16u);
    EXPECT_DOUBLE_EQ(v.vertical_deg.front(), 15.0);
    EXPECT_DOUBLE_EQ(v.vertical_deg.back(), -15.0);
  }
  EXPECT_THROW(lidar_model("hdl32"), pl::Error);
}

TEST(SimLidar, ScanGeometryNoiseAndRings) {
  Scene s = street();
  LidarModel h = lidar_model("hdl64");
  std::mt19937_64 rng(3);
  pl::Scan scan = cast_scan(h, pl::make_pose(0, 0, 1.73), s, nullptr, rng);
  ASSERT_GT(scan.size(), 60000u);
  // Points on the wall (y ~ 10) scatter by the 2 cm range noise; ground points sit at z = -1.73.
  double sum = 0, sum2 = 0;
  std::size_t wall = 0, ground = 0;
  for (const auto& p : scan) {
    if (std::abs(p.x) < 3 && p.y > 9 && p.z > -1.0f) {
      double e = p.y - 10.0;
      sum += e, sum2 += e * e, ++wall;
    }
    if (std::abs(p.z + 1.73f) < 0.1f) ++ground;
  }
  ASSERT_GT(wall, 200u);
  EXPECT_NEAR(sum / wall, 0.0, 0.005);
  EXPECT_NEAR(std::sqrt(sum2 / wall), 0.02, 0.006);
  EXPECT_GT(ground, 30000u);
  // Stored laser by laser like KITTI: the azimuth-wrap ring finder recovers the beams, and each
  // ring's elevation matches the beam table.
  auto rings = pl::rings_from_azimuth(scan);
  std::map<int, std::vector<double>> el;
  for (std::size_t i = 0; i < scan.size(); ++i)
    el[rings[i]].push_back(std::atan2(scan[i].z, std::hypot(scan[i].x, scan[i].y)) * 180.0 / M_PI);
  EXPECT_EQ(el.size(), 64u);
  for (const auto& [r, v] : el) EXPECT_NEAR(pl::median(v), h.vertical_deg[r], 0.05) << r;
}

TEST(SimLidar, HalfFieldOfViewBlocksTheRear) {
  Scene s = street();
  LidarModel h = lidar_model("vlp16");
  h.fov_deg = 180;
  std::mt19937_64 rng(1);
  pl::Scan scan = cast_scan(h, pl::make_pose(0, 0, 1.73), s, nullptr, rng);
  ASSERT_GT(scan.size(), 1000u);
  for (const auto& p : scan) EXPECT_GE(p.x, -1e-3f);
}

TEST(SimEncoder, IntegratesBackToTheGroundTruth) {
  const SimTrajectory& t = loop();
  double t1 = std::min(t.end_time(), 40.0);
  for (bool perfect : {true, false}) {
    EncoderConfig cfg;
    if (perfect) cfg.scale_left = cfg.scale_right = 1.0, cfg.slip = 0.0;
    auto enc = simulate_encoder(t, 0.0, t1, cfg);
    ASSERT_EQ(enc.size(), static_cast<std::size_t>(std::round(t1 * 100)) + 1);
    // Differential drive: d = (dl + dr) / 2, dtheta = (dr - dl) / L, from the first pose.
    pl::Pose start = t.pose_at(0.0);
    double x = start.translation().x(), y = start.translation().y(), th = pl::yaw_of(start);
    for (std::size_t k = 1; k < enc.size(); ++k) {
      double dl = enc[k].left_m - enc[k - 1].left_m, dr = enc[k].right_m - enc[k - 1].right_m;
      double d = 0.5 * (dl + dr), dth = (dr - dl) / cfg.wheel_base;
      x += d * std::cos(th + 0.5 * dth), y += d * std::sin(th + 0.5 * dth), th += dth;
    }
    pl::Pose end = t.pose_at(t1);
    double dist = t.distance_at(t1);
    double err = std::hypot(x - end.translation().x(), y - end.translation().y());
    double yaw_err = std::abs(std::remainder(th - pl::yaw_of(end), 2 * M_PI));
    // Quantization alone (1.3 cm counts): the heading error stays below two counts over the wheel base.
    if (perfect) {
      EXPECT_LT(err, 0.01 * dist) << err << " m over " << dist << " m";
      EXPECT_LT(yaw_err, 2.0 * encoder_resolution(cfg) / cfg.wheel_base + 1e-9);
    } else {
      // Wheel-size errors (+0.3 % and +0.25 %) and slip in the turns: the path drifts, by metres
      // at most over a few hundred metres.
      EXPECT_GT(err, 0.01);
      EXPECT_LT(err, 0.05 * dist);
      EXPECT_LT(yaw_err, 0.2);
    }
  }
}

TEST(SimGps, NoiseMatchesTheStatus) {
  const SimTrajectory& t = loop();
  WorldConfig wc;
  World w = build_world(t, 0.0, t.end_time(), wc);
  pl::EnuFrame enu({49.0, 8.4, 100.0});
  GpsConfig cfg;
  std::mt19937_64 rng(5);
  auto fixes = simulate_gps(t, 0.0, t.end_time(), w, enu, cfg, rng);
  ASSERT_GT(fixes.size(), 100u);
  double fixed2 = 0;
  std::size_t nfixed = 0, outliers = 0;
  std::map<int, std::size_t> mix;
  for (const auto& f : fixes) {
    ++mix[f.status];
    Eigen::Vector3d truth = t.pose_at(f.t) * cfg.lever_arm;
    Eigen::Vector3d e = enu.to_enu(f.position) - truth;
    if (f.status == pl::kGpsFixed) fixed2 += e.head<2>().squaredNorm(), ++nfixed;
    outliers += e.head<2>().norm() > 1.9 && e.head<2>().norm() > 5 * f.std_m;  // multipath: metres off, sigma as usual
    EXPECT_GT(f.std_m, 0.0);
  }
  ASSERT_GT(nfixed, 100u);
  // rtk-fixed: 2 cm per horizontal axis, so ~2.8 cm horizontally.
  EXPECT_NEAR(std::sqrt(fixed2 / nfixed), 0.02 * std::sqrt(2.0), 0.006);
  EXPECT_GE(mix.size(), 3u) << "the town should degrade the receiver somewhere";
  EXPECT_GT(outliers, 0u) << "no multipath near the tall buildings";
  // Outages: a drive of N seconds at 10 Hz would have 10 N fixes.
  EXPECT_LT(fixes.size(), static_cast<std::size_t>(t.end_time() * 10.0));
}

TEST(SimWorld, EpochOneChangesTheMovableShareAndNothingStatic) {
  const SimTrajectory& t = loop();
  WorldConfig c0;
  c0.seed = 7;
  WorldConfig c1 = c0;
  c1.epoch = 1;
  World w0 = build_world(t, 0.0, t.end_time(), c0), w1 = build_world(t, 0.0, t.end_time(), c1);
  std::map<std::uint32_t, const WorldObject*> by_id;
  for (const auto& o : w1.objects) by_id[o.id] = &o;
  auto same = [](const WorldObject& a, const WorldObject& b) {
    if (a.shapes.size() != b.shapes.size() || a.cls != b.cls) return false;
    for (std::size_t k = 0; k < a.shapes.size(); ++k)
      if (!a.shapes[k].a.isApprox(b.shapes[k].a) || !a.shapes[k].b.isApprox(b.shapes[k].b)) return false;
    return true;
  };
  std::size_t movable = 0, changed = 0, statics = 0;
  for (const auto& o : w0.objects) {
    auto it = by_id.find(o.id);
    if (!is_movable(o.cls)) {
      ++statics;
      ASSERT_NE(it, by_id.end()) << class_name(o.cls) << " " << o.id << " vanished";
      EXPECT_TRUE(same(o, *it->second)) << class_name(o.cls) << " " << o.id << " changed";
      continue;
    }
    ++movable;
    if (it == by_id.end() || !same(o, *it->second)) ++changed;
  }
  std::size_t added = 0;
  std::map<std::uint32_t, bool> ids0;
  for (const auto& o : w0.objects) ids0[o.id] = true;
  for (const auto& o : w1.objects) added += !ids0.count(o.id);
  ASSERT_GT(movable, 50u);
  EXPECT_GT(statics, 100u);
  double share = static_cast<double>(changed + added) / static_cast<double>(movable);
  EXPECT_NEAR(share, 0.15, 0.03) << changed << " changed, " << added << " added of " << movable;
  EXPECT_GT(added, 0u);
}

TEST(SimWorld, SameSeedSameWorldOtherSeedOtherWorld) {
  const SimTrajectory& t = loop();
  WorldConfig c;
  World a = build_world(t, 0.0, 30.0, c), b = build_world(t, 0.0, 30.0, c);
  ASSERT_EQ(a.objects.size(), b.objects.size());
  for (std::size_t i = 0; i < a.objects.size(); ++i) ASSERT_TRUE(a.objects[i].centre == b.objects[i].centre);
  c.seed = 2;
  World d = build_world(t, 0.0, 30.0, c);
  bool differs = d.objects.size() != a.objects.size();
  for (std::size_t i = 0; !differs && i < a.objects.size(); ++i) differs = !(a.objects[i].centre == d.objects[i].centre);
  EXPECT_TRUE(differs);
}

TEST(SimDrive, SameSeedSameBytesWhateverTheThreads) {
  TempDir dir;
  SimOptions o;
  o.route = "loop";
  o.frames = 4;
  o.lidar = "vlp16";
  o.traffic.count = 6;
  o.out_dir = dir / "a";
  o.threads = 1;
  simulate(o);
  o.out_dir = dir / "b";
  o.threads = 3;
  simulate(o);
  for (const char* f : {"velodyne/000000.bin", "velodyne/000003.bin", "poses.txt", "times.txt", "encoder.csv", "gps.csv", "meta.json"})
    EXPECT_EQ(pl::test::read_file(dir / (std::string("a/") + f)), pl::test::read_file(dir / (std::string("b/") + f))) << f;
  o.out_dir = dir / "c";
  o.world.seed = 2;
  simulate(o);
  EXPECT_NE(pl::test::read_file(dir / "a/velodyne/000000.bin"), pl::test::read_file(dir / "c/velodyne/000000.bin"));
  // The dataset reader takes it as is.
  pl::Dataset ds = pl::open_dataset(dir / "a");
  EXPECT_EQ(ds.size(), 4u);
  EXPECT_EQ(ds.meta.sensor.beams, 16);
  EXPECT_EQ(ds.ground_truth.size(), 4u);
  EXPECT_FALSE(ds.encoder.empty());
  EXPECT_FALSE(ds.gps.empty());
  ASSERT_TRUE(ds.meta.origin.has_value());
  // An existing dataset is not overwritten without --force.
  EXPECT_THROW(simulate(o), pl::Error);
  o.force = true;
  EXPECT_NO_THROW(simulate(o));
}

TEST(SimDrive, CommandLine) {
  TempDir dir;
  auto r = pl::test::run(pl::test::tool("pl-sim") + " --route loop --frames 30 --lidar rs16 --fov 180 --out " + (dir / "d") +
                         " --preview " + (dir / "p.svg") + " --map-out " + (dir / "m.pcd") + " --map-spacing 0.5");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("wrote 30 scans"), std::string::npos) << r.output;
  std::string svg = pl::test::read_file(dir / "p.svg");
  EXPECT_EQ(svg.rfind("<svg", 0), 0u);
  EXPECT_NE(svg.find("building"), std::string::npos);
  std::string pcd = pl::test::read_file(dir / "m.pcd");
  EXPECT_NE(pcd.find("FIELDS x y z intensity"), std::string::npos);
  auto info = pl::test::run(pl::test::tool("pl-dataset") + " info " + (dir / "d"));
  EXPECT_EQ(info.exit_code, 0) << info.output;
  EXPECT_NE(info.output.find("RS-LiDAR-16, 16 in the table; rings found per scan: median 16"), std::string::npos) << info.output;
  auto bad = pl::test::run(pl::test::tool("pl-sim") + " --route ring --out " + (dir / "e"));
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_NE(bad.output.find("--route takes loop or estate"), std::string::npos) << bad.output;
  auto both = pl::test::run(pl::test::tool("pl-sim") + " --out " + (dir / "e"));
  EXPECT_NE(both.output.find("either --route"), std::string::npos) << both.output;
  EXPECT_FALSE(std::filesystem::exists(dir / "e"));
}
