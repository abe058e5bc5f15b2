// A recording whose scans are a LiDAR's packets (a driver's packet topic, or a pcap file): the topic
// to decode, the decoder's options from the dataset's, and what the sensor tells the dataset.
#include <algorithm>
#include <cstdio>

#include "dataset_recording.hpp"
#include "packet_scans.hpp"
#include "pl/common/error.hpp"
#include "pl/common/text.hpp"

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
      if (ros::is_lidar_metadata(s.type) && s.name.size() >= 8 && s.name.compare(s.name.size() - 8, 8, "metadata") == 0) {
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
  info.lidar = format_text("%s %s, %d channels, %.1f Hz: %zu sweeps from %zu packets (%zu skipped%s%s), %zu points a sweep",
                           s.vendor.c_str(), s.model.c_str(), s.channels, s.rotation_hz, scans.size(), c.packets, c.skipped,
                           c.last_problem.empty() ? "" : ": ", c.last_problem.c_str(), c.points / std::max<std::size_t>(1, c.sweeps));
  info.point_times = "from the packets: each firing's time in its sweep";
}

}  // namespace pl
