#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>

#include "pl/common/error.hpp"
#include "pl/common/stats.hpp"
#include "pl/recordings/dataset.hpp"
#include "pl/sim/lidar.hpp"
#include "pl/sim/sensors.hpp"
#include "pl/sim/simulate.hpp"
#include "pl/sim/world.hpp"
#include "test_util.hpp"

using namespace pl::sim;
using pl::test::TempDir;

namespace {

// Flat asphalt ground 200 m square and one concrete wall (a box): the ego LiDAR stands 1.73 m up.
Scene ground_and_wall(const Eigen::Vector3f& wall_centre, const Eigen::Vector3f& wall_half) {
  Scene s;
  std::vector<Primitive> prims;
  prims.push_back(make_triangle({-100, -100, 0}, {100, -100, 0}, {100, 100, 0}, 0));
  prims.push_back(make_triangle({-100, -100, 0}, {100, 100, 0}, {-100, 100, 0}, 0));
  prims.push_back(make_box(wall_centre, wall_half, 0, 1));
  s.info = {{0, Material::Asphalt}, {0, Material::Concrete}};
  s.bvh = Bvh(std::move(prims));
  return s;
}

// A straight street: a wall 10 m to the left.
Scene street() { return ground_and_wall({0, 10.25f, 5}, {60, 0.25f, 5}); }

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

// A wall across the road 20 m ahead (x = 20).
Scene wall_ahead() { return ground_and_wall({20.25f, 0, 5}, {0.25f, 40, 5}); }

TEST(SimLidar, SweepDistortsTheScanByTheMotionAndTimesEachPoint) {
  Scene s = wall_ahead();
  LidarModel h = lidar_model("vlp16");
  h.range_noise = 0.0;
  // 20 m/s forward: over the 0.1 s sweep the sensor moves 2 m.
  const auto at = [](double share) { return pl::make_pose(2.0 * share, 0, 1.73); };
  std::mt19937_64 rng(5);
  std::vector<float> shares;
  const pl::Scan swept = cast_sweep(h, at, s, nullptr, rng, &shares);
  ASSERT_EQ(shares.size(), swept.size());
  std::size_t wall = 0;
  double left = 0, right = 0;
  std::size_t n_left = 0, n_right = 0;
  for (std::size_t i = 0; i < swept.size(); ++i) {
    const auto& p = swept[i];
    // The share is the firing's azimuth: a counter-clockwise turn timed facing ahead.
    EXPECT_NEAR(shares[i], std::atan2(p.y, p.x) / (2 * M_PI), 2e-3) << i;
    if (p.x < 15 || p.z < -1.0f) continue;  // the wall's points only
    ++wall;
    // Written in the frame of its own firing: back in the world through that pose it lies on the wall.
    const Eigen::Vector3d w = at(shares[i]) * Eigen::Vector3d(p.x, p.y, p.z);
    EXPECT_NEAR(w.x(), 20.0, 0.01) << i;
    (p.y > 0 ? left : right) += p.x;
    ++(p.y > 0 ? n_left : n_right);
  }
  ASSERT_GT(wall, 500u);
  ASSERT_GT(n_left, 100u);
  ASSERT_GT(n_right, 100u);
  // The right half is fired before the scan's time (the sensor further back), the left half after:
  // the wall reads farther on the right than on the left, by up to the 2 m the sensor moved.
  EXPECT_GT(right / n_right - left / n_left, 0.25);
  // From one pose the two halves agree.
  std::mt19937_64 rng2(5);
  const pl::Scan still = cast_scan(h, at(0.0), s, nullptr, rng2);
  double l = 0, r = 0;
  std::size_t nl = 0, nr = 0;
  for (const auto& p : still) {
    if (p.x < 15 || p.z < -1.0f) continue;
    (p.y > 0 ? l : r) += p.x;
    ++(p.y > 0 ? nl : nr);
  }
  ASSERT_GT(nl, 100u);
  ASSERT_GT(nr, 100u);
  EXPECT_NEAR(l / nl - r / nr, 0.0, 0.05);
}

TEST(SimLidar, CalibrationErrorsStayInTheData) {
  // Drawn per laser, reproducible, of the stated size, none at scale 0.
  const auto e = draw_laser_errors(64, 1.0, 7);
  ASSERT_EQ(e.size(), 64u);
  std::vector<double> el, az, range;
  for (const auto& l : e) el.push_back(l.elevation_deg), az.push_back(l.azimuth_deg), range.push_back(l.range_m);
  const auto sigma = [](const std::vector<double>& v) {
    double s2 = 0;
    for (double x : v) s2 += x * x;
    return std::sqrt(s2 / static_cast<double>(v.size()));
  };
  EXPECT_NEAR(sigma(el), 0.12, 0.05);
  EXPECT_NEAR(sigma(az), 0.12, 0.05);
  EXPECT_NEAR(sigma(range), 0.02, 0.008);
  EXPECT_EQ(draw_laser_errors(64, 1.0, 7)[9].azimuth_deg, e[9].azimuth_deg);
  EXPECT_NE(draw_laser_errors(64, 1.0, 8)[9].azimuth_deg, e[9].azimuth_deg);
  for (const auto& l : draw_laser_errors(64, 0.0, 7)) EXPECT_EQ(l.elevation_deg + l.azimuth_deg + l.range_m, 0.0);

  // A laser whose ranges read 10 cm long and one pointing 0.5 deg higher than its table says: the
  // wall 10 m to the left reads 10 cm further, and the ground is seen nearer than the table expects.
  Scene s = street();
  LidarModel h = lidar_model("vlp16");
  h.range_noise = 0.0;
  h.dropout = 0.0;
  h.laser_errors.assign(h.vertical_deg.size(), LaserError{});
  h.laser_errors[3].range_m = 0.10;        // +9 deg: sees the wall
  h.laser_errors[12].elevation_deg = 0.5;  // -9 deg: sees the ground at ~11 m
  std::mt19937_64 rng(1);
  const pl::Scan scan = cast_scan(h, pl::make_pose(0, 0, 1.73), s, nullptr, rng);
  const auto rings = pl::rings_from_azimuth(scan);
  std::vector<double> wall3, ground12, ground13;
  for (std::size_t i = 0; i < scan.size(); ++i) {
    const auto& p = scan[i];
    if (std::abs(p.x) < 1 && p.y > 5 && p.z > -1.0f && rings[i] == 3) wall3.push_back(p.y);
    if (std::abs(p.y) < 2 && p.x > 0 && p.z < -1.0f && rings[i] == 12) ground12.push_back(p.z);
    if (std::abs(p.y) < 2 && p.x > 0 && p.z < -1.0f && rings[i] == 13) ground13.push_back(p.z);
  }
  ASSERT_GT(wall3.size(), 3u);
  ASSERT_GT(ground12.size(), 3u);
  ASSERT_GT(ground13.size(), 3u);
  EXPECT_NEAR(pl::median(wall3), 10.0 + 0.10 * std::cos(9.0 * M_PI / 180), 0.01);
  EXPECT_NEAR(pl::median(ground13), -1.73, 0.01);
  // Ray at -8.5 deg meets the ground at 11.6 m; the point is written along -9 deg: 1.82 m down.
  const double range12 = 1.73 / std::sin(8.5 * M_PI / 180);
  EXPECT_NEAR(pl::median(ground12), -range12 * std::sin(9.0 * M_PI / 180), 0.02);
  EXPECT_LT(pl::median(ground12), -1.78);
  h.laser_errors.resize(3);
  EXPECT_THROW(cast_scan(h, pl::make_pose(0, 0, 1.73), s, nullptr, rng), pl::Error);
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

TEST(SimWorld, ChangesBetweenEpochsListWhatDiffersAndNothingElse) {
  const SimTrajectory& t = loop();
  WorldConfig c0;
  c0.seed = 7;
  WorldConfig c1 = c0;
  c1.epoch = 1;
  const World w0 = build_world(t, 0.0, t.end_time(), c0), w1 = build_world(t, 0.0, t.end_time(), c1);
  EXPECT_TRUE(changes_between(w0, w0).empty());
  const std::vector<ObjectChange> changes = changes_between(w0, w1);
  std::map<std::uint32_t, const WorldObject*> old, now;
  for (const auto& o : w0.objects) old[o.id] = &o;
  for (const auto& o : w1.objects) now[o.id] = &o;
  std::map<ObjectChange::Kind, std::size_t> kinds;
  std::map<std::uint32_t, bool> listed;
  for (const ObjectChange& c : changes) {
    ++kinds[c.kind];
    listed[c.id] = true;
    EXPECT_TRUE(is_movable(c.cls)) << class_name(c.cls);
    EXPECT_EQ(c.has_before, c.kind != ObjectChange::Kind::Added);
    EXPECT_EQ(c.has_after, c.kind != ObjectChange::Kind::Removed);
    if (c.kind == ObjectChange::Kind::Moved) {
      EXPECT_GT((c.after.centre - c.before.centre).norm(), 1.9f);
    }
    if (c.kind == ObjectChange::Kind::Grown) {
      EXPECT_GT(c.after.half.x(), c.before.half.x());
    }
  }
  // Every thing not listed is the same in both epochs.
  for (const auto& [id, o] : old) {
    if (listed.count(id)) continue;
    ASSERT_TRUE(now.count(id)) << id;
    EXPECT_TRUE(now[id]->centre == o->centre && now[id]->half == o->half) << id;
  }
  EXPECT_GT(kinds[ObjectChange::Kind::Removed] + kinds[ObjectChange::Kind::Moved], 0u);
  EXPECT_GT(kinds[ObjectChange::Kind::Added], 0u);
  EXPECT_GT(kinds[ObjectChange::Kind::Grown], 0u);
  // The CSV: a header and a row per change, the missing footprint's columns empty.
  const std::string csv = changes_csv(changes, std::vector<std::uint64_t>(changes.size(), 5));
  EXPECT_EQ(csv.substr(0, csv.find('\n')), "id,class,change,x0,y0,half_x0,half_y0,yaw0,x1,y1,half_x1,half_y1,yaw1,rays_seeing");
  EXPECT_EQ(static_cast<std::size_t>(std::count(csv.begin(), csv.end(), '\n')), changes.size() + 1);
  EXPECT_NE(csv.find(",added,,,,,,"), std::string::npos);
  EXPECT_THROW(changes_csv(changes, {}), pl::Error);
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

// The first `frames` scans of the town loop with a VLP-16, into `out`.
SimOptions loop_drive(long long frames, const std::string& out) {
  SimOptions o;
  o.route = "loop";
  o.frames = frames;
  o.lidar = "vlp16";
  o.out_dir = out;
  return o;
}

TEST(SimDrive, SameSeedSameBytesWhateverTheThreads) {
  TempDir dir;
  SimOptions o = loop_drive(4, dir / "a");
  o.traffic.count = 6;
  o.threads = 1;
  simulate(o);
  o.out_dir = dir / "b";
  o.threads = 3;
  simulate(o);
  for (const char* f : {"velodyne/000000.bin", "velodyne/000003.bin", "point_times/000003.bin", "poses.txt", "times.txt",
                        "encoder.csv", "gps.csv", "meta.json"})
    EXPECT_EQ(pl::test::read_file(dir / (std::string("a/") + f)), pl::test::read_file(dir / (std::string("b/") + f))) << f;
  o.out_dir = dir / "c";
  o.world.seed = 2;
  simulate(o);
  EXPECT_NE(pl::test::read_file(dir / "a/velodyne/000000.bin"), pl::test::read_file(dir / "c/velodyne/000000.bin"));
  // Another drive in the same world (another vehicle, another day): other traffic and noise, the
  // same things; the drive seed given as the world's is the default.
  o.world.seed = 1;
  o.drive_seed = 1;
  o.out_dir = dir / "d";
  simulate(o);
  EXPECT_EQ(pl::test::read_file(dir / "a/velodyne/000003.bin"), pl::test::read_file(dir / "d/velodyne/000003.bin"));
  o.drive_seed = 5;
  o.out_dir = dir / "e";
  simulate(o);
  EXPECT_NE(pl::test::read_file(dir / "a/velodyne/000003.bin"), pl::test::read_file(dir / "e/velodyne/000003.bin"));
  const std::string objects_a = pl::test::read_file(dir / "a/objects.csv"), objects_e = pl::test::read_file(dir / "e/objects.csv");
  EXPECT_EQ(objects_a.substr(0, objects_a.find('\n')), "id,class,x,y,half_x,half_y,yaw,base,height,returns,returns_40m");
  EXPECT_EQ(std::count(objects_a.begin(), objects_a.end(), '\n'), std::count(objects_e.begin(), objects_e.end(), '\n'));
  EXPECT_FALSE(std::filesystem::exists(dir / "a/changes.csv")) << "epoch 0 has no changes";
  // The dataset reader takes it as is.
  pl::Dataset ds = pl::open_dataset(dir / "a");
  EXPECT_EQ(ds.size(), 4u);
  EXPECT_EQ(ds.meta.sensor.beams, 16);
  EXPECT_EQ(ds.ground_truth.size(), 4u);
  EXPECT_FALSE(ds.encoder.empty());
  EXPECT_FALSE(ds.gps.empty());
  ASSERT_TRUE(ds.meta.origin.has_value());
  // Each point's time, as a driver gives it: within the 0.1 s sweep, from the azimuth.
  ASSERT_FALSE(ds.point_times_dir.empty());
  const pl::Scan scan = ds.load_scan(2);
  const std::vector<float> times = ds.load_point_times(2, scan.size());
  ASSERT_EQ(times.size(), scan.size());
  for (std::size_t i = 0; i < scan.size(); i += 97)
    EXPECT_NEAR(times[i], 0.1 * std::atan2(scan[i].y, scan[i].x) / (2 * M_PI), 0.002) << i;
  // An existing dataset is not overwritten without --force.
  EXPECT_THROW(simulate(o), pl::Error);
  o.force = true;
  EXPECT_NO_THROW(simulate(o));
}

TEST(SimTruth, AnInsTruthWandersAsConfiguredAndTheExactOneDoesNot) {
  // A straight drive at 10 m/s, 10 Hz, for an hour: long enough for the processes' statistics.
  std::vector<pl::Pose, Eigen::aligned_allocator<pl::Pose>> truth;
  std::vector<double> times;
  for (int i = 0; i < 36000; ++i) {
    times.push_back(0.1 * i);
    truth.push_back(pl::make_pose(1.0 * i, 0.0, 0.0, 0, 0, 0.0));
  }
  TruthErrorConfig cfg;
  EXPECT_EQ(ins_truth(truth, times, cfg, 1).back().matrix(), truth.back().matrix());  // scale 0: exact
  cfg.scale = 1.0;
  const auto ins = ins_truth(truth, times, cfg, 1);
  ASSERT_EQ(ins.size(), truth.size());
  std::vector<double> along, across, height, step;
  for (std::size_t i = 0; i < ins.size(); ++i) {
    const Eigen::Vector3d e = ins[i].translation() - truth[i].translation();
    along.push_back(e.x() - cfg.along_share * 1.0 * static_cast<double>(i));  // the wander: less the 3 % short
    across.push_back(e.y()), height.push_back(e.z());
    if (i) step.push_back(along[i] - along[i - 1]);
  }
  const auto rms = [](const std::vector<double>& v) {
    double s = 0;
    for (double x : v) s += x * x;
    return std::sqrt(s / static_cast<double>(v.size()));
  };
  EXPECT_NEAR(rms(height), cfg.height_m, 0.2 * cfg.height_m);
  EXPECT_NEAR(rms(across), cfg.across_m, 0.25 * cfg.across_m);
  EXPECT_NEAR(rms(along), cfg.along_m, 0.3 * cfg.along_m);  // 10 s: fewer independent samples
  // From one scan to the next the along-track error moves smoothly (0.1 s / 10 s of its size) plus
  // the jitter, twice: centimetres, not the decimetres a rough process of that size would jump.
  EXPECT_NEAR(rms(step), std::sqrt(2.0 * cfg.jitter_m * cfg.jitter_m + std::pow(0.1 / cfg.along_s * cfg.along_m, 2)), 0.005);
  // The height wanders smoothly: a second apart the errors correlate as (1 + 1/tau) exp(-1/tau).
  double c = 0, n = 0;
  for (std::size_t i = 10; i < height.size(); ++i) c += height[i] * height[i - 10], n += height[i - 10] * height[i - 10];
  EXPECT_NEAR(c / n, (1.0 + 1.0 / cfg.height_s) * std::exp(-1.0 / cfg.height_s), 0.05);
  // Along the track it runs 3 % short of the distance travelled, as drive 0005's truth does.
  EXPECT_NEAR(ins.back().translation().x() / truth.back().translation().x(), 1.0 + cfg.along_share, 0.001);
  // The same seed gives the same truth; another seed another one.
  EXPECT_EQ(ins_truth(truth, times, cfg, 1)[500].matrix(), ins[500].matrix());
  EXPECT_NE(ins_truth(truth, times, cfg, 2)[500].matrix(), ins[500].matrix());
  cfg.scale = -1.0;
  EXPECT_THROW(ins_truth(truth, times, cfg, 1), pl::Error);
}

TEST(SimDrive, AnInsTruthChangesThePosesWrittenAndNotTheScans) {
  TempDir dir;
  SimOptions o = loop_drive(5, dir / "exact");
  simulate(o);
  o.out_dir = dir / "ins";
  o.truth.scale = 1.0;
  simulate(o);
  EXPECT_EQ(pl::test::read_file(dir / "exact/velodyne/000004.bin"), pl::test::read_file(dir / "ins/velodyne/000004.bin"));
  const pl::Dataset a = pl::open_dataset(dir / "exact"), b = pl::open_dataset(dir / "ins");
  ASSERT_EQ(b.ground_truth.size(), 5u);
  double largest = 0;
  for (std::size_t i = 0; i < 5; ++i)
    largest = std::max(largest, (a.ground_truth.poses[i].translation() - b.ground_truth.poses[i].translation()).norm());
  EXPECT_GT(largest, 0.005);
  EXPECT_LT(largest, 3.0);
}

TEST(SimDrive, SpeedScaleDrivesTheRouteFasterAtTheSameScanRate) {
  TempDir dir;
  SimOptions o = loop_drive(6, dir / "slow");
  const SimReport slow = simulate(o);
  o.out_dir = dir / "fast";
  o.speed_scale = 3.0;
  const SimReport fast = simulate(o);
  EXPECT_NEAR(fast.max_speed_mps, 3.0 * slow.max_speed_mps, 1e-6 * slow.max_speed_mps);
  EXPECT_GT(fast.max_speed_mps, 25.0);  // the loop's 9 m/s straights at 27 m/s
  const pl::Dataset a = pl::open_dataset(dir / "slow"), b = pl::open_dataset(dir / "fast");
  ASSERT_EQ(a.size(), 6u);
  ASSERT_EQ(b.size(), 6u);
  for (std::size_t i = 1; i < 6; ++i) {
    EXPECT_NEAR(b.times[i] - b.times[i - 1], 0.1, 1e-6);
    const double da = (a.ground_truth.poses[i].translation() - a.ground_truth.poses[i - 1].translation()).norm();
    const double db = (b.ground_truth.poses[i].translation() - b.ground_truth.poses[i - 1].translation()).norm();
    EXPECT_NEAR(db, 3.0 * da, 0.02 * da) << i;
  }
  o.speed_scale = 0.0;
  o.out_dir = dir / "none";
  EXPECT_THROW(simulate(o), pl::Error);
}

// objects.csv without the last two columns (the returns this drive got): the world's things.
std::vector<std::string> object_rows(const std::string& csv) {
  std::vector<std::string> rows;
  std::size_t at = 0;
  while (at < csv.size()) {
    const std::size_t end = std::min(csv.find('\n', at), csv.size());
    std::string row = csv.substr(at, end - at);
    for (int k = 0; k < 2; ++k) row = row.substr(0, row.rfind(','));
    rows.push_back(row);
    at = end + 1;
  }
  return rows;
}

TEST(SimDrive, ReverseDrivesTheSameStretchBackThroughTheSameWorld) {
  TempDir dir;
  SimOptions o = loop_drive(20, dir / "fwd");
  o.map_out = dir / "fwd.pcd";
  o.map_spacing = 0.5;
  simulate(o);
  auto r = pl::test::run(pl::test::tool("pl-sim") + " --route loop --frames 20 --lidar vlp16 --reverse --out " + (dir / "rev") +
                         " --map-out " + (dir / "rev.pcd") + " --map-spacing 0.5");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  // The same world: the same things in the same places, the same reference cloud.
  const auto fwd_objects = object_rows(pl::test::read_file(dir / "fwd/objects.csv"));
  EXPECT_GT(fwd_objects.size(), 100u);
  EXPECT_EQ(fwd_objects, object_rows(pl::test::read_file(dir / "rev/objects.csv")));
  EXPECT_EQ(pl::test::read_file(dir / "fwd.pcd"), pl::test::read_file(dir / "rev.pcd"));
  const pl::Dataset a = pl::open_dataset(dir / "fwd"), b = pl::open_dataset(dir / "rev");
  ASSERT_EQ(b.size(), 20u);
  ASSERT_EQ(b.ground_truth.size(), 20u);
  EXPECT_EQ(b.times.front(), 0.0);
  // It starts where the forward drive ends; every pose lies on the forward path, the LiDAR as high
  // and as upright, facing the other way.
  EXPECT_LT((b.ground_truth.poses.front().translation() - a.ground_truth.poses.back().translation()).norm(), 0.01);
  EXPECT_LT((b.ground_truth.poses.back().translation() - a.ground_truth.poses.front().translation()).norm(), 0.01);
  for (std::size_t i = 0; i < b.size(); ++i) {
    const pl::Pose& p = b.ground_truth.poses[i];
    std::size_t nearest = 0;
    for (std::size_t j = 1; j < a.size(); ++j)
      if ((a.ground_truth.poses[j].translation() - p.translation()).norm() <
          (a.ground_truth.poses[nearest].translation() - p.translation()).norm())
        nearest = j;
    const pl::Pose& q = a.ground_truth.poses[nearest];
    EXPECT_LT((q.translation() - p.translation()).norm(), 0.03) << i;
    EXPECT_NEAR(std::abs(std::remainder(pl::yaw_of(p) - pl::yaw_of(q), 2 * M_PI)), M_PI, 1e-3) << i;
    EXPECT_GT(p.linear().col(2).dot(q.linear().col(2)), 1.0 - 1e-6) << i;
    if (i + 1 < b.size()) {  // moving forward in its own frame, 0.1 s apart
      EXPECT_GT((b.ground_truth.poses[i + 1].translation() - p.translation()).dot(p.linear().col(0)), 0.3) << i;
      EXPECT_NEAR(b.times[i + 1] - b.times[i], 0.1, 1e-6) << i;
    }
    if (i % 6 == 0) {
      EXPECT_GT(b.load_scan(i).size(), 5000u) << i;
    }
  }
  // The wheels turn forwards.
  ASSERT_FALSE(b.encoder.empty());
  EXPECT_GT(b.encoder.back().left_m, 5.0);
  EXPECT_GT(b.encoder.back().right_m, 5.0);
}

TEST(SimTraffic, ReversedTrafficKeepsItsLanesRelativeToTheEgoVehicle) {
  // Leads in the ego lane (on the path), oncoming vehicles 3 m to the ego's left: on the forward
  // path's right when the route is driven the other way, moving the way the forward route does.
  const SimTrajectory back = loop().reversed();
  TrafficConfig cfg;
  cfg.count = 40;
  cfg.pedestrian_share = 0.0;
  const Traffic traffic(back, back.start_time(), back.end_time(), cfg);
  const auto& fwd = loop().poses();
  const auto nearest = [&](const Eigen::Vector2f& c) {  // the forward pose nearest to c
    std::size_t n = 0;
    for (std::size_t j = 1; j < fwd.size(); ++j)
      if ((fwd[j].translation().head<2>() - c.cast<double>()).squaredNorm() <
          (fwd[n].translation().head<2>() - c.cast<double>()).squaredNorm())
        n = j;
    return fwd[n];
  };
  int leads = 0, oncoming = 0;
  for (double t : {20.0, 45.0}) {
    const auto now = traffic.positions_at(t), later = traffic.positions_at(t + 0.5);
    ASSERT_EQ(now.size(), later.size());
    const pl::Pose ego = back.pose_at(t);
    for (std::size_t k = 0; k < now.size(); ++k) {
      const pl::Pose on = nearest(now[k]);
      const Eigen::Vector2d f = on.linear().col(0).head<2>().normalized(), left(-f.y(), f.x());
      const double lateral = (now[k].cast<double>() - on.translation().head<2>()).dot(left);
      const double along = (later[k] - now[k]).cast<double>().dot(f);
      const bool lead = (now[k].cast<double>() - ego.translation().head<2>()).norm() < 30.0 && std::abs(lateral) < 0.3;
      if (lead) {
        ++leads;
        EXPECT_LT(along, 0.0) << "a lead drives with the ego vehicle, against the forward route";
      } else {
        ++oncoming;
        EXPECT_NEAR(lateral, -3.0, 0.3) << "oncoming: the ego's left, the forward route's right";
        EXPECT_GT(along, 0.0) << "oncoming: towards the ego vehicle, the forward route's way";
      }
    }
  }
  EXPECT_GT(oncoming, 10);
  EXPECT_GT(leads, 0);
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
  // Six months later, another vehicle: what changed, with the rays of this drive that saw it.
  auto later = pl::test::run(pl::test::tool("pl-sim") + " --route loop --frames 30 --lidar vlp16 --epoch 1 --drive-seed 3 --out " +
                             (dir / "l"));
  ASSERT_EQ(later.exit_code, 0) << later.output;
  EXPECT_NE(later.output.find("changed since epoch 0:"), std::string::npos) << later.output;
  const std::string changes = pl::test::read_file(dir / "l/changes.csv");
  EXPECT_EQ(changes.rfind("id,class,change,", 0), 0u);
  EXPECT_GT(std::count(changes.begin(), changes.end(), '\n'), 5);
  const std::string seen = pl::test::read_file(dir / "l/changes_seen.csv");
  EXPECT_EQ(seen.rfind("id,x,y,rays\n", 0), 0u);
  EXPECT_GT(std::count(seen.begin(), seen.end(), '\n'), 1) << "30 scans saw some change";
  auto bad = pl::test::run(pl::test::tool("pl-sim") + " --route ring --out " + (dir / "e"));
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_NE(bad.output.find("--route takes loop or estate"), std::string::npos) << bad.output;
  auto both = pl::test::run(pl::test::tool("pl-sim") + " --out " + (dir / "e"));
  EXPECT_NE(both.output.find("either --route"), std::string::npos) << both.output;
  EXPECT_FALSE(std::filesystem::exists(dir / "e"));
}
