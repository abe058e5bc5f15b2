// The part of a recording's dataset that stays open: its reader and where each scan lies.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>

#include "pl/lidar/decoder.hpp"
#include "pl/recordings/bag.hpp"
#include "pl/recordings/dataset.hpp"

namespace pl {

// Scan i of the recording, decoded from its PointCloud2 (with `with_rings`, rings from the cloud's ring
// field, or from its points' order where it has none but comes laser by laser; times from its time
// field). Safe from several threads (one read at a time).
Frame recording_frame(RecordingScans& recording, std::size_t i, bool with_rings);

class PacketScans;

// Packet recordings (dataset_packets.cpp). The LiDAR packet topic the scans come from: the one
// --points-topic names, or the only one where the recording has no PointCloud2 topic; else nullptr.
const bag::Topic* choose_packet_topic(const bag::Reader& r, const DatasetOptions& options, std::uint32_t& index);
std::unique_ptr<PacketScans> open_packet_scans(bag::Reader& r, std::uint32_t topic, const DatasetOptions& options);
lidar::DecoderOptions decoder_options(const DatasetOptions& options);
// The sensor's model, beams, rate and beam table into the dataset's meta, and a line for pl-dataset info.
void describe_packet_sensor(const PacketScans& scans, Dataset& ds);

}  // namespace pl
