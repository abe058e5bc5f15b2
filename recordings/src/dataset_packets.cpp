// A recording whose scans are a LiDAR's packets (a driver's packet topic, or a pcap file): the topic
// to decode, the decoder's options from the dataset's, and what the sensor tells the dataset.
#include <algorithm>
#include <map>
#include <optional>

#include "dataset_recording.hpp"
#include "packet_scans.hpp"
#include "pl/common/error.hpp"
#include "pl/common/text.hpp"
#include "pl/lidar/pcap.hpp"

namespace pl {
namespace {

// A bag's packet messages, each a unit.
class BagPackets : public PacketStream {
 public:
  BagPackets(bag::Reader& reader, std::vector<bag::MessageRef> messages, std::string path)
      : reader_(reader), messages_(std::move(messages)), path_(std::move(path)) {}
  std::size_t units() const override { return messages_.size(); }
  std::vector<ros::LidarPacket> packets(std::size_t u) override {
    const bag::MessageRef& m = messages_.at(u);
    const bag::Topic& t = reader_.topics()[m.topic];
    ros::PacketScan scan = ros::decode_packet_scan(reader_.read(m), t.encoding, t.type, where(u));
    for (ros::LidarPacket& p : scan.packets)
      if (p.stamp_ns == 0) p.stamp_ns = m.time_ns;
    return std::move(scan.packets);
  }
  std::string where(std::size_t u) const override {
    return path_ + ": " + reader_.topics()[messages_.at(u).topic].name + " message " + std::to_string(u);
  }

 private:
  bag::Reader& reader_;
  std::vector<bag::MessageRef> messages_;
  std::string path_;
};

// A capture's UDP datagrams of the LiDAR, each a unit; the views point into the mapped file.
class PcapPackets : public PacketStream {
 public:
  PcapPackets(lidar::PcapReader reader, std::vector<ros::LidarPacket> packets, std::string path)
      : reader_(std::move(reader)), packets_(std::move(packets)), path_(std::move(path)) {}
  std::size_t units() const override { return packets_.size(); }
  std::vector<ros::LidarPacket> packets(std::size_t u) override { return {packets_.at(u)}; }
  std::string where(std::size_t u) const override { return path_ + ": LiDAR datagram " + std::to_string(u); }

 private:
  lidar::PcapReader reader_;  // owns the bytes the packets view
  std::vector<ros::LidarPacket> packets_;
  std::string path_;
};

bool ends_with(const std::string& s, const char* tail) {
  const std::string t(tail);
  return s.size() >= t.size() && s.compare(s.size() - t.size(), t.size(), t) == 0;
}

}  // namespace

lidar::DecoderOptions decoder_options(const DatasetOptions& options) {
  lidar::DecoderOptions o;
  o.model = options.lidar_model;
  o.calibration_path = options.lidar_calibration;
  return o;
}

const bag::Topic* choose_packet_topic(const bag::Reader& r, const DatasetOptions& options, std::uint32_t& index) {
  std::vector<std::uint32_t> packet_topics;
  bool clouds = false;
  for (std::uint32_t k = 0; k < r.topics().size(); ++k) {
    const bag::Topic& t = r.topics()[k];
    if (!options.points_topic.empty() && t.name == options.points_topic) {
      if (!ros::packet_vendor(t.type)) return nullptr;  // a cloud topic, or a wrong one: choose() says which
      index = k;
      return &t;
    }
    if (ros::packet_vendor(t.type)) packet_topics.push_back(k);
    clouds |= t.type == "sensor_msgs/PointCloud2";
  }
  if (!options.points_topic.empty() || clouds || packet_topics.empty()) return nullptr;
  // An Ouster driver records its IMU's packets in the same message type, on a topic named so.
  if (packet_topics.size() > 1)
    packet_topics.erase(std::remove_if(packet_topics.begin(), packet_topics.end(),
                                       [&](std::uint32_t k) { return r.topics()[k].name.find("imu") != std::string::npos; }),
                        packet_topics.end());
  if (packet_topics.empty()) return nullptr;
  if (packet_topics.size() > 1) {
    std::string have;
    for (std::uint32_t k : packet_topics) have += " " + r.topics()[k].name;
    throw Error(r.path() + ": several LiDAR packet topics:" + have + "; choose one with --points-topic");
  }
  index = packet_topics.front();
  return &r.topics()[index];
}

std::unique_ptr<PacketScans> open_packet_scans(bag::Reader& r, std::uint32_t topic, const DatasetOptions& options) {
  const bag::Topic& t = r.topics()[topic];
  lidar::DecoderOptions o = decoder_options(options);
  const lidar::Vendor vendor = *ros::packet_vendor(t.type);
  std::vector<bag::MessageRef> messages;
  for (const bag::MessageRef& m : r.messages())
    if (m.topic == topic) messages.push_back(m);
  // An Ouster driver publishes the sensor's metadata (its calibration) once, as a string.
  if (vendor == lidar::Vendor::Ouster && o.calibration_path.empty()) {
    for (const bag::MessageRef& m : r.messages()) {
      const bag::Topic& s = r.topics()[m.topic];
      if (ros::is_lidar_metadata(s.type) && ends_with(s.name, "metadata")) {
        o.calibration_text = ros::decode_string(r.read(m), s.encoding, r.path() + ": " + s.name);
        break;
      }
    }
  }
  if (messages.empty()) throw Error(r.path() + ": " + t.name + " has no messages, so no scans");
  return std::make_unique<PacketScans>(std::make_unique<BagPackets>(r, std::move(messages), r.path()), vendor, o);
}

void describe_packet_sensor(const PacketScans& scans, Dataset& ds) {
  const lidar::SensorInfo& s = scans.sensor();
  const lidar::DecodeCounts& c = scans.counts();
  if (scans.size() == 0)
    throw Error(ds.dir + ": the " + std::string(lidar::vendor_name(scans.vendor())) + " packets gave no sweep (" + std::to_string(c.packets) +
                " packets, " + std::to_string(c.skipped) + " skipped" + (c.last_problem.empty() ? "" : ": " + c.last_problem) + ")");
  ds.meta.sensor.model = s.vendor + " " + s.model;
  ds.meta.sensor.beams = std::max(1, s.channels);
  ds.meta.sensor.point_order = "any";
  ds.meta.sensor.vertical_angles_deg = s.elevation_deg;
  std::sort(ds.meta.sensor.vertical_angles_deg.begin(), ds.meta.sensor.vertical_angles_deg.end());
  if (s.rotation_hz > 0) ds.meta.sensor.rate_hz = s.rotation_hz;
  ds.point_times_in_clouds = true;
  RecordingInfo& info = ds.recording_info;
  info.lidar = format_text("%s %s, %d channels, %.1f Hz: %zu sweeps from %zu packets (%zu skipped%s%s), median %zu points a sweep",
                           s.vendor.c_str(), s.model.c_str(), s.channels, s.rotation_hz, scans.size(), c.packets, c.skipped,
                           c.last_problem.empty() ? "" : ": ", c.last_problem.c_str(), scans.median_points());
  info.point_times = "from the packets: each firing's time in its sweep";
  if (scans.partial_sweeps() > 0)
    info.notes.push_back(std::to_string(scans.partial_sweeps()) +
                         " part rotation(s) where the recording starts or stops (less than half a sweep's points) left out");
}

Dataset open_pcap_recording(const std::string& path, const DatasetOptions& options) {
  lidar::PcapReader reader = lidar::PcapReader::open_file(path);
  struct Port {
    std::size_t count = 0;
    std::uint64_t bytes = 0;
    std::optional<lidar::Vendor> vendor;
    double first_s = 0, last_s = 0, max_gap_s = 0;
  };
  std::map<std::uint16_t, Port> ports;
  std::vector<lidar::UdpDatagram> datagrams;
  for (lidar::UdpDatagram d; reader.next(d);) {
    Port& p = ports[d.destination_port];
    const double t = ns_to_seconds(d.stamp_ns);
    if (p.count == 0) p.vendor = lidar::vendor_of_packet(d.payload), p.first_s = t;
    p.max_gap_s = std::max(p.max_gap_s, p.count ? t - p.last_s : 0.0);
    p.last_s = t;
    ++p.count;
    p.bytes += d.payload.size();
    datagrams.push_back(d);
  }
  // The LiDAR: the port whose packets a vendor's mark names (with the most bytes), else the port with
  // the most bytes, taken as an Ouster's when its metadata is given.
  std::optional<lidar::Vendor> vendor;
  std::uint16_t lidar_port = 0;
  std::uint64_t most = 0;
  for (const auto& [port, p] : ports)
    if (p.vendor && p.bytes > most) vendor = p.vendor, lidar_port = port, most = p.bytes;
  if (!vendor && ends_with(options.lidar_calibration, ".json")) {
    for (const auto& [port, p] : ports)
      if (p.bytes > most) lidar_port = port, most = p.bytes;
    if (most > 0) vendor = lidar::Vendor::Ouster;
  }
  if (!vendor)
    throw Error(path + ": no LiDAR packets found: " + std::to_string(datagrams.size()) + " UDP datagrams on " + std::to_string(ports.size()) +
                " ports, none a Velodyne, Hesai or RoboSense packet; for an Ouster capture pass its metadata with --lidar-calibration FILE.json");
  // RoboSense sends its calibration (DIFOP) from a second port: the decoder takes both.
  std::vector<ros::LidarPacket> packets;
  for (const lidar::UdpDatagram& d : datagrams)
    if (d.destination_port == lidar_port || (*vendor == lidar::Vendor::RoboSense && ports[d.destination_port].vendor == vendor))
      packets.push_back({d.stamp_ns, d.payload});

  Dataset ds;
  ds.dir = path;
  ds.layout = DatasetLayout::Recording;
  RecordingInfo& info = ds.recording_info;
  info.format = reader.format();
  for (const auto& [port, p] : ports) {
    RecordingInfo::TopicUse u;
    u.name = "udp port " + std::to_string(port);
    u.type = p.vendor ? std::string(lidar::vendor_name(*p.vendor)) + " packets" : port == lidar_port ? "Ouster packets" : "UDP";
    u.count = p.count;
    u.first_s = p.first_s, u.last_s = p.last_s, u.max_gap_s = p.max_gap_s;
    if (p.count > 1 && p.last_s > p.first_s) u.rate_hz = static_cast<double>(p.count - 1) / (p.last_s - p.first_s);
    if (port == lidar_port) u.use = "scans";
    info.topics.push_back(u);
  }
  const lidar::PcapCounts& pc = reader.counts();
  if (pc.not_udp + pc.fragments + pc.cut_short + pc.malformed > 0)
    info.notes.push_back(format_text("%zu of the capture's %zu records are not whole UDP datagrams (%zu other protocols, %zu fragments, %zu cut "
                                     "short, %zu malformed)%s%s",
                                     pc.not_udp + pc.fragments + pc.cut_short + pc.malformed, pc.records, pc.not_udp, pc.fragments,
                                     pc.cut_short, pc.malformed, pc.last_problem.empty() ? "" : ": ", pc.last_problem.c_str()));
  auto rec = std::make_shared<RecordingScans>();
  rec->path = path;
  rec->packets = std::make_unique<PacketScans>(std::make_unique<PcapPackets>(std::move(reader), std::move(packets), path), *vendor,
                                               decoder_options(options));
  describe_packet_sensor(*rec->packets, ds);
  for (std::size_t i = 0; i < rec->packets->size(); ++i) {
    ds.times.push_back(ns_to_seconds(rec->packets->stamp_ns(i)));
    ds.frame_ids.push_back(static_cast<long>(i));
  }
  ds.recording = std::move(rec);
  return ds;
}

}  // namespace pl
