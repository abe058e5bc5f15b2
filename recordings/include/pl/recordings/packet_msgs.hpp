// The messages LiDAR drivers record packets in, decoded without ROS in either encoding: the packets of
// one scan (velodyne_msgs/VelodyneScan, pandar_msgs/PandarScan, robosense_msgs/RobosenseScan,
// rslidar_msgs/rslidarScan, nebula_msgs/NebulaPackets) or one packet a message (ouster_ros/PacketMsg),
// and the metadata an Ouster driver publishes as a std_msgs/String. pl/lidar/decoder.hpp decodes the
// packets. Every length is checked: a damaged message is a pl::Error naming `name` and the offset.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "pl/lidar/decoder.hpp"
#include "pl/recordings/bag.hpp"
#include "pl/recordings/ros_msgs.hpp"

namespace pl::ros {

struct LidarPacket {
  std::int64_t stamp_ns = 0;  // when the driver received it (0 where the message has no stamp)
  std::string_view data;      // the UDP payload: a view into the message's bytes
};

struct PacketScan {
  Header header;  // empty for a message without one (ouster_ros/PacketMsg)
  std::vector<LidarPacket> packets;
};

// What a topic of this type carries: the vendor of its packets, or nullopt when it is no packet type.
// `type` as bag::Topic gives it ("velodyne_msgs/VelodyneScan").
std::optional<lidar::Vendor> packet_vendor(const std::string& type);
bool is_lidar_metadata(const std::string& type);  // std_msgs/String (an Ouster driver's metadata topic)

// The packets of a message of one of the packet types above.
PacketScan decode_packet_scan(std::string_view bytes, bag::Encoding encoding, const std::string& type, const std::string& name);
// std_msgs/String.
std::string decode_string(std::string_view bytes, bag::Encoding encoding, const std::string& name);

}  // namespace pl::ros
