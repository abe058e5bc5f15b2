// Recordings as datasets: one drive written as a ROS 1 bag (by python3-rosbag), a ROS 2 bag and an
// MCAP file (by make_drive_recordings.py) gives the same scans, times, odometry, fixes and extrinsics
// from each; a recording without a usable topic, or with several, says what it saw and what to give.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <cstring>

#include "pl/recordings/dataset.hpp"
#include "error_of.hpp"
#include "pl/common/error.hpp"
#include "test_util.hpp"

#ifndef PL_TEST_SCRIPTS_DIR
#define PL_TEST_SCRIPTS_DIR "tests/recordings"
#endif

namespace {

const std::string& recordings() {
  static pl::test::TempDir dir;
  static const std::string path = [] {
    const std::string cmd = std::string("/usr/bin/python3 ") + PL_TEST_SCRIPTS_DIR + "/make_drive_recordings.py " + dir.path() + " >/dev/null";
    if (std::system(cmd.c_str()) != 0) throw std::runtime_error("make_drive_recordings.py failed (python3-rosbag installed?)");
    return dir.path();
  }();
  return path;
}

void expect_the_drive(const pl::Dataset& ds, const std::string& format) {
  SCOPED_TRACE(format);
  EXPECT_EQ(ds.recording_info.format, format);
  EXPECT_EQ(ds.layout, pl::DatasetLayout::Recording);
  ASSERT_EQ(ds.size(), 6u);
  // The scans at their header stamps (not when they were recorded, 50 ms later), absolute.
  for (std::size_t k = 0; k < 6; ++k) EXPECT_NEAR(ds.times[k], 1700000000.0 + 0.1 * k, 1e-6);
  EXPECT_EQ(ds.meta.sensor.beams, 16);
  EXPECT_TRUE(ds.has_point_times());
  const pl::Frame f = ds.load_frame(2);
  ASSERT_EQ(f.scan.size(), 16u * 90u);  // the NaN point left out
  ASSERT_EQ(f.rings.size(), f.scan.size());
  ASSERT_EQ(f.times.size(), f.scan.size());
  EXPECT_EQ(f.rings[0], 0);
  EXPECT_EQ(f.rings.back(), 15);
  EXPECT_NEAR(f.times[0], -0.05, 1e-6);
  // Point 0 of ring 0 at azimuth 0: range 8.02 m (8 + 0.01 k), elevation -15 deg.
  EXPECT_NEAR(f.scan[0].x, 8.02 * std::cos(-15 * M_PI / 180), 1e-5);
  EXPECT_NEAR(f.scan[0].z, 8.02 * std::sin(-15 * M_PI / 180), 1e-5);
  EXPECT_EQ(ds.load_point_times(2, f.scan.size()), f.times);
  // Odometry: base_link's poses turned into the LiDAR's through base_link -> velodyne.
  ASSERT_EQ(ds.odometry.size(), 12u);
  EXPECT_NEAR(ds.odometry[0].t, 1700000000.0, 1e-6);
  const pl::Pose& o = ds.odometry[4].pose;  // t = 0.2 s: base at x 0.2, yaw 0.08 rad
  const Eigen::Vector3d lidar = Eigen::Vector3d(0.2, 0, 0) + Eigen::AngleAxisd(0.08, Eigen::Vector3d::UnitZ()) * Eigen::Vector3d(1.2, 0, 1.7);
  // (1e-6: the writer computed x from an absolute time in double precision, good to 2.4e-7 s.)
  EXPECT_NEAR((o.translation() - lidar).norm(), 0.0, 1e-6);
  // GPS: GBAS with a 2 cm standard deviation is an RTK fixed solution; its lever arm in the LiDAR frame.
  ASSERT_EQ(ds.gps.size(), 3u);
  EXPECT_EQ(ds.gps[0].status, pl::kGpsFixed);
  EXPECT_NEAR(ds.gps[0].std_m, 0.02, 1e-12);
  EXPECT_NEAR(ds.gps[1].position.lat_deg, 49.00001, 1e-12);
  EXPECT_TRUE(ds.meta.vehicle.gps_lever_arm.isApprox(Eigen::Vector3d(-1.5, 0.2, 0.2), 1e-12)) << ds.meta.vehicle.gps_lever_arm.transpose();
  ASSERT_TRUE(ds.meta.origin.has_value());
  EXPECT_NEAR(ds.to_world(ds.gps[0].position).norm(), 0.0, 1e-6);
  EXPECT_EQ(ds.recording_info.lidar_frame, "velodyne");
  EXPECT_EQ(ds.recording_info.base_frame, "base_link");
  EXPECT_EQ(ds.recording_info.gps_frame, "gps_antenna");
}

}  // namespace

TEST(RecordingDataset, Ros1BagWrittenByRosbagGivesTheDrive) { expect_the_drive(pl::open_dataset(recordings() + "/drive.bag"), "ROS 1 bag"); }

TEST(RecordingDataset, Ros2BagFolderGivesTheDrive) { expect_the_drive(pl::open_dataset(recordings() + "/drive_ros2"), "ROS 2 bag"); }

TEST(RecordingDataset, McapFileGivesTheDrive) { expect_the_drive(pl::open_dataset(recordings() + "/drive.mcap"), "MCAP"); }

TEST(RecordingDataset, TheThreeFormatsGiveTheSameScansBitForBit) {
  const pl::Dataset a = pl::open_dataset(recordings() + "/drive.bag");
  const pl::Dataset b = pl::open_dataset(recordings() + "/drive_ros2");
  const pl::Dataset c = pl::open_dataset(recordings() + "/drive.mcap");
  for (std::size_t k = 0; k < a.size(); ++k) {
    const pl::Frame fa = a.load_frame(k), fb = b.load_frame(k), fc = c.load_frame(k);
    ASSERT_EQ(fa.scan.size(), fb.scan.size());
    ASSERT_EQ(fa.scan.size(), fc.scan.size());
    for (std::size_t i = 0; i < fa.scan.size(); ++i) {
      EXPECT_EQ(std::memcmp(&fa.scan[i], &fb.scan[i], sizeof(pl::PointXYZI)), 0);
      EXPECT_EQ(std::memcmp(&fa.scan[i], &fc.scan[i], sizeof(pl::PointXYZI)), 0);
    }
    EXPECT_EQ(fa.rings, fc.rings);
    EXPECT_EQ(fa.times, fb.times);
  }
}

TEST(RecordingDataset, NamedTopicsAreCheckedAndAMissingOneListsWhatThereIs) {
  pl::DatasetOptions o;
  o.points_topic = "/lidar";
  std::string e = pl::test::error_of([&] { pl::open_dataset(recordings() + "/drive.bag", o); });
  EXPECT_NE(e.find("no topic /lidar (--points-topic); its sensor_msgs/PointCloud2 topics: /velodyne_points"), std::string::npos) << e;
  o.points_topic = "/odom";
  e = pl::test::error_of([&] { pl::open_dataset(recordings() + "/drive.bag", o); });
  EXPECT_NE(e.find("--points-topic /odom is a nav_msgs/Odometry topic"), std::string::npos) << e;
  o.points_topic = "/velodyne_points";
  EXPECT_EQ(pl::open_dataset(recordings() + "/drive.bag", o).size(), 6u);
}

TEST(RecordingDataset, TopicUseIsReportedWithRatesAndFrames) {
  const pl::Dataset ds = pl::open_dataset(recordings() + "/drive.mcap");
  bool scans = false, odom = false;
  for (const auto& t : ds.recording_info.topics) {
    if (t.name == "/velodyne_points") {
      scans = true;
      EXPECT_EQ(t.use, "scans");
      EXPECT_EQ(t.count, 6u);
      EXPECT_NEAR(t.rate_hz, 10.0, 1e-6);
      EXPECT_EQ(t.frame_id, "velodyne");
      EXPECT_EQ(t.encoding, "cdr");
    }
    if (t.name == "/odom") {
      odom = true;
      EXPECT_EQ(t.use, "odometry");
      EXPECT_NEAR(t.max_gap_s, 0.05, 1e-6);
    }
  }
  EXPECT_TRUE(scans && odom);
}

// A ground-truth topic gives each scan the pose recorded at its stamp, exactly (a scan's time in
// double seconds may round to either side of the stamp it came from), and leaves the odometry topic
// to be the odometry.
TEST(RecordingDataset, TruthTopicGivesThePoseAtEachStamp) {
  const std::string bag = recordings() + "/drive_truth.bag";
  std::string e = pl::test::error_of([&] { pl::open_dataset(bag); });
  EXPECT_NE(e.find("several nav_msgs/Odometry topics: /odom /ground_truth; choose one with --odom-topic"), std::string::npos) << e;
  pl::DatasetOptions o;
  o.truth_topic = "/ground_truth";
  const pl::Dataset ds = pl::open_dataset(bag, o);
  ASSERT_TRUE(ds.has_ground_truth());
  ASSERT_EQ(ds.ground_truth.size(), 6u);
  EXPECT_EQ(ds.odometry.size(), 12u);  // /odom, the one Odometry topic besides the truth
  for (std::size_t k = 0; k < 6; ++k) {
    const Eigen::Vector3d p(100.0 + 1.25 * k, -3.0 + 0.5 * k, 0.125 * k);
    EXPECT_EQ(ds.ground_truth.poses[k].translation(), p) << k;  // exactly: the pose at the stamp, not a blend
    EXPECT_NEAR(pl::yaw_of(ds.ground_truth.poses[k]), 0.1 * k, 1e-8) << k;  // on the grid of canonical_rotation
  }
  EXPECT_EQ(ds.ground_truth.times, ds.times);
}

