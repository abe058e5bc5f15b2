// pl_localizer_node: PointLocalization's localizer as a ROS 1 node (see localizer_node.hpp and
// docs/ros1.md). Callbacks run on one spinner thread; registration on the localizer's own worker.
#include <ros/ros.h>

#include <exception>

#include "localizer_node.hpp"

int main(int argc, char** argv) {
  ros::init(argc, argv, "pl_localizer");
  ros::NodeHandle nh, pnh("~");
  try {
    pl::ros1::LocalizerNode node(nh, pnh);
    ros::spin();
  } catch (const std::exception& e) {
    ROS_FATAL("pl_localizer: %s", e.what());
    return 2;
  }
  return 0;
}
