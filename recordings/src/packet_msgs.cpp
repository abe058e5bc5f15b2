// Each driver's scan message is a header and a sequence of packets; the packet element differs only
// in how its bytes are held (a fixed array, a sequence, an array with the real length beside it).
#include "pl/recordings/packet_msgs.hpp"

#include "pl/common/error.hpp"
#include "ros_cursor.hpp"

namespace pl::ros {
namespace {

// How one packet element is laid out after its stamp.
struct PacketLayout {
  const char* type;
  lidar::Vendor vendor;
  bool header_and_sequence;  // false: the message is one packet (uint8[] buf), no stamp
  bool has_stamp;
  int leading_u8;            // bytes before the data (robosense_msgs: one)
  std::uint32_t fixed_size;  // uint8[N] data; 0: a uint8[] sequence
  bool has_size;             // a uint32 `size` after the data: the packet's real length
};

constexpr PacketLayout kLayouts[] = {
    {"velodyne_msgs/VelodyneScan", lidar::Vendor::Velodyne, true, true, 0, 1206, false},
    {"pandar_msgs/PandarScan", lidar::Vendor::Hesai, true, true, 0, 1500, true},
    {"robosense_msgs/RobosenseScan", lidar::Vendor::RoboSense, true, true, 1, 1500, true},
    {"rslidar_msgs/rslidarScan", lidar::Vendor::RoboSense, true, true, 0, 1248, false},
    {"ouster_ros/PacketMsg", lidar::Vendor::Ouster, false, false, 0, 0, false},
    {"ouster_sensor_msgs/PacketMsg", lidar::Vendor::Ouster, false, false, 0, 0, false},
};

const PacketLayout* layout_of(const std::string& type) {
  for (const auto& l : kLayouts)
    if (type == l.type) return &l;
  return nullptr;
}

std::int64_t stamp(Cursor& c) {
  const std::int64_t sec = c.cdr() ? c.get<std::int32_t>("a packet's stamp") : static_cast<std::int64_t>(c.u32("a packet's stamp"));
  const std::uint32_t nsec = c.u32("a packet's stamp");
  if (nsec >= 1000000000u) c.fail("a packet's stamp has " + std::to_string(nsec) + " nanoseconds (expected below 1e9)");
  return sec * 1000000000LL + nsec;
}

}  // namespace

std::optional<lidar::Vendor> packet_vendor(const std::string& type) {
  if (const PacketLayout* l = layout_of(type)) return l->vendor;
  return std::nullopt;
}

bool is_lidar_metadata(const std::string& type) { return type == "std_msgs/String"; }

PacketScan decode_packet_scan(std::string_view bytes, bag::Encoding encoding, const std::string& type, const std::string& name) {
  const PacketLayout* l = layout_of(type);
  if (!l) throw Error(name + ": " + type + " is not a LiDAR packet message");
  Cursor c(bytes, encoding, name);
  PacketScan out;
  if (!l->header_and_sequence) {
    const std::uint32_t n = c.count("the packet's buf", 1);
    out.packets.push_back({0, c.bytes(n, "the packet's buf")});
    return out;
  }
  out.header = c.header();
  const std::size_t least = 8 + l->leading_u8 + (l->fixed_size ? l->fixed_size : 4) + (l->has_size ? 4 : 0);
  const std::uint32_t n = c.count("the packets", least);
  out.packets.reserve(n);
  for (std::uint32_t i = 0; i < n; ++i) {
    LidarPacket p;
    if (l->has_stamp) p.stamp_ns = stamp(c);
    for (int k = 0; k < l->leading_u8; ++k) c.get<std::uint8_t>("a packet's leading byte");
    const std::uint32_t size = l->fixed_size ? l->fixed_size : c.count("a packet's data", 1);
    p.data = c.bytes(size, "a packet's data");
    if (l->has_size) {
      const std::uint32_t real = c.u32("a packet's size");
      if (real > size) c.fail("a packet's size " + std::to_string(real) + " exceeds its " + std::to_string(size) + " bytes");
      p.data = p.data.substr(0, real);
    }
    out.packets.push_back(p);
  }
  return out;
}

std::string decode_string(std::string_view bytes, bag::Encoding encoding, const std::string& name) {
  Cursor c(bytes, encoding, name);
  return c.str("the string's data");
}

}  // namespace pl::ros
