#include "convert.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>

#include "pl/common/error.hpp"
#include "pl/common/pose.hpp"

namespace pl::ros1 {

geometry_msgs::Pose to_msg(const Eigen::Isometry3d& pose) {
  geometry_msgs::Pose m;
  const Eigen::Quaterniond q(pose.rotation());
  m.position.x = pose.translation().x();
  m.position.y = pose.translation().y();
  m.position.z = pose.translation().z();
  m.orientation.x = q.x();
  m.orientation.y = q.y();
  m.orientation.z = q.z();
  m.orientation.w = q.w();
  return m;
}

geometry_msgs::Transform to_transform_msg(const Eigen::Isometry3d& pose) {
  const geometry_msgs::Pose p = to_msg(pose);
  geometry_msgs::Transform t;
  t.translation.x = p.position.x;
  t.translation.y = p.position.y;
  t.translation.z = p.position.z;
  t.rotation = p.orientation;
  return t;
}

namespace {
Eigen::Isometry3d make(double x, double y, double z, double qx, double qy, double qz, double qw) {
  Eigen::Quaterniond q(qw, qx, qy, qz);
  if (!(q.norm() > 0.5)) q = Eigen::Quaterniond::Identity();  // all zeros: an unset orientation
  Eigen::Isometry3d p = Eigen::Isometry3d::Identity();
  p.linear() = q.normalized().toRotationMatrix();
  p.translation() = Eigen::Vector3d(x, y, z);
  return p;
}
}  // namespace

Eigen::Isometry3d from_msg(const geometry_msgs::Pose& m) {
  return make(m.position.x, m.position.y, m.position.z, m.orientation.x, m.orientation.y, m.orientation.z, m.orientation.w);
}

Eigen::Isometry3d from_msg(const geometry_msgs::Transform& m) {
  return make(m.translation.x, m.translation.y, m.translation.z, m.rotation.x, m.rotation.y, m.rotation.z, m.rotation.w);
}

Eigen::Isometry3d pose_from_list(const std::vector<double>& v, const std::string& what) {
  if (v.size() != 6)
    throw Error(what + ": expected 6 numbers [x, y, z, roll, pitch, yaw] (metres, degrees), got " + std::to_string(v.size()));
  for (double x : v)
    if (!std::isfinite(x)) throw Error(what + ": every number must be finite");
  // Degrees to radians as pl-localize --init does it (x * pi / 180, in that order): the same numbers
  // give the same bits.
  return make_pose(v[0], v[1], v[2], v[3] * M_PI / 180.0, v[4] * M_PI / 180.0, v[5] * M_PI / 180.0);
}

::ros::Time ros_time(double t) {
  ::ros::Time r;
  r.fromNSec(static_cast<std::uint64_t>(std::llround(std::max(0.0, t) * 1e9)));
  return r;
}

boost::array<double, 36> covariance_in_map(const Eigen::Matrix<double, 6, 6>& base_cov, const Eigen::Isometry3d& base_in_map) {
  Eigen::Matrix<double, 6, 6> j = Eigen::Matrix<double, 6, 6>::Zero();
  j.topLeftCorner<3, 3>() = base_in_map.rotation();
  j.bottomRightCorner<3, 3>() = base_in_map.rotation();
  const Eigen::Matrix<double, 6, 6> c = j * base_cov * j.transpose();
  boost::array<double, 36> out{};
  for (int r = 0; r < 6; ++r)
    for (int k = 0; k < 6; ++k) out[static_cast<std::size_t>(r * 6 + k)] = c(r, k);
  return out;
}

diagnostic_msgs::KeyValue kv(const std::string& k, const std::string& v) {
  diagnostic_msgs::KeyValue x;
  x.key = k;
  x.value = v;
  return x;
}

std::string num(double v, const char* fmt) {
  char buf[64];
  std::snprintf(buf, sizeof buf, fmt, v);
  return buf;
}

}  // namespace pl::ros1
