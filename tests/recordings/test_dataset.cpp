#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "pl/common/cloud_io.hpp"
#include "pl/common/error.hpp"
#include "pl/recordings/dataset.hpp"
#include "error_of.hpp"
#include "test_util.hpp"

using pl::test::TempDir;
using pl::test::write_file;

namespace {

std::string kitti_line(const pl::Pose& p) {
  std::string s;
  char buf[64];
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c) {
      std::snprintf(buf, sizeof(buf), "%.12g%s", p.matrix()(r, c), (r == 2 && c == 3) ? "\n" : " ");
      s += buf;
    }
  return s;
}

std::string error_of(const std::string& dir) {
  try {
    pl::open_dataset(dir);
  } catch (const pl::Error& e) {
    return e.what();
  }
  return "(no error)";
}

// Whether an error message says what it should; on failure the test shows both.
testing::AssertionResult contains(const std::string& message, const std::string& part) {
  if (message.find(part) != std::string::npos) return testing::AssertionSuccess();
  return testing::AssertionFailure() << "the message \"" << message << "\"\ndoes not contain \"" << part << "\"";
}

pl::Scan small_scan(float shift) { return {{1.f + shift, 2.f, 3.f, 0.5f}, {4.f, 5.f, 6.f, 0.25f}}; }

// A KITTI raw drive of n frames on a curve near Karlsruhe, with varying roll/pitch/yaw.
void write_raw_drive(const std::string& dir, int n) {
  write_file(dir + "/calib_imu_to_velo.txt",
             "calib_time: 25-May-2012 16:47:16\n"
             "R: 9.999976e-01 7.553071e-04 -2.035826e-03 -7.854027e-04 9.998898e-01 -1.482298e-02 2.024406e-03 "
             "1.482454e-02 9.998881e-01\nT: -8.086759e-01 3.195559e-01 -7.997231e-01\n");
  std::string stamps;
  for (int i = 0; i < n; ++i) {
    double a = 0.05 * i;
    double lat = 49.0112128 + 0.0004 * std::sin(a), lon = 8.4228850 + 0.0006 * (1 - std::cos(a));
    double alt = 112.8 + 0.05 * i, roll = 0.01 * std::sin(3 * a), pitch = -0.02 * std::cos(2 * a), yaw = -1.2 + a;
    char line[512];
    int posmode = i < n / 2 ? 6 : (i % 3 == 0 ? 4 : 5);
    std::snprintf(line, sizeof(line),
                  "%.12f %.12f %.6f %.9f %.9f %.9f 1 2 10 0 0 0 0 9.8 0 0 9.8 0 0 0.1 0 0 0.1 %.3f 0.05 4 10 %d 4 0\n",
                  lat, lon, alt, roll, pitch, yaw, 0.02 + 0.01 * i, posmode);
    char name[64];
    std::snprintf(name, sizeof(name), "/oxts/data/%010d.txt", i);
    write_file(dir + name, line);
    std::snprintf(name, sizeof(name), "/velodyne_points/data/%010d.bin", i);
    std::filesystem::create_directories(dir + "/velodyne_points/data");
    pl::write_kitti_bin(dir + name, small_scan(static_cast<float>(i)));
    // Crosses midnight halfway: the times must still increase by 0.1 s.
    std::snprintf(line, sizeof(line), "2011-09-26 23:59:%012.9f\n", 59.0 + 0.1 * i);
    if (59.0 + 0.1 * i >= 60.0) std::snprintf(line, sizeof(line), "2011-09-27 00:00:%012.9f\n", 59.0 + 0.1 * i - 60.0);
    stamps += line;
  }
  write_file(dir + "/oxts/timestamps.txt", stamps);
}

}  // namespace

TEST(Dataset, OdometryLayoutConvertsCam0PosesToLidar) {
  TempDir dir;
  pl::write_kitti_bin(dir / "velodyne/000000.bin", (std::filesystem::create_directories(dir / "velodyne"), small_scan(0)));
  pl::write_kitti_bin(dir / "velodyne/000002.bin", small_scan(1));
  write_file(dir / "times.txt", "0\n0.1\n0.2\n");
  pl::Pose p0 = pl::make_pose(0, 0, 0), p1 = pl::make_pose(0.1, 0, 1, 0, 0.01, 0), p2 = pl::make_pose(0.3, -0.1, 2.5, 0.02, -0.05, 0.01);
  write_file(dir / "poses.txt", kitti_line(p0) + kitti_line(p1) + kitti_line(p2));
  pl::Dataset plain = pl::open_dataset(dir.path());
  ASSERT_EQ(plain.size(), 2u);
  EXPECT_EQ(plain.frame_ids[1], 2);
  EXPECT_DOUBLE_EQ(plain.times[1], 0.2);
  EXPECT_TRUE(plain.ground_truth.poses[1].isApprox(p2, 1e-9));  // no calib.txt: poses are LiDAR poses already

  // With calib.txt the poses are cam0 poses: LiDAR pose = Tr^-1 P Tr.
  pl::Pose tr = pl::Pose::Identity();
  tr.linear() << 0, -1, 0, 0, 0, -1, 1, 0, 0;  // x_cam = -y_velo, y_cam = -z_velo, z_cam = x_velo
  tr.translation() = Eigen::Vector3d(-0.01, -0.05, -0.29);
  std::string trs = kitti_line(tr);
  write_file(dir / "calib.txt", "P0: 1 0 0 0 0 1 0 0 0 0 1 0\nTr: " + trs);
  pl::Dataset ds = pl::open_dataset(dir.path());
  pl::Pose expected = tr.inverse() * p2 * tr;
  EXPECT_TRUE(ds.ground_truth.poses[1].isApprox(expected, 1e-9));
  // The camera's forward (z) motion becomes the LiDAR's forward (x) motion.
  EXPECT_NEAR(ds.ground_truth.poses[1].translation().x() - ds.ground_truth.poses[0].translation().x(), 2.5, 0.1);
  pl::Scan s = ds.load_scan(1);
  EXPECT_EQ(s[0].x, 2.f);
}

TEST(Dataset, OdometryLayoutErrorsNameTheFile) {
  TempDir dir;
  std::filesystem::create_directories(dir / "velodyne");
  EXPECT_NE(error_of(dir.path()).find("no .bin scans"), std::string::npos);
  write_file(dir / "velodyne/000000.bin.xz", "x");
  EXPECT_NE(error_of(dir.path()).find("unpack.sh"), std::string::npos);
  pl::write_kitti_bin(dir / "velodyne/000000.bin", small_scan(0));
  pl::write_kitti_bin(dir / "velodyne/000005.bin", small_scan(0));
  EXPECT_NE(error_of(dir.path()).find("times.txt: missing"), std::string::npos);
  write_file(dir / "times.txt", "0\n0.1\n");
  EXPECT_NE(error_of(dir.path()).find("needs line 6"), std::string::npos);
  write_file(dir / "times.txt", "0\n0.1\n0.2\nfoo\n0.4\n0.5\n");
  EXPECT_NE(error_of(dir.path()).find("times.txt:4"), std::string::npos);
  write_file(dir / "times.txt", "0\n0.1\n0.2\n0.3\n0.4\n0.5\n");
  write_file(dir / "poses.txt", "1 0 0 0 0 1 0 0 0 0 1 0\n");
  EXPECT_NE(error_of(dir.path()).find("poses.txt: has 1 poses"), std::string::npos);
  std::filesystem::remove(dir / "poses.txt");
  write_file(dir / "velodyne/abc.bin", "");
  EXPECT_NE(error_of(dir.path()).find("named by their frame number"), std::string::npos);
  EXPECT_NE(error_of(dir / "nope").find("no such folder"), std::string::npos);
  TempDir empty;
  EXPECT_NE(error_of(empty.path()).find("not a dataset"), std::string::npos);
}

TEST(Dataset, SidecarsAreRead) {
  TempDir dir;
  std::filesystem::create_directories(dir / "velodyne");
  pl::write_kitti_bin(dir / "velodyne/000000.bin", small_scan(0));
  write_file(dir / "times.txt", "0\n");
  write_file(dir / "gps.csv", "t,lat,lon,alt,std_m,status\n0.0,49.0,8.4,100.0,0.02,4\n0.1,49.00001,8.4,100.5,1.5,1\n");
  write_file(dir / "encoder.csv", "t,left_m,right_m\n0,0,0\n0.01,0.1,0.12\n");
  write_file(dir / "odometry.csv", "t,x,y,z,qx,qy,qz,qw\n0,1,2,3,0,0,0,1\n");
  write_file(dir / "meta.json", R"({"sensor": {"model": "VLP-16", "beams": 16, "point_order": "any",
      "vertical_angles_deg": [-15,1,-13,3,-11,5,-9,7,-7,9,-5,11,-3,13,-1,15], "fov_deg": 180},
      "vehicle": {"wheel_base_m": 1.6, "gps_lever_arm_m": [0.5, 0, 1.2]},
      "origin": {"lat": 49.0, "lon": 8.4, "alt": 100.0}})");
  pl::Dataset ds = pl::open_dataset(dir.path());
  ASSERT_EQ(ds.gps.size(), 2u);
  EXPECT_EQ(ds.gps[0].status, pl::kGpsFixed);
  EXPECT_DOUBLE_EQ(ds.gps[1].std_m, 1.5);
  ASSERT_EQ(ds.encoder.size(), 2u);
  EXPECT_DOUBLE_EQ(ds.encoder[1].right_m, 0.12);
  ASSERT_EQ(ds.odometry.size(), 1u);
  EXPECT_DOUBLE_EQ(ds.odometry[0].pose.translation().y(), 2.0);
  EXPECT_EQ(ds.meta.sensor.beams, 16);
  EXPECT_EQ(ds.meta.sensor.fov_deg, 180.0);
  EXPECT_DOUBLE_EQ(ds.meta.vehicle.wheel_base_m, 1.6);
  EXPECT_DOUBLE_EQ(ds.meta.vehicle.gps_lever_arm.z(), 1.2);
  EXPECT_EQ(ds.sidecars.size(), 4u);
  // The world frame is ENU about the origin: the second fix is ~1.1 m north and 0.5 m up.
  Eigen::Vector3d w = ds.to_world(ds.gps[1].position);
  EXPECT_NEAR(w.x(), 0.0, 1e-6);
  EXPECT_NEAR(w.y(), 1.11, 0.01);
  EXPECT_NEAR(w.z(), 0.5, 1e-3);
  // Rings come from the table when the points are in any order.
  pl::Scan s = {{10.f, 0.f, 10.f * std::tan(3.0f * float(M_PI) / 180.f), 0.f}};
  EXPECT_EQ(ds.rings(s)[0], 3);  // +3 deg is the fourth entry of the table
}

TEST(Dataset, PointTimesAreReadAndCheckedAgainstTheirScan) {
  TempDir dir;
  std::filesystem::create_directories(dir / "velodyne");
  pl::write_kitti_bin(dir / "velodyne/000000.bin", small_scan(0));
  pl::write_kitti_bin(dir / "velodyne/000001.bin", small_scan(1));
  write_file(dir / "times.txt", "0\n0.1\n");
  EXPECT_TRUE(pl::open_dataset(dir.path()).point_times_dir.empty());
  EXPECT_TRUE(pl::open_dataset(dir.path()).load_point_times(0, 2).empty());
  std::filesystem::create_directories(dir / "point_times");
  pl::write_point_times(dir / "point_times/000000.bin", {-0.05f, 0.025f});
  const pl::Dataset ds = pl::open_dataset(dir.path());
  EXPECT_EQ(ds.sidecars.back(), "point_times/");
  const std::vector<float> t = ds.load_point_times(0, 2);
  ASSERT_EQ(t.size(), 2u);
  EXPECT_EQ(t[0], -0.05f);
  EXPECT_EQ(t[1], 0.025f);
  // One scan without its file, a count that is not the scan's, a time that is not within the sweep.
  EXPECT_TRUE(contains(pl::test::error_of([&] { ds.load_point_times(1, 2); }), "point_times/000001.bin: missing"));
  EXPECT_TRUE(contains(pl::test::error_of([&] { ds.load_point_times(0, 3); }), "000000.bin: 8 bytes for the times of 3 points"));
  pl::write_point_times(dir / "point_times/000001.bin", {0.0f, 2.5f});
  EXPECT_TRUE(contains(pl::test::error_of([&] { ds.load_point_times(1, 2); }), "point 1's time 2.5"));
  pl::write_point_times(dir / "point_times/000001.bin", {0.0f, NAN});
  EXPECT_TRUE(contains(pl::test::error_of([&] { ds.load_point_times(1, 2); }), "is not within a second"));
}

TEST(Dataset, SidecarErrorsNameFileLineAndFix) {
  TempDir dir;
  std::filesystem::create_directories(dir / "velodyne");
  pl::write_kitti_bin(dir / "velodyne/000000.bin", small_scan(0));
  write_file(dir / "times.txt", "0\n");
  write_file(dir / "gps.csv", "t,lat,lon,alt,std_m,status\n0.0,49.0,8.4,100.0,0.02,4\n0.1,49.0,8.4,100.0,0.02,7\n");
  std::string e = error_of(dir.path());
  EXPECT_NE(e.find("gps.csv:3"), std::string::npos) << e;
  EXPECT_NE(e.find("rtk-fixed"), std::string::npos) << e;
  write_file(dir / "gps.csv", "time,lat,lon\n");
  e = error_of(dir.path());
  EXPECT_NE(e.find("gps.csv:1"), std::string::npos) << e;
  EXPECT_NE(e.find("t,lat,lon,alt,std_m,status"), std::string::npos) << e;
  write_file(dir / "gps.csv", "0.2,49.0,8.4,100.0,0.02,4\n0.1,49.0,8.4,100.0,0.02,4\n");
  EXPECT_NE(error_of(dir.path()).find("non-decreasing"), std::string::npos);
  std::filesystem::remove(dir / "gps.csv");
  write_file(dir / "encoder.csv", "t,left_m,right_m\n0,0,0\n");
  e = error_of(dir.path());
  EXPECT_NE(e.find("wheel_base_m"), std::string::npos) << e;
  write_file(dir / "meta.json", "{\"vehicle\": {\"wheel_base_m\": 1.6,}}");
  e = error_of(dir.path());
  EXPECT_NE(e.find("meta.json: not valid JSON"), std::string::npos) << e;
  EXPECT_NE(e.find("line 1"), std::string::npos) << e;
  write_file(dir / "meta.json", R"({"sensor": {"beams": 16, "vertical_angles_deg": [1, 2]}})");
  EXPECT_NE(error_of(dir.path()).find("has 2 angles"), std::string::npos);
  write_file(dir / "meta.json", R"({"vehicle": {"wheel_base_m": 1.6}, "origin": {"lat": 49}})");
  EXPECT_NE(error_of(dir.path()).find("missing \"origin.lon\""), std::string::npos);
}

TEST(Dataset, KittiTimestamps) {
  double a = 0, b = 0;
  ASSERT_TRUE(pl::parse_kitti_timestamp("2011-09-26 13:04:32.349659964", a));
  ASSERT_TRUE(pl::parse_kitti_timestamp("2011-09-26 13:04:32.459792166", b));
  EXPECT_NEAR(b - a, 0.110132202, 1e-6);
  ASSERT_TRUE(pl::parse_kitti_timestamp("1970-01-02 00:00:00.0", a));
  EXPECT_DOUBLE_EQ(a, 86400.0);
  ASSERT_TRUE(pl::parse_kitti_timestamp("2012-03-01 00:00:00", a));
  ASSERT_TRUE(pl::parse_kitti_timestamp("2012-02-29 23:59:59.5", b));
  EXPECT_DOUBLE_EQ(a - b, 0.5);  // leap day
  EXPECT_FALSE(pl::parse_kitti_timestamp("2011-13-26 13:04:32", a));
  EXPECT_FALSE(pl::parse_kitti_timestamp("yesterday", a));
}

TEST(Dataset, RawLayoutOxtsGivesPosesGpsAndTimes) {
  TempDir dir;
  write_raw_drive(dir.path(), 30);
  pl::Dataset ds = pl::open_dataset(dir.path());
  EXPECT_EQ(ds.layout, pl::DatasetLayout::KittiRaw);
  ASSERT_EQ(ds.size(), 30u);
  ASSERT_EQ(ds.ground_truth.size(), 30u);
  ASSERT_EQ(ds.gps.size(), 30u);
  for (std::size_t i = 1; i < ds.size(); ++i) EXPECT_NEAR(ds.times[i] - ds.times[i - 1], 0.1, 1e-6);
  EXPECT_TRUE(ds.ground_truth.poses[0].isApprox(pl::Pose::Identity(), 1e-9));
  EXPECT_EQ(ds.gps[0].status, pl::kGpsFixed);
  EXPECT_EQ(ds.gps[29].status, pl::kGpsFloat);
  EXPECT_EQ(ds.gps[27].status, pl::kGpsDgps);
  EXPECT_NEAR(ds.gps[3].std_m, 0.05, 1e-9);
  EXPECT_NEAR(ds.meta.vehicle.gps_lever_arm.x(), -0.8086759, 1e-9);
  // The GPS (IMU) position in the world frame is the LiDAR pose applied to the lever arm.
  for (std::size_t i : {0u, 10u, 29u}) {
    Eigen::Vector3d antenna = ds.ground_truth.poses[i] * ds.meta.vehicle.gps_lever_arm;
    EXPECT_NEAR((ds.to_world(ds.gps[i].position) - antenna).norm(), 0.0, 1e-6) << i;
  }
}

TEST(Dataset, RawPosesAgreeWithIndependentConversion) {
  TempDir dir;
  write_raw_drive(dir / "drive", 40);
  auto r = pl::test::run(pl::test::tool("pl-dataset") + " poses " + (dir / "drive") + " --out " + (dir / "gt.txt"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  auto check = pl::test::run("python3 " PL_SOURCE_DIR "/tests/tools/oxts_poses.py " + (dir / "drive") + " " + (dir / "gt.txt") + " --tol 0.001");
  EXPECT_EQ(check.exit_code, 0) << check.output;
  EXPECT_NE(check.output.find("poses 40"), std::string::npos) << check.output;
}

TEST(Dataset, PlDatasetInfoReportsAndFailsClearly) {
  TempDir dir;
  write_raw_drive(dir / "drive", 12);
  auto r = pl::test::run(pl::test::tool("pl-dataset") + " info " + (dir / "drive"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("KITTI raw"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("12 poses"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("12 fixes"), std::string::npos) << r.output;
  auto j = pl::test::run(pl::test::tool("pl-dataset") + " info --json " + (dir / "drive"));
  EXPECT_NE(j.output.find("\"scans\": 12"), std::string::npos) << j.output;
  std::filesystem::remove(dir / "drive/oxts/data/0000000005.txt");
  auto bad = pl::test::run(pl::test::tool("pl-dataset") + " info " + (dir / "drive"));
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_NE(bad.output.find("0000000005.txt: missing"), std::string::npos) << bad.output;
  auto typo = pl::test::run(pl::test::tool("pl-dataset") + " poses " + (dir / "drive") + " --outfile x");
  EXPECT_EQ(typo.exit_code, 2);
  EXPECT_NE(typo.output.find("--out"), std::string::npos) << typo.output;
}

// pl-dataset scans checks --timing before it reads a scan: a path under a regular file or in a
// missing folder fails at once, naming the path.
TEST(Dataset, ScansChecksTheTimingPathBeforeTheWork) {
  TempDir dir;
  write_raw_drive(dir / "drive", 5);
  write_file(dir / "file.txt", "a regular file\n");
  const std::string tool = pl::test::tool("pl-dataset") + " scans " + (dir / "drive") + " --timing ";
  for (const std::string& path : {dir / "file.txt/t.csv", dir / "no/such/t.csv"}) {
    auto r = pl::test::run(tool + path);
    EXPECT_EQ(r.exit_code, 2) << r.output;
    EXPECT_NE(r.output.find("cannot write " + path), std::string::npos) << r.output;
    EXPECT_EQ(r.output.find("prepared"), std::string::npos) << r.output;
  }
  auto ok = pl::test::run(tool + (dir / "t.csv"));
  ASSERT_EQ(ok.exit_code, 0) << ok.output;
  EXPECT_NE(ok.output.find("prepared 5 scans"), std::string::npos) << ok.output;
}

TEST(Dataset, GpsCsvBesideARawDriveReplacesTheOxtsFixes) {
  TempDir dir;
  write_raw_drive(dir.path(), 20);
  const pl::Dataset oxts = pl::open_dataset(dir.path());
  ASSERT_EQ(oxts.gps.size(), 20u);
  write_file(dir / "gps.csv",
             "# a consumer receiver\nt,lat,lon,alt,std_m,status\n0.0,49.0112200,8.4228900,113.0,1.5,1\n"
             "1.0,49.0112500,8.4229500,113.5,1.5,1\n");
  const pl::Dataset ds = pl::open_dataset(dir.path());
  ASSERT_EQ(ds.gps.size(), 2u);  // the CSV's fixes only: none of the 20 OXTS fixes are kept
  for (const auto& f : ds.gps) {
    EXPECT_EQ(f.status, pl::kGpsSingle);
    EXPECT_DOUBLE_EQ(f.std_m, 1.5);
  }
  EXPECT_DOUBLE_EQ(ds.gps[1].t, 1.0);
  EXPECT_DOUBLE_EQ(ds.gps[1].position.lat_deg, 49.01125);
  EXPECT_EQ(ds.sidecars, std::vector<std::string>{"gps.csv"});
  // Everything else still comes from OXTS: poses, the world frame, the lever arm.
  ASSERT_EQ(ds.ground_truth.size(), oxts.ground_truth.size());
  for (std::size_t i = 0; i < ds.size(); ++i)
    EXPECT_TRUE(ds.ground_truth.poses[i].isApprox(oxts.ground_truth.poses[i], 1e-12)) << i;
  EXPECT_EQ(ds.projection.kind, pl::WorldProjection::Kind::KittiMercator);
  EXPECT_NEAR((ds.to_world(ds.gps[0].position) - oxts.to_world(ds.gps[0].position)).norm(), 0.0, 1e-12);
  EXPECT_NEAR(ds.meta.vehicle.gps_lever_arm.x(), -0.8086759, 1e-9);
}

namespace {

// Per fix of `degraded`, its offset east/north/up from the fix of `source` at the same time.
std::vector<Eigen::Vector3d> gps_offsets(const pl::Dataset& source, const pl::Dataset& degraded) {
  std::vector<Eigen::Vector3d> out;
  for (const auto& f : degraded.gps) {
    auto it = std::find_if(source.gps.begin(), source.gps.end(), [&](const pl::GpsFix& g) { return std::fabs(g.t - f.t) < 1e-6; });
    EXPECT_NE(it, source.gps.end()) << "no source fix at t = " << f.t;
    if (it != source.gps.end()) out.push_back(pl::EnuFrame(it->position).to_enu(f.position));
  }
  return out;
}

double rms_of(const std::vector<Eigen::Vector3d>& v, int axis) {
  double s = 0;
  for (const auto& d : v) s += d[axis] * d[axis];
  return std::sqrt(s / static_cast<double>(v.size()));
}

}  // namespace

TEST(Dataset, DegradeGpsWritesTheSameDriveWithAConsumerReceiver) {
  TempDir dir;
  write_raw_drive(dir / "drive", 301);  // 30 s of OXTS at 10 Hz
  const std::string tool = pl::test::tool("pl-dataset");
  auto r = pl::test::run(tool + " degrade-gps " + (dir / "drive") + " --out " + (dir / "consumer") +
                         " --rate 5 --sigma 2 --seed 7");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("151 fixes at 5 Hz"), std::string::npos) << r.output;

  const pl::Dataset source = pl::open_dataset(dir / "drive");
  const pl::Dataset ds = pl::open_dataset(dir / "consumer");
  EXPECT_EQ(ds.layout, pl::DatasetLayout::KittiRaw);
  ASSERT_EQ(ds.size(), source.size());
  // The scans and OXTS are reached through symlinks, not copies.
  EXPECT_TRUE(std::filesystem::is_symlink(dir / "consumer/velodyne_points"));
  EXPECT_TRUE(std::filesystem::is_symlink(dir / "consumer/oxts"));
  EXPECT_FALSE(std::filesystem::is_symlink(dir / "consumer/gps.csv"));
  // Ground truth and times unchanged.
  ASSERT_EQ(ds.ground_truth.size(), source.ground_truth.size());
  for (std::size_t i = 0; i < ds.size(); ++i) {
    EXPECT_DOUBLE_EQ(ds.times[i], source.times[i]);
    EXPECT_TRUE(ds.ground_truth.poses[i].isApprox(source.ground_truth.poses[i], 1e-12)) << i;
  }
  // rate x duration + 1 fixes, 0.2 s apart, single, std 2 m.
  ASSERT_EQ(ds.gps.size(), 151u);
  for (std::size_t i = 1; i < ds.gps.size(); ++i) EXPECT_NEAR(ds.gps[i].t - ds.gps[i - 1].t, 0.2, 1e-6);
  for (const auto& f : ds.gps) {
    EXPECT_EQ(f.status, pl::kGpsSingle);
    EXPECT_DOUBLE_EQ(f.std_m, 2.0);
  }
  // Zero-mean noise of sigma 2 m east and north, 3 m up (151 draws each: the std is within ~15 %).
  const auto d = gps_offsets(source, ds);
  ASSERT_EQ(d.size(), 151u);
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& v : d) mean += v / static_cast<double>(d.size());
  EXPECT_NEAR(mean.x(), 0.0, 0.5);
  EXPECT_NEAR(mean.y(), 0.0, 0.5);
  EXPECT_NEAR(mean.z(), 0.0, 0.75);
  EXPECT_NEAR(rms_of(d, 0), 2.0, 0.3);
  EXPECT_NEAR(rms_of(d, 1), 2.0, 0.3);
  EXPECT_NEAR(rms_of(d, 2), 3.0, 0.45);

  // Deterministic: the same seed writes the same file (the output folder is replaced); another seed
  // another one; the default rate (1 Hz) gives one fix a second.
  const std::string first = pl::test::read_file(dir / "consumer/gps.csv");
  r = pl::test::run(tool + " degrade-gps " + (dir / "drive") + " --out " + (dir / "consumer") + " --rate 5 --sigma 2 --seed 7");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(pl::test::read_file(dir / "consumer/gps.csv"), first);
  r = pl::test::run(tool + " degrade-gps " + (dir / "drive") + " --out " + (dir / "other") + " --rate 5 --sigma 2 --seed 8");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(pl::test::read_file(dir / "other/gps.csv"), first);
  r = pl::test::run(tool + " degrade-gps " + (dir / "drive") + " --out " + (dir / "slow"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const pl::Dataset slow = pl::open_dataset(dir / "slow");
  EXPECT_EQ(slow.gps.size(), 31u);
  EXPECT_DOUBLE_EQ(slow.gps[0].std_m, 1.5);
  auto info = pl::test::run(tool + " info " + (dir / "slow"));
  EXPECT_EQ(info.exit_code, 0) << info.output;
  EXPECT_NE(info.output.find("31 fixes, median std 1.500 m: single 100.0 %"), std::string::npos) << info.output;
}

TEST(Dataset, DegradeGpsRejectsBadInputClearly) {
  TempDir dir;
  write_raw_drive(dir / "drive", 12);
  write_file(dir / "taken/notes.txt", "mine");
  // A hand-made drive: scans linked from elsewhere, its own receiver log. Not ours to clear.
  write_file(dir / "linked/gps.csv", "t,lat,lon,alt,std_m,status\n");
  std::filesystem::create_symlink(dir / "drive", dir / "linked/scans");
  const std::string tool = pl::test::tool("pl-dataset") + " degrade-gps " + (dir / "drive");
  const std::vector<std::pair<std::string, std::string>> cases = {
      {" --out " + (dir / "c") + " --rate 0", "--rate takes"},
      {" --out " + (dir / "c") + " --rate 20", "above the rate of the source GPS"},
      {" --out " + (dir / "c") + " --sigma -1", "--sigma takes"},
      {" --out " + (dir / "drive/inside"), "inside the source folder"},
      {" --out " + (dir / "drive"), "the source folder itself"},
      {" --out " + (dir / "taken"), "not an earlier degrade-gps output"},
      {" --out " + (dir / "linked"), "not an earlier degrade-gps output"},
      {"", "--out is required"},
      {" --out " + (dir / "c") + " --sigmaa 2", "--sigmaa"},
  };
  for (const auto& [args, expected] : cases) {
    auto r = pl::test::run(tool + args);
    EXPECT_EQ(r.exit_code, 2) << args << "\n" << r.output;
    EXPECT_NE(r.output.find(expected), std::string::npos) << args << "\n" << r.output;
  }
  EXPECT_FALSE(std::filesystem::exists(dir / "drive/inside"));
  EXPECT_EQ(pl::test::read_file(dir / "taken/notes.txt"), "mine");
  EXPECT_EQ(pl::test::read_file(dir / "linked/gps.csv"), "t,lat,lon,alt,std_m,status\n");
  EXPECT_TRUE(std::filesystem::is_symlink(dir / "linked/scans"));
}

// The regressions below are the classes of fuzz_dataset's findings (tests/fuzz/regressions/dataset):
// undefined behaviour, an exception that was not a pl::Error, or a dataset with duplicate frames or
// non-finite times and poses, before the reader checked them.

namespace {

// A one-scan odometry drive in `dir`.
void write_odometry_drive(const TempDir& dir) {
  std::filesystem::create_directories(dir / "velodyne");
  pl::write_kitti_bin(dir / "velodyne/000000.bin", small_scan(0));
  write_file(dir / "times.txt", "0\n");
}

// The 30 values of an OXTS record with lat, lon and the values at `changes` (index -> text) replaced.
std::string oxts_record(const std::map<int, std::string>& changes) {
  std::vector<std::string> v = {"49.0112128", "8.422885", "112.8", "0.01", "-0.02", "-1.2"};
  v.resize(30, "0");
  v[23] = "0.05", v[27] = "6";
  for (const auto& [i, text] : changes) v[static_cast<std::size_t>(i)] = text;
  std::string line;
  for (const auto& x : v) line += x + " ";
  return line + "\n";
}

}  // namespace

TEST(Dataset, TwoScansOfOneFrameAreRefused) {
  TempDir dir;
  write_odometry_drive(dir);
  pl::write_kitti_bin(dir / "velodyne/0.bin", small_scan(1));
  const std::string e = error_of(dir.path());
  EXPECT_TRUE(contains(e, "velodyne/0.bin and "));
  EXPECT_TRUE(contains(e, "velodyne/000000.bin are both frame 0: keep one scan per frame number"));
}

TEST(Dataset, TimestampsOutOfRangeAreRefused) {
  double s = 0;
  // sscanf's %d on more digits than an int holds is undefined, and so was the day count after it.
  EXPECT_FALSE(pl::parse_kitti_timestamp("-2147483648-01-01 00:00:00.0", s));
  EXPECT_FALSE(pl::parse_kitti_timestamp("99999-01-01 00:00:00.0", s));
  EXPECT_FALSE(pl::parse_kitti_timestamp("2011-09-26 13:02:nan", s));
  EXPECT_FALSE(pl::parse_kitti_timestamp("2011-09-26 13:02:1e400", s));
  // Times are kept in nanoseconds since 1970 (64 bits: 1677 to 2262).
  EXPECT_FALSE(pl::parse_kitti_timestamp("0001-01-01 00:00:00", s));
  ASSERT_TRUE(pl::parse_kitti_timestamp("1970-01-01 00:00:01.000000001", s));
  std::int64_t ns = 0;
  ASSERT_TRUE(pl::parse_kitti_timestamp_ns("2011-09-26 13:04:32.349659964", ns));
  EXPECT_EQ(ns, 1317042272349659964LL);
  ASSERT_TRUE(pl::parse_kitti_timestamp_ns("2011-09-26 13:04:32.5", ns));
  EXPECT_EQ(ns, 1317042272500000000LL);
  TempDir dir;
  write_raw_drive(dir.path(), 2);
  write_file(dir / "oxts/timestamps.txt", "2011-09-26 13:02:25.9\n2011-09-26 13:02:nan\n");
  EXPECT_TRUE(contains(error_of(dir.path()), "oxts/timestamps.txt:2: expected a timestamp like 2011-09-26 13:04:32.349659964, found \"2011-09-26 13:02:nan\""));
}

TEST(Dataset, MetaNumbersOutOfRangeAreRefused) {
  TempDir dir;
  write_odometry_drive(dir);
  // nlohmann's get<int>() on 1e300 is a float-to-int conversion out of range (undefined).
  write_file(dir / "meta.json", R"({"sensor": {"beams": 1e300}})");
  EXPECT_TRUE(contains(error_of(dir.path()), "meta.json: \"sensor.beams\" must be a whole number, found 1e+300"));
  write_file(dir / "meta.json", R"({"sensor": {"beams": 16.5}})");
  EXPECT_TRUE(contains(error_of(dir.path()), "\"sensor.beams\" must be a whole number, found 16.5"));
  write_file(dir / "meta.json", R"({"sensor": {"beams": true}})");
  EXPECT_TRUE(contains(error_of(dir.path()), "\"sensor.beams\" has the wrong type (boolean; expected a whole number)"));
  write_file(dir / "meta.json", R"({"sensor": {"beams": 16.0}})");
  EXPECT_EQ(pl::open_dataset(dir.path()).meta.sensor.beams, 16);
  // A number beyond double was nlohmann's out_of_range, not a pl::Error: it escaped the reader.
  write_file(dir / "meta.json", R"({"sensor": {"beams": 64, "fov_deg": 1e400}})");
  const std::string e = error_of(dir.path());
  EXPECT_TRUE(contains(e, "meta.json: not valid JSON: "));
  EXPECT_TRUE(contains(e, "number overflow parsing '1e400'"));
}

TEST(Dataset, OxtsValuesOutOfRange) {
  TempDir dir;
  write_raw_drive(dir.path(), 2);
  // At lat -90 the Mercator projection is infinite.
  write_file(dir / "oxts/data/0000000001.txt", oxts_record({{0, "-90"}}));
  EXPECT_TRUE(contains(error_of(dir.path()), "oxts/data/0000000001.txt: expected lat in (-90, 90) and lon in [-180, 180] degrees (the first two values), found -90 8.422885"));
  write_file(dir / "oxts/data/0000000001.txt", oxts_record({{1, "1e300"}}));
  EXPECT_TRUE(contains(error_of(dir.path()), "found 49.0112128 1e+300"));
  write_file(dir / "oxts/data/0000000001.txt", oxts_record({{23, "-1"}}));
  EXPECT_TRUE(contains(error_of(dir.path()), "oxts/data/0000000001.txt: expected pos_accuracy (value 24) >= 0, found -1"));
  // A position mode that is no mode (1e300 as an int was undefined) is no fix status.
  write_file(dir / "oxts/data/0000000001.txt", oxts_record({{27, "1e300"}}));
  pl::Dataset ds = pl::open_dataset(dir.path());
  EXPECT_EQ(ds.gps[1].status, pl::kGpsNone);
  write_file(dir / "oxts/data/0000000001.txt", oxts_record({{27, "5.5"}}));
  EXPECT_EQ(pl::open_dataset(dir.path()).gps[1].status, pl::kGpsNone);
  // An altitude that overflows in the pose conversion.
  write_file(dir / "oxts/data/0000000000.txt", oxts_record({{2, "1.7e308"}}));
  write_file(dir / "oxts/data/0000000001.txt", oxts_record({{2, "-1.7e308"}}));
  EXPECT_TRUE(contains(error_of(dir.path()), "oxts/data/0000000001.txt: the pose of this record is not finite after the conversion (values out of range?)"));
}

TEST(Dataset, PosesThatOverflowInTheConversionAreRefused) {
  TempDir dir;
  write_odometry_drive(dir);
  write_file(dir / "poses.txt", "1 0 0 1.7e308 0 1 0 1.7e308 0 0 1 1.7e308\n");
  write_file(dir / "calib.txt", "Tr: 1 0 0 -1.7e308 0 1 0 -1.7e308 0 0 1 -1.7e308\n");
  EXPECT_TRUE(contains(error_of(dir.path()), "poses.txt: the pose of frame 0 is not finite after the conversion (values out of range?)"));
  TempDir raw;
  write_raw_drive(raw.path(), 2);
  write_file(raw / "calib_imu_to_velo.txt", "R: 0.7071068 -0.7071068 0 0.7071068 0.7071068 0 0 0 1\nT: 1.7e308 1.7e308 1.7e308\n");
  EXPECT_TRUE(contains(error_of(raw.path()), "oxts/data/0000000000.txt: the pose of this record is not finite after the conversion"));
}

TEST(Dataset, AFolderInPlaceOfAFileIsNamed) {
  TempDir dir;
  write_raw_drive(dir.path(), 2);
  std::filesystem::remove(dir / "oxts/timestamps.txt");
  std::filesystem::create_directories(dir / "oxts/timestamps.txt");
  EXPECT_TRUE(contains(error_of(dir.path()), "oxts/timestamps.txt: is a folder, expected a text file"));
}

// A folder of cloud frames as PCL or Open3D save them: PCD and PLY files in name order (by number),
// times from times.txt, or times and the ground truth from poses.tum.
TEST(Dataset, CloudFramesWithTimesOrTumPoses) {
  TempDir dir;
  auto frame = [&](const std::string& name, float x) {
    pl::Points3d pts = {Eigen::Vector3d(x, 1.0, 2.0), Eigen::Vector3d(x + 1.0, -1.0, 0.5)};
    pl::write_pcd(dir / name, pts, {3.0f, 4.0f});
  };
  frame("2.pcd", 20.0f);
  frame("10.pcd", 100.0f);  // after 2 by number, before it by name
  write_file(dir / "1.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\n5 6 7\n");
  // No times yet: refused, naming what to add.
  std::string e = pl::test::error_of([&] { pl::open_dataset(dir.path()); });
  EXPECT_NE(e.find("3 cloud frames but no times: add times.txt"), std::string::npos) << e;
  write_file(dir / "times.txt", "1700000000.0\n1700000000.1\n");
  e = pl::test::error_of([&] { pl::open_dataset(dir.path()); });
  EXPECT_NE(e.find("times.txt: has 2 times for 3 frames"), std::string::npos) << e;
  write_file(dir / "times.txt", "1700000000.0\n1700000000.1\n1700000000.2\n");
  const pl::Dataset ds = pl::open_dataset(dir.path());
  EXPECT_EQ(ds.layout, pl::DatasetLayout::Frames);
  ASSERT_EQ(ds.size(), 3u);
  EXPECT_DOUBLE_EQ(ds.times[2], 1700000000.2);
  EXPECT_FALSE(ds.has_ground_truth());
  EXPECT_FLOAT_EQ(ds.load_scan(0)[0].x, 5.0f);  // 1.ply
  const pl::Frame f = ds.load_frame(1);          // 2.pcd
  ASSERT_EQ(f.scan.size(), 2u);
  EXPECT_FLOAT_EQ(f.scan[1].x, 21.0f);
  EXPECT_FLOAT_EQ(f.scan[1].intensity, 4.0f);
  EXPECT_TRUE(f.rings.empty());  // clouds carry no rings
  EXPECT_FLOAT_EQ(ds.load_scan(2)[0].x, 100.0f);
  // poses.tum gives the ground truth (and the times where times.txt is absent).
  std::filesystem::remove(dir / "times.txt");
  write_file(dir / "poses.tum", "5.0 0 0 0 0 0 0 1\n5.1 1 0 0 0 0 0 1\n5.2 2 0 0 0 0 0 1\n");
  const pl::Dataset gt = pl::open_dataset(dir.path());
  ASSERT_TRUE(gt.has_ground_truth());
  EXPECT_DOUBLE_EQ(gt.times[1], 5.1);
  EXPECT_DOUBLE_EQ(gt.ground_truth.poses[2].translation().x(), 2.0);
  write_file(dir / "times.txt", "5.0\n5.2\n5.1\n");  // times.txt wins over the poses' times, and must grow too
  e = pl::test::error_of([&] { pl::open_dataset(dir.path()); });
  EXPECT_NE(e.find("is not later than the frame before it"), std::string::npos) << e;
}
