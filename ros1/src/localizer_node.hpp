// The ROS 1 node: pl::client::VehicleLocalizer between a vehicle's topics and its consumers.
//
// Subscribes (relative names, remap them): points (sensor_msgs/PointCloud2), odom (nav_msgs/Odometry:
// the base in the odometry frame), fix (sensor_msgs/NavSatFix), /initialpose (rviz's "2D Pose
// Estimate": re-initializes, searching round it).
// Publishes (private names): ~odometry (nav_msgs/Odometry: the fused pose of the base in the map
// frame, at the odometry's rate; per scan without odometry), ~pose (geometry_msgs/
// PoseWithCovarianceStamped: each scan's pose as registered), the transform map -> odom (map -> base
// without odometry) on /tf, and /diagnostics (health, protection level, the tile client's state).
// Parameters: see ros1/config/localizer.yaml (every one, with its default) and docs/ros1.md.
//
// What the node decides:
// - A scan waits for the odometry that covers its sweep (its stamp plus its latest point time) before
//   it is registered, at most ~odometry_wait_s: the prediction then interpolates the odometry rather
//   than extrapolating it, as pl-localize's replay does.
// - The localizer is made once the first scan tells the LiDAR's frame (its extrinsics come from /tf
//   unless ~base_from_lidar is given), its beams and whether its points carry times. While the map
//   service does not answer, the node retries every ~retry_s and says so in /diagnostics; scans that
//   arrive meanwhile are dropped (odometry is kept).
// - ~queue_scans false (the default, for a vehicle): a scan arriving while the previous one is still
//   being registered replaces the waiting one. true (for replays): every scan is registered, in order.
#pragma once

#include <ros/ros.h>

#include <memory>

namespace pl::ros1 {

class LocalizerNode {
 public:
  // Reads the parameters (throws pl::Error naming a bad one) and subscribes.
  LocalizerNode(::ros::NodeHandle nh, ::ros::NodeHandle private_nh);
  ~LocalizerNode();
  LocalizerNode(const LocalizerNode&) = delete;
  LocalizerNode& operator=(const LocalizerNode&) = delete;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace pl::ros1
