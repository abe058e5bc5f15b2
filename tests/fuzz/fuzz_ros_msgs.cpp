// Fuzz target: the ROS message decoders (recordings/src/ros_msgs.cpp, packet_msgs.cpp) on any bytes, in
// either encoding. The first byte picks the message and the encoding. Refusing with pl::Error is the decoder's job; a
// cloud that comes back must be consistent: finite points, one ring and one time per point when the
// cloud has them, times within a second of the stamp, no more points than the bytes could hold.
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include "pl/common/error.hpp"
#include "pl/recordings/packet_msgs.hpp"
#include "pl/recordings/ros_msgs.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  const pl::bag::Encoding enc = (data[0] & 1) ? pl::bag::Encoding::Cdr : pl::bag::Encoding::Ros1;
  const std::string_view bytes(reinterpret_cast<const char*>(data + 1), size - 1);
  try {
    switch ((data[0] >> 1) % 12) {
      case 0: {
        const pl::ros::PointCloud c = pl::ros::decode_point_cloud2(bytes, enc, "fuzz");
        for (const auto& p : c.points)
          if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z) || !std::isfinite(p.intensity)) std::abort();
        if (!c.rings.empty() && c.rings.size() != c.points.size()) std::abort();
        if (!c.times.empty() && c.times.size() != c.points.size()) std::abort();
        for (float t : c.times)
          if (!(std::abs(t) < 1.0f)) std::abort();
        // Each point takes at least one byte of data (a point_step of 1 and three 1-byte fields).
        if (c.points.size() + c.dropped > bytes.size()) std::abort();
        break;
      }
      case 1: {
        const pl::ros::Odometry o = pl::ros::decode_odometry(bytes, enc, "fuzz");
        if (!o.pose.matrix().allFinite()) std::abort();
        break;
      }
      case 2: pl::ros::decode_nav_sat_fix(bytes, enc, "fuzz"); break;
      case 3: pl::ros::decode_twist_stamped(bytes, enc, "fuzz"); break;
      case 4: pl::ros::decode_imu(bytes, enc, "fuzz"); break;
      case 5: case 6: case 7: case 8: case 9: {
        static const char* const kTypes[] = {"velodyne_msgs/VelodyneScan", "pandar_msgs/PandarScan", "robosense_msgs/RobosenseScan",
                                             "rslidar_msgs/rslidarScan", "ouster_ros/PacketMsg"};
        const pl::ros::PacketScan s = pl::ros::decode_packet_scan(bytes, enc, kTypes[(data[0] >> 1) % 12 - 5], "fuzz");
        for (const auto& p : s.packets)  // every packet a view inside the message
          if (p.data.data() < bytes.data() || p.data.data() + p.data.size() > bytes.data() + bytes.size()) std::abort();
        break;
      }
      case 10: pl::ros::decode_string(bytes, enc, "fuzz"); break;
      default: {
        const auto tf = pl::ros::decode_tf_message(bytes, enc, "fuzz");
        for (const auto& t : tf)
          if (!t.pose.matrix().allFinite()) std::abort();
        break;
      }
    }
  } catch (const pl::Error&) {
  }
  return 0;
}
