// Between roscpp's message classes and PointLocalization's types. Incoming messages go through the
// same decoders that read recordings (pl/recordings/ros_msgs.hpp): the message is serialized back to its
// ROS 1 bytes and decoded there, so a scan, an odometry pose or a fix means exactly the same to the
// node as to pl-localize reading the same messages from a bag (the test compares the two). The copy
// costs about a millisecond for a 64-beam cloud.
#pragma once

#include <ros/serialization.h>
#include <ros/time.h>

#include <boost/array.hpp>

#include <Eigen/Geometry>

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include <diagnostic_msgs/KeyValue.h>
#include <geometry_msgs/Pose.h>
#include <geometry_msgs/Transform.h>

#include "pl/recordings/ros_msgs.hpp"

namespace pl::ros1 {

// A message's ROS 1 serialized bytes.
template <class Message>
std::vector<std::uint8_t> serialize(const Message& m) {
  const std::uint32_t n = ::ros::serialization::serializationLength(m);
  std::vector<std::uint8_t> bytes(n);
  ::ros::serialization::OStream stream(bytes.data(), n);
  ::ros::serialization::serialize(stream, m);
  return bytes;
}

inline std::string_view view(const std::vector<std::uint8_t>& bytes) {
  return {reinterpret_cast<const char*>(bytes.data()), bytes.size()};
}

geometry_msgs::Pose to_msg(const Eigen::Isometry3d& pose);
geometry_msgs::Transform to_transform_msg(const Eigen::Isometry3d& pose);
Eigen::Isometry3d from_msg(const geometry_msgs::Pose& pose);
Eigen::Isometry3d from_msg(const geometry_msgs::Transform& t);
// x, y, z, roll, pitch, yaw (degrees) as a pose; throws pl::Error naming `what` for another count.
Eigen::Isometry3d pose_from_list(const std::vector<double>& v, const std::string& what);
::ros::Time ros_time(double t);  // seconds (negative: 0)
// The covariance proxy (x, y, z, roll, pitch, yaw in the base frame) as ROS wants it: about the
// fixed axes of the parent frame.
boost::array<double, 36> covariance_in_map(const Eigen::Matrix<double, 6, 6>& base_cov, const Eigen::Isometry3d& base_in_map);
// A diagnostics key and value; a number as text.
diagnostic_msgs::KeyValue kv(const std::string& k, const std::string& v);
std::string num(double v, const char* fmt = "%.3f");

}  // namespace pl::ros1
