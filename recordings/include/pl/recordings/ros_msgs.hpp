// The ROS messages a localizer needs from a recording, decoded from their serialized bytes in either
// encoding (ROS 1's, or CDR for ROS 2) without ROS: sensor_msgs/PointCloud2 with the field layouts of
// the common LiDAR drivers, nav_msgs/Odometry, geometry_msgs/TwistStamped, sensor_msgs/NavSatFix,
// sensor_msgs/Imu and tf2_msgs/TFMessage. Every decoder checks each length against the bytes present
// and throws pl::Error naming `name` (the file and message), the byte offset and the problem.
#pragma once

#include <Eigen/Core>

#include <algorithm>
#include <array>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "pl/common/pose.hpp"
#include "pl/common/scan.hpp"
#include "pl/recordings/bag.hpp"

namespace pl::ros {

// A tf frame name without the leading '/' that ROS 1 tools sometimes add ("/velodyne" is "velodyne").
inline std::string frame_name(const std::string& frame_id) {
  return !frame_id.empty() && frame_id.front() == '/' ? frame_id.substr(1) : frame_id;
}

struct Header {
  std::int64_t stamp_ns = 0;  // nanoseconds since 1970 (the sender's clock)
  std::string frame_id;
};
// The std_msgs/Header every stamped message begins with.
Header decode_header(std::string_view bytes, bag::Encoding encoding, const std::string& name);

// A PointCloud2 as a scan: the finite points (an organised cloud's NaN "no return" points dropped),
// their intensities (field intensity, else reflectivity, else 0), and, when the cloud has them, each
// point's ring (field ring, or Livox's line) and its time in seconds from the header's stamp. The
// time field is the first of t (Ouster), time (Velodyne, RoboSense), timestamp (Hesai, Livox),
// time_stamp (nebula), time_offset, offset_time; its unit comes from its type and from the spread
// its values must have over a sweep (float: s, ms, us or ns; integer: ns, us or ms), and values near
// the stamp are absolute and made relative. A field that spreads over no sweep (constant, all zero,
// or far from one rotation in any unit) is set aside: `times` stays empty and `time_set_aside` says why.
struct PointCloud {
  Header header;
  Scan points;
  std::vector<std::uint16_t> rings;  // empty when the cloud has no ring field
  std::vector<float> times;          // empty when the cloud has no time field, or it was set aside
  std::string time_field;            // "t (uint32)": the field read for times; empty when none
  std::string time_unit;             // "ns, from the stamp", "s, absolute", ... when times were kept
  double time_span_s = 0;            // the sweep the kept times span
  std::string time_set_aside;        // why the time field's values are not per-point times
  std::size_t dropped = 0;           // points left out: a coordinate not finite
  std::vector<std::string> fields;   // the cloud's field names, in order
};
// The spread a sweep's per-point times may have: without a known rotation rate, anything from a
// sliver of a rotation to a whole second; with one (SweepBounds::around), 0.2 to 2 periods.
struct SweepBounds {
  double min_s = 0.002;
  double max_s = 1.0;
  static SweepBounds around(double period_s) { return {0.2 * period_s, std::min(1.0, 2.0 * period_s)}; }
};
PointCloud decode_point_cloud2(std::string_view bytes, bag::Encoding encoding, const std::string& name,
                               const SweepBounds& sweep = {});

// nav_msgs/Odometry: the pose of child_frame_id in header.frame_id, and the velocity in child_frame_id.
struct Odometry {
  Header header;
  std::string child_frame_id;
  Pose pose = Pose::Identity();
  std::array<double, 36> pose_covariance{};
  Eigen::Vector3d linear = Eigen::Vector3d::Zero(), angular = Eigen::Vector3d::Zero();
  EIGEN_MAKE_ALIGNED_OPERATOR_NEW
};
Odometry decode_odometry(std::string_view bytes, bag::Encoding encoding, const std::string& name);

// geometry_msgs/TwistStamped.
struct Twist {
  Header header;
  Eigen::Vector3d linear = Eigen::Vector3d::Zero(), angular = Eigen::Vector3d::Zero();
};
Twist decode_twist_stamped(std::string_view bytes, bag::Encoding encoding, const std::string& name);

// sensor_msgs/NavSatFix. status: -1 no fix, 0 fix, 1 SBAS, 2 GBAS (the drivers' RTK); covariance
// row-major ENU m^2, its type 0 unknown, 1 approximated, 2 diagonal known, 3 known.
struct NavSatFix {
  Header header;
  int status = -1;
  int service = 0;
  double latitude = 0, longitude = 0, altitude = 0;
  std::array<double, 9> covariance{};
  int covariance_type = 0;
};
NavSatFix decode_nav_sat_fix(std::string_view bytes, bag::Encoding encoding, const std::string& name);

// sensor_msgs/Imu.
struct Imu {
  Header header;
  Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();
  Eigen::Vector3d angular_velocity = Eigen::Vector3d::Zero(), linear_acceleration = Eigen::Vector3d::Zero();
  EIGEN_MAKE_ALIGNED_OPERATOR_NEW
};
Imu decode_imu(std::string_view bytes, bag::Encoding encoding, const std::string& name);

// One transform of a tf2_msgs/TFMessage: the pose of child_frame_id in header.frame_id.
struct Transform {
  Header header;
  std::string child_frame_id;
  Pose pose = Pose::Identity();
  EIGEN_MAKE_ALIGNED_OPERATOR_NEW
};
std::vector<Transform, Eigen::aligned_allocator<Transform>> decode_tf_message(std::string_view bytes, bag::Encoding encoding,
                                                                              const std::string& name);

}  // namespace pl::ros
