// A recording's LiDAR packets as scans. Opening decodes every packet once, to find the sweeps and
// where each begins; loading a scan decodes its packets again. A decoder kept between loads serves
// scans in order at the cost of one decode; a jump back starts a new decoder a few sweeps earlier
// (so that what a decoder learns from the stream, a rotation rate or a calibration packet, is known).
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "pl/lidar/decoder.hpp"
#include "pl/recordings/dataset.hpp"
#include "pl/recordings/packet_msgs.hpp"

namespace pl {

// Where packets come from: numbered units (a scan message's packets, a pcap record) read on demand.
class PacketStream {
 public:
  virtual ~PacketStream() = default;
  virtual std::size_t units() const = 0;
  // The packets of unit u, stamped (a packet without its own stamp takes the unit's recording time).
  // The views stay valid until the next call.
  virtual std::vector<ros::LidarPacket> packets(std::size_t u) = 0;
  virtual std::string where(std::size_t u) const = 0;  // "FILE: TOPIC message N", for messages
};

class PacketScans {
 public:
  PacketScans(std::unique_ptr<PacketStream> stream, lidar::Vendor vendor, lidar::DecoderOptions options);
  std::size_t size() const { return stamps_.size(); }
  std::int64_t stamp_ns(std::size_t i) const { return stamps_.at(i); }
  const lidar::SensorInfo& sensor() const { return sensor_; }
  const lidar::DecodeCounts& counts() const { return counts_; }  // of the pass made on opening
  lidar::Vendor vendor() const { return vendor_; }
  std::size_t partial_sweeps() const { return partial_; }  // at the start or end, left out
  std::size_t median_points() const { return median_points_; }
  // Sweep i as a scan: one return a firing (the strongest, where the sensor reports several), rings
  // bottom to top, times from the sweep's stamp.
  Frame frame(std::size_t i);
  lidar::Sweep sweep(std::size_t i);

 private:
  void restart(std::size_t unit);
  std::unique_ptr<PacketStream> stream_;
  lidar::Vendor vendor_;
  lidar::DecoderOptions options_;
  lidar::SensorInfo sensor_;
  lidar::DecodeCounts counts_;
  std::vector<std::int64_t> stamps_;
  std::size_t partial_ = 0, median_points_ = 0;
  std::vector<std::size_t> start_unit_;  // the unit whose packets begin sweep i
  std::unique_ptr<lidar::PacketDecoder> cursor_;
  std::size_t next_unit_ = 0;
  std::int64_t emitted_ = 0;  // the latest stamp the decoder has given
  std::vector<lidar::Sweep> ready_;  // decoded, not yet asked for
};

// One return a firing: where a sweep holds the strongest returns, those (and returns reported once as
// both, or as the strongest and the first or last); else the last; else all.
Frame frame_of_sweep(const lidar::Sweep& sweep, const lidar::SensorInfo& sensor);

}  // namespace pl
