#include "pl/recordings/dataset_cli.hpp"

namespace pl::cli {

void topic_options(CLI::App& app, DatasetOptions& topics) {
  app.add_option("--points-topic", topics.points_topic, "a recording's sensor_msgs/PointCloud2 or LiDAR packet topic (when it has several)")->type_name("TOPIC");
  app.add_option("--odom-topic", topics.odom_topic, "a recording's nav_msgs/Odometry topic (when it has several)")->type_name("TOPIC");
  app.add_option("--gps-topic", topics.gps_topic, "a recording's sensor_msgs/NavSatFix topic (when it has several)")->type_name("TOPIC");
  app.add_option("--truth-topic", topics.truth_topic, "a recording's nav_msgs/Odometry topic holding the ground truth")->type_name("TOPIC");
  app.add_option("--lidar-calibration", topics.lidar_calibration,
                 "the LiDAR maker's calibration file, for a recording of packets that does not carry it (Velodyne YAML, Hesai angle CSV, "
                 "Ouster metadata JSON)")
      ->type_name("FILE")
      ->check(CLI::ExistingFile);
  app.add_option("--lidar-model", topics.lidar_model, "the LiDAR's model, for a recording of packets that do not name it (e.g. VLP-16)")
      ->type_name("MODEL");
}

CLI::Option* dataset_option(CLI::App& app, std::string& path, DatasetOptions& topics, const std::string& help) {
  topic_options(app, topics);
  return app.add_option("--dataset", path, help + ": a KITTI folder, a ROS 1 bag, a ROS 2 bag (folder or .db3), an MCAP file or a pcap capture of a LiDAR")
      ->required()
      ->type_name("PATH");
}

CLI::Option* datasets_option(CLI::App& app, std::vector<std::string>& paths, DatasetOptions& topics, const std::string& help) {
  topic_options(app, topics);
  return app.add_option("--dataset", paths, help + ": a KITTI folder, a ROS 1 bag, a ROS 2 bag (folder or .db3), an MCAP file or a pcap capture of a LiDAR")
      ->required()
      ->type_name("PATH");
}

}  // namespace pl::cli
