// The node's ROS parameters as the library's settings take them.
#pragma once

#include <ros/node_handle.h>

#include <optional>
#include <string>
#include <vector>

namespace pl::ros1 {

// A parameter as text for set_config_field (numbers, booleans and strings, as YAML gives them).
std::optional<std::string> param_text(const ::ros::NodeHandle& nh, const std::string& name);
// A list of numbers; empty when the parameter is not set.
std::vector<double> param_list(const ::ros::NodeHandle& nh, const std::string& name);

}  // namespace pl::ros1
