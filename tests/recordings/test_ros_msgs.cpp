// The ROS message decoders on bytes serialized by ROS's own Python classes (ROS 1) and by a CDR writer
// written here to the CDR rules (ROS 2).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <functional>
#include <map>
#include <string>

#include "cdr_writer.hpp"
#include "error_of.hpp"
#include "pl/common/error.hpp"
#include "pl/recordings/ros_msgs.hpp"
#include "test_util.hpp"

#ifndef PL_TEST_SCRIPTS_DIR
#define PL_TEST_SCRIPTS_DIR "tests/recordings"
#endif

namespace ros = pl::ros;
using pl::bag::Encoding;

namespace {

using pl::test::CdrWriter;
using pl::test::from_hex;

// NAME -> serialized bytes, from make_ros1_msgs.py run by Debian's Python with the ROS message packages.
const std::map<std::string, std::string>& ros1_messages() {
  static const std::map<std::string, std::string> messages = [] {
    std::map<std::string, std::string> m;
    const std::string cmd = std::string("/usr/bin/python3 ") + PL_TEST_SCRIPTS_DIR + "/make_ros1_msgs.py";
    FILE* p = popen(cmd.c_str(), "r");
    if (!p) return m;
    char line[1 << 16];
    while (std::fgets(line, sizeof(line), p)) {
      std::string s(line);
      while (!s.empty() && (s.back() == '\n' || s.back() == '\r')) s.pop_back();
      const auto space = s.find(' ');
      if (space != std::string::npos) m[s.substr(0, space)] = from_hex(s.substr(space + 1));
    }
    pclose(p);
    return m;
  }();
  return messages;
}

const std::string& ros1(const std::string& name) {
  const auto& m = ros1_messages();
  auto it = m.find(name);
  if (it == m.end()) throw std::runtime_error("make_ros1_msgs.py gave no message " + name + " (python3-sensor-msgs installed?)");
  return it->second;
}

}  // namespace

TEST(RosPointCloud2, DecodesVelodynesLayoutAsRosWritesIt) {
  const ros::PointCloud c = ros::decode_point_cloud2(ros1("velodyne"), Encoding::Ros1, "velodyne");
  EXPECT_EQ(c.header.stamp_ns, 1317000000LL * 1000000000LL + 123456789);
  EXPECT_EQ(c.header.frame_id, "velodyne");
  ASSERT_EQ(c.points.size(), 3u);  // the NaN point dropped
  EXPECT_EQ(c.dropped, 1u);
  EXPECT_FLOAT_EQ(c.points[0].x, 1.5f);
  EXPECT_FLOAT_EQ(c.points[0].y, -2.25f);
  EXPECT_FLOAT_EQ(c.points[0].z, 0.125f);
  EXPECT_FLOAT_EQ(c.points[0].intensity, 7.0f);
  EXPECT_FLOAT_EQ(c.points[2].x, -3.0f);
  ASSERT_EQ(c.rings.size(), 3u);
  EXPECT_EQ(c.rings[0], 3);
  EXPECT_EQ(c.rings[1], 15);
  EXPECT_EQ(c.rings[2], 0);  // the ring of the point after the NaN, not the NaN's
  ASSERT_EQ(c.times.size(), 3u);
  EXPECT_FLOAT_EQ(c.times[0], -0.05f);
  EXPECT_FLOAT_EQ(c.times[2], 0.049f);
  EXPECT_EQ(c.fields.size(), 6u);
}

TEST(RosPointCloud2, DecodesAnOrganisedOusterCloudWithNanosecondTimes) {
  const ros::PointCloud c = ros::decode_point_cloud2(ros1("ouster"), Encoding::Ros1, "ouster");
  ASSERT_EQ(c.points.size(), 3u);
  EXPECT_EQ(c.dropped, 1u);
  EXPECT_FLOAT_EQ(c.points[2].x, 7.0f);
  EXPECT_FLOAT_EQ(c.points[1].intensity, 6.0f);  // intensity preferred to reflectivity
  ASSERT_EQ(c.times.size(), 3u);
  EXPECT_NEAR(c.times[0], 1e-6, 1e-9);
  EXPECT_NEAR(c.times[1], 0.05, 1e-7);
  EXPECT_NEAR(c.times[2], 0.099, 1e-7);
  EXPECT_EQ(c.rings, (std::vector<std::uint16_t>{0, 1, 3}));
}

TEST(RosPointCloud2, MakesAbsoluteTimestampsRelativeToTheStamp) {
  const ros::PointCloud hesai = ros::decode_point_cloud2(ros1("hesai"), Encoding::Ros1, "hesai");
  ASSERT_EQ(hesai.times.size(), 2u);
  EXPECT_NEAR(hesai.times[0], 0.0, 1e-6);
  EXPECT_NEAR(hesai.times[1], 0.05, 1e-6);
  EXPECT_EQ(hesai.rings, (std::vector<std::uint16_t>{1, 31}));
  const ros::PointCloud livox = ros::decode_point_cloud2(ros1("livox"), Encoding::Ros1, "livox");  // nanoseconds
  ASSERT_EQ(livox.times.size(), 2u);
  EXPECT_NEAR(livox.times[0], 0.0, 1e-6);
  EXPECT_NEAR(livox.times[1], 0.05, 1e-6);
  EXPECT_EQ(livox.rings, (std::vector<std::uint16_t>{2, 5}));  // Livox's "line"
}

TEST(RosPointCloud2, RefusesACloudWithoutCoordinatesNamingItsFields) {
  const std::string e = pl::test::error_of([] { ros::decode_point_cloud2(ros1("no_xyz"), Encoding::Ros1, "drive.bag: /points"); });
  EXPECT_NE(e.find("drive.bag: /points"), std::string::npos) << e;
  EXPECT_NE(e.find("no x, y and z fields (it has: a)"), std::string::npos) << e;
}

TEST(RosPointCloud2, RefusesEveryTruncationAndADamagedDataLength) {
  const std::string& full = ros1("velodyne");
  for (std::size_t cut = 0; cut < full.size(); ++cut) {
    const std::string e = pl::test::error_of([&] { ros::decode_point_cloud2(full.substr(0, cut), Encoding::Ros1, "v.bag"); });
    EXPECT_NE(e.find("v.bag: offset"), std::string::npos) << "cut at " << cut << ": " << e;
  }
  // The data's length (the u32 before the data, which only is_dense follows) made larger than the message.
  std::size_t at = 0;
  for (std::uint32_t d = 0; d + 5 < full.size(); ++d) {
    std::uint32_t v;
    std::memcpy(&v, &full[full.size() - 1 - d - 4], 4);
    if (v == d) at = full.size() - 1 - d - 4;
  }
  ASSERT_GT(at, 0u);
  std::string damaged = full;
  const std::uint32_t huge = 1u << 30;
  std::memcpy(&damaged[at], &huge, 4);
  const std::string e = pl::test::error_of([&] { ros::decode_point_cloud2(damaged, Encoding::Ros1, "v.bag"); });
  EXPECT_NE(e.find("the data"), std::string::npos) << e;
}

TEST(RosPointCloud2, RefusesAFieldOutsideThePointAndAShortData) {
  // CDR cloud: 2 x 1 points of 12 bytes, field z at offset 10 (beyond the 12-byte point).
  auto cloud = [](std::uint32_t z_offset, std::uint32_t data_bytes) {
    CdrWriter w;
    w.header(100, 5, "lidar").put<std::uint32_t>(1).put<std::uint32_t>(2).put<std::uint32_t>(3);
    const char* names[] = {"x", "y", "z"};
    const std::uint32_t offsets[] = {0, 4, z_offset};
    for (int k = 0; k < 3; ++k) w.str(names[k]).put<std::uint32_t>(offsets[k]).put<std::uint8_t>(7).put<std::uint32_t>(1);
    w.put<std::uint8_t>(0).put<std::uint32_t>(12).put<std::uint32_t>(24).put<std::uint32_t>(data_bytes);
    w.raw(std::string(data_bytes, '\0')).put<std::uint8_t>(1);
    return w.bytes();
  };
  EXPECT_NO_THROW(ros::decode_point_cloud2(cloud(8, 24), Encoding::Cdr, "c"));
  EXPECT_NE(pl::test::error_of([&] { ros::decode_point_cloud2(cloud(10, 24), Encoding::Cdr, "c"); }).find("lies outside the point's 12 bytes"), std::string::npos);
  EXPECT_NE(pl::test::error_of([&] { ros::decode_point_cloud2(cloud(8, 20), Encoding::Cdr, "c"); }).find("needs 24 bytes of data, has 20"), std::string::npos);
}

TEST(RosPointCloud2, DecodesCdrWithItsAlignment) {
  // x y z f32, ring u16 at 12, time f32 at 16: 20-byte points; the header's frame of odd length puts
  // the u32s after it on a padded boundary.
  CdrWriter w;
  w.header(1700000000, 500, "lidar_top").put<std::uint32_t>(1).put<std::uint32_t>(2).put<std::uint32_t>(5);
  const char* names[] = {"x", "y", "z", "ring", "time"};
  const std::uint32_t offsets[] = {0, 4, 8, 12, 16};
  const std::uint8_t types[] = {7, 7, 7, 4, 7};
  for (int k = 0; k < 5; ++k) w.str(names[k]).put<std::uint32_t>(offsets[k]).put<std::uint8_t>(types[k]).put<std::uint32_t>(1);
  w.put<std::uint8_t>(0).put<std::uint32_t>(20).put<std::uint32_t>(40).put<std::uint32_t>(40);
  std::string data;
  auto point = [&](float x, float y, float z, std::uint16_t ring, float t) {
    char p[20] = {};
    std::memcpy(p, &x, 4), std::memcpy(p + 4, &y, 4), std::memcpy(p + 8, &z, 4), std::memcpy(p + 12, &ring, 2), std::memcpy(p + 16, &t, 4);
    data.append(p, 20);
  };
  point(1, 2, 3, 11, 0.01f);
  point(-4, 5, -6, 12, 0.02f);
  w.raw(data).put<std::uint8_t>(1);
  const ros::PointCloud c = ros::decode_point_cloud2(w.bytes(), Encoding::Cdr, "c");
  EXPECT_EQ(c.header.stamp_ns, 1700000000LL * 1000000000LL + 500);
  EXPECT_EQ(c.header.frame_id, "lidar_top");
  ASSERT_EQ(c.points.size(), 2u);
  EXPECT_FLOAT_EQ(c.points[1].x, -4.0f);
  EXPECT_FLOAT_EQ(c.points[1].z, -6.0f);
  EXPECT_EQ(c.rings, (std::vector<std::uint16_t>{11, 12}));
  EXPECT_FLOAT_EQ(c.times[1], 0.02f);
  // A big-endian encapsulation is refused by name.
  std::string be = w.bytes();
  be[1] = '\0';
  EXPECT_NE(pl::test::error_of([&] { ros::decode_point_cloud2(be, Encoding::Cdr, "c"); }).find("big-endian CDR"), std::string::npos);
}

// A CDR cloud of `n` points along a sweep: x y z f32, then one time field of `type` at offset 12,
// point k's value value(k) (the stamp is 1700000000.5 s).
std::string timed_cloud(const std::string& field, std::uint8_t type, int n, const std::function<double(int)>& value) {
  const std::uint32_t size = type == 8 ? 8 : 4, step = 12 + size;
  CdrWriter w;
  w.header(1700000000, 500000000, "lidar").put<std::uint32_t>(1).put<std::uint32_t>(static_cast<std::uint32_t>(n)).put<std::uint32_t>(4);
  const char* names[] = {"x", "y", "z"};
  for (int k = 0; k < 3; ++k) w.str(names[k]).put<std::uint32_t>(4u * static_cast<std::uint32_t>(k)).put<std::uint8_t>(7).put<std::uint32_t>(1);
  w.str(field).put<std::uint32_t>(12).put<std::uint8_t>(type).put<std::uint32_t>(1);
  w.put<std::uint8_t>(0).put<std::uint32_t>(step).put<std::uint32_t>(step * static_cast<std::uint32_t>(n));
  w.put<std::uint32_t>(step * static_cast<std::uint32_t>(n));
  std::string data;
  for (int k = 0; k < n; ++k) {
    const float xyz[3] = {10.0f * std::cos(0.01f * static_cast<float>(k)), 10.0f * std::sin(0.01f * static_cast<float>(k)), 0.5f};
    data.append(reinterpret_cast<const char*>(xyz), 12);
    const double v = value(k);
    char b[8] = {};
    if (type == 7) { const float f = static_cast<float>(v); std::memcpy(b, &f, 4); }
    if (type == 8) std::memcpy(b, &v, 8);
    if (type == 6) { const auto u = static_cast<std::uint32_t>(v); std::memcpy(b, &u, 4); }
    data.append(b, size);
  }
  w.raw(data).put<std::uint8_t>(1);
  return w.bytes();
}

TEST(RosPointCloud2, ATimeFieldThatCarriesNoTimeIsSetAsideSayingWhy) {
  // The Velodyne layout's time, all zero as several drivers and converters leave it.
  const ros::PointCloud zero = ros::decode_point_cloud2(timed_cloud("time", 7, 100, [](int) { return 0.0; }), Encoding::Cdr, "c");
  EXPECT_EQ(zero.points.size(), 100u);
  EXPECT_TRUE(zero.times.empty());
  EXPECT_EQ(zero.time_field, "time (float32)");
  EXPECT_NE(zero.time_set_aside.find("all its values are 0"), std::string::npos) << zero.time_set_aside;
  // A constant other than zero, and one that spreads over 2.5 ms of a 100 ms sweep.
  const ros::PointCloud constant = ros::decode_point_cloud2(timed_cloud("t", 6, 50, [](int) { return 12345.0; }), Encoding::Cdr, "c");
  EXPECT_TRUE(constant.times.empty());
  EXPECT_NE(constant.time_set_aside.find("12345"), std::string::npos) << constant.time_set_aside;
  const auto sliver = timed_cloud("time", 7, 100, [](int k) { return 2.5e-5 * k; });
  const ros::PointCloud thin = ros::decode_point_cloud2(sliver, Encoding::Cdr, "c", ros::SweepBounds::around(0.1));
  EXPECT_TRUE(thin.times.empty());
  EXPECT_NE(thin.time_set_aside.find("span a sweep"), std::string::npos) << thin.time_set_aside;
  // One value that is not a number sets the field aside.
  const auto nan_at_50 = [](int k) { return k == 50 ? std::nan("") : 0.001 * k; };
  const ros::PointCloud nan = ros::decode_point_cloud2(timed_cloud("time", 7, 100, nan_at_50), Encoding::Cdr, "c");
  EXPECT_TRUE(nan.times.empty());
  EXPECT_NE(nan.time_set_aside.find("not finite"), std::string::npos) << nan.time_set_aside;
  // Without a known rate the same 2.5 ms are a (narrow) sweep.
  EXPECT_EQ(ros::decode_point_cloud2(sliver, Encoding::Cdr, "c").times.size(), 100u);
}

TEST(RosPointCloud2, TheTimeUnitComesFromTheFieldsTypeAndItsSpreadOverASweep) {
  const auto bounds = ros::SweepBounds::around(0.1);
  // float32 milliseconds over a 100 ms sweep: read as ms, not as 99 s.
  const ros::PointCloud ms = ros::decode_point_cloud2(timed_cloud("time", 7, 100, [](int k) { return 1.0 * k; }), Encoding::Cdr, "c", bounds);
  ASSERT_EQ(ms.times.size(), 100u);
  EXPECT_EQ(ms.time_unit, "ms, from the stamp");
  EXPECT_NEAR(ms.times[99], 0.099, 1e-7);
  EXPECT_NEAR(ms.time_span_s, 0.099, 1e-9);
  // nebula's time_stamp: uint32 nanoseconds from the stamp.
  const ros::PointCloud ns = ros::decode_point_cloud2(timed_cloud("time_stamp", 6, 100, [](int k) { return 1e6 * k; }), Encoding::Cdr, "c", bounds);
  ASSERT_EQ(ns.times.size(), 100u);
  EXPECT_EQ(ns.time_unit, "ns, from the stamp");
  EXPECT_NEAR(ns.times[50], 0.05, 1e-7);
  // Microseconds in a uint32 (spreading over 100,000 of them).
  const ros::PointCloud us = ros::decode_point_cloud2(timed_cloud("offset_time", 6, 100, [](int k) { return 1000.0 * k; }), Encoding::Cdr, "c", bounds);
  EXPECT_EQ(us.time_unit, "us, from the stamp");
  EXPECT_NEAR(us.times[99], 0.099, 1e-7);
  // float64 seconds since 1970 (Hesai) and float64 nanoseconds since 1970 (Livox): made relative to the stamp.
  const ros::PointCloud abs_s =
      ros::decode_point_cloud2(timed_cloud("timestamp", 8, 100, [](int k) { return 1700000000.5 + 0.001 * k; }), Encoding::Cdr, "c", bounds);
  EXPECT_EQ(abs_s.time_unit, "s, absolute");
  EXPECT_NEAR(abs_s.times[0], 0.0, 1e-6);
  EXPECT_NEAR(abs_s.times[99], 0.099, 1e-6);
  const ros::PointCloud abs_ns = ros::decode_point_cloud2(
      timed_cloud("timestamp", 8, 100, [](int k) { return 1700000000.5e9 - 5e7 + 1e6 * k; }), Encoding::Cdr, "c", bounds);
  EXPECT_EQ(abs_ns.time_unit, "ns, absolute");
  EXPECT_NEAR(abs_ns.times[0], -0.05, 1e-6);  // before the stamp: a driver that stamps the sweep's middle
  // Values that are a sweep in no unit: a uint32 spreading over 0.5 s of nanoseconds at 10 Hz.
  const ros::PointCloud wide = ros::decode_point_cloud2(timed_cloud("t", 6, 100, [](int k) { return 5e6 * k; }), Encoding::Cdr, "c", bounds);
  EXPECT_TRUE(wide.times.empty());
  EXPECT_NE(wide.time_set_aside.find("in no unit"), std::string::npos) << wide.time_set_aside;
}

TEST(RosMessages, DecodeOdometryNavSatFixTwistImuAndTf) {
  const ros::Odometry o = ros::decode_odometry(ros1("odometry"), Encoding::Ros1, "o");
  EXPECT_EQ(o.header.frame_id, "odom");
  EXPECT_EQ(o.child_frame_id, "base_link");
  EXPECT_EQ(o.header.stamp_ns, 1317000001LL * 1000000000LL + 5);
  EXPECT_TRUE(o.pose.translation().isApprox(Eigen::Vector3d(1.0, -2.0, 0.5)));
  EXPECT_NEAR(pl::yaw_of(o.pose), 0.5, 1e-12);
  EXPECT_EQ(o.pose_covariance[35], 35.0);
  EXPECT_TRUE(o.linear.isApprox(Eigen::Vector3d(3.0, 0.1, 0.0)));
  EXPECT_NEAR(o.angular.z(), 0.2, 1e-15);

  const ros::NavSatFix f = ros::decode_nav_sat_fix(ros1("navsatfix"), Encoding::Ros1, "f");
  EXPECT_EQ(f.status, 2);
  EXPECT_EQ(f.service, 1);
  EXPECT_DOUBLE_EQ(f.latitude, 49.011);
  EXPECT_DOUBLE_EQ(f.longitude, 8.422);
  EXPECT_DOUBLE_EQ(f.altitude, 112.5);
  EXPECT_DOUBLE_EQ(f.covariance[4], 0.0009);
  EXPECT_EQ(f.covariance_type, 2);
  EXPECT_EQ(f.header.frame_id, "gps_antenna");

  const ros::Twist t = ros::decode_twist_stamped(ros1("twist"), Encoding::Ros1, "t");
  EXPECT_TRUE(t.linear.isApprox(Eigen::Vector3d(1, 2, 3)));
  EXPECT_TRUE(t.angular.isApprox(Eigen::Vector3d(-1, -2, -3)));

  const ros::Imu i = ros::decode_imu(ros1("imu"), Encoding::Ros1, "i");
  EXPECT_NEAR(i.linear_acceleration.z(), 9.81, 1e-15);
  EXPECT_NEAR(i.angular_velocity.y(), 0.2, 1e-15);

  const auto tf = ros::decode_tf_message(ros1("tf"), Encoding::Ros1, "tf");
  ASSERT_EQ(tf.size(), 2u);
  EXPECT_EQ(tf[1].header.frame_id, "base_link");
  EXPECT_EQ(tf[1].child_frame_id, "gps_antenna");
  EXPECT_TRUE(tf[1].pose.translation().isApprox(Eigen::Vector3d(-0.3, 0.2, 1.9)));
}

TEST(RosMessages, DecodeCdrNavSatFixWithItsPadding) {
  CdrWriter w;
  w.header(10, 20, "gps").put<std::int8_t>(0).put<std::uint16_t>(1).put<double>(48.5).put<double>(-122.25).put<double>(30.0);
  for (int k = 0; k < 9; ++k) w.put<double>(k == 0 || k == 4 ? 4.0 : 0.0);
  w.put<std::uint8_t>(2);
  const ros::NavSatFix f = ros::decode_nav_sat_fix(w.bytes(), Encoding::Cdr, "f");
  EXPECT_EQ(f.header.stamp_ns, 10LL * 1000000000LL + 20);
  EXPECT_EQ(f.status, 0);
  EXPECT_DOUBLE_EQ(f.longitude, -122.25);
  EXPECT_DOUBLE_EQ(f.covariance[4], 4.0);
  EXPECT_EQ(f.covariance_type, 2);
}

TEST(RosMessages, RefuseANonUnitQuaternionAndAHugeTransformCount) {
  std::string o = ros1("odometry");
  // The orientation's w (the 4th double after the 3 position doubles) set to 0: the quaternion is
  // then (0, 0, sin .25, 0), norm 0.247.
  const std::size_t pose_at = 4 + 8 + 4 + 4 + 4 + 9;  // seq, stamp, "odom", "base_link"
  const double zero = 0.0;
  std::memcpy(&o[pose_at + 6 * 8], &zero, 8);
  EXPECT_NE(pl::test::error_of([&] { ros::decode_odometry(o, Encoding::Ros1, "o"); }).find("not a unit quaternion"), std::string::npos);
  std::string tf = ros1("tf");
  const std::uint32_t huge = 0x7fffffff;
  std::memcpy(&tf[0], &huge, 4);
  EXPECT_NE(pl::test::error_of([&] { ros::decode_tf_message(tf, Encoding::Ros1, "tf"); }).find("cannot fit"), std::string::npos);
}

TEST(RosPointCloud2, ACloudWithNoPointsIsEmptyWhateverItsOtherSide) {
  // Width 0 and a height of two billion rows: no points, and no loop over the empty rows (the fuzzer
  // found it took 11 s).
  CdrWriter w;
  w.header(1, 0, "l").put<std::uint32_t>(2000000000u).put<std::uint32_t>(0).put<std::uint32_t>(3);
  const char* names[] = {"x", "y", "z"};
  for (int k = 0; k < 3; ++k) w.str(names[k]).put<std::uint32_t>(4 * k).put<std::uint8_t>(7).put<std::uint32_t>(1);
  w.put<std::uint8_t>(0).put<std::uint32_t>(12).put<std::uint32_t>(0).put<std::uint32_t>(0).put<std::uint8_t>(1);
  const ros::PointCloud c = ros::decode_point_cloud2(w.bytes(), Encoding::Cdr, "c");
  EXPECT_TRUE(c.points.empty());
  EXPECT_EQ(c.fields.size(), 3u);
}

