// The command-line flags that name a drive to read: the dataset's path and, for a recording, its topics.
#pragma once

#include <CLI/CLI.hpp>

#include <string>
#include <vector>

#include "pl/recordings/dataset.hpp"

namespace pl::cli {

// --dataset PATH (a KITTI folder, a ROS 1 bag, a ROS 2 bag folder or .db3 file, or an MCAP file), and
// the flags that choose a recording's topics where it has several of a kind: --points-topic,
// --odom-topic, --gps-topic, --truth-topic; for a recording of LiDAR packets, --lidar-calibration and
// --lidar-model.
CLI::Option* dataset_option(CLI::App& app, std::string& path, DatasetOptions& topics, const std::string& help);
// The same, --dataset given once or more (the topic flags apply to every recording).
CLI::Option* datasets_option(CLI::App& app, std::vector<std::string>& paths, DatasetOptions& topics, const std::string& help);
// The topic flags alone (for a program whose dataset is a positional argument).
void topic_options(CLI::App& app, DatasetOptions& topics);

}  // namespace pl::cli
