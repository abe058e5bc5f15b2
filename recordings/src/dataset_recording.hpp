// The part of a recording's dataset that stays open: its reader and where each scan lies.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "pl/lidar/decoder.hpp"
#include "pl/recordings/bag.hpp"
#include "pl/recordings/dataset.hpp"
#include "pl/recordings/ros_msgs.hpp"

namespace pl {

class PacketScans;

// A recording's scans, read on demand: PointCloud2 messages, or a LiDAR's packets.
class RecordingScans {
 public:
  ~RecordingScans();
  std::unique_ptr<bag::Reader> reader;
  std::vector<bag::MessageRef> scans;  // in stamp order
  bag::Encoding encoding = bag::Encoding::Ros1;
  std::string path, topic;
  ros::SweepBounds sweep;       // from the scans' rate
  bool rings_from_order = false;  // no ring field, but the points come laser by laser
  std::vector<double> beam_table;  // no ring field, points in any order: rings from their elevations
  std::unique_ptr<PacketScans> packets;  // set when the scans are a LiDAR's packets
  std::mutex mutex;
};

// Scan i of the recording, decoded from its PointCloud2 or its packets (with `with_rings`, rings from the cloud's ring
// field, or from its points' order where it has none but comes laser by laser; times from its time
// field). Safe from several threads (one read at a time).
Frame recording_frame(RecordingScans& recording, std::size_t i, bool with_rings);

// Packet recordings (dataset_packets.cpp). The LiDAR packet topic the scans come from: the one
// --points-topic names, or the only one where the recording has no PointCloud2 topic; else nullptr.
const bag::Topic* choose_packet_topic(const bag::Reader& r, const DatasetOptions& options, std::uint32_t& index);
std::unique_ptr<PacketScans> open_packet_scans(bag::Reader& r, std::uint32_t topic, const DatasetOptions& options);
lidar::DecoderOptions decoder_options(const DatasetOptions& options);
// The sensor's model, beams, rate and beam table into the dataset's meta, and a line for pl-dataset info.
void describe_packet_sensor(const PacketScans& scans, Dataset& ds);
// A pcap capture of a LiDAR's UDP packets as a dataset (scans only).
Dataset open_pcap_recording(const std::string& path, const DatasetOptions& options);

}  // namespace pl
