// LiDAR packets -> sweeps. A sensor sends its measurements as UDP packets (a ROS driver records them as
// VelodyneScan, PandarScan, RobosenseScan or Ouster PacketMsg messages; a pcap file holds them as
// captured); a decoder turns that stream into sweeps, one per rotation, cut where the makers' drivers
// cut them. Each point keeps the sensor's channel, its time within the sweep and its intensity.
// Packets that are damaged or not the sensor's are skipped and counted, never read past their end.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace pl::lidar {

// What a return is, where a sensor reports more than one per firing (dual and triple return modes).
// The same meanings, in the same order, as the reference decoder's codes (tier4/nebula), so that a
// reference cloud compares directly.
enum class ReturnType : std::uint8_t {
  Unknown = 0, Last, First, Strongest, FirstWeak, LastWeak,
  Identical,  // dual mode, both returns the same: reported once
  Second, SecondStrongest, FirstStrong, LastStrong
};

// One return, in the sensor frame (x forward, y left, z up; the makers' drivers' frame).
struct Point {
  float x = 0, y = 0, z = 0;
  float intensity = 0;        // the sensor's reflectivity, 0-255
  std::uint16_t channel = 0;  // the laser as the maker numbers it (the calibration's order)
  ReturnType return_type = ReturnType::Unknown;  // single-return modes: Strongest, Last or First
  float azimuth_deg = 0;      // the sensor's azimuth of the firing, corrected, [0, 360)
  float elevation_deg = 0;
  float distance_m = 0;
  double time_s = 0;          // seconds from the sweep's stamp
};

struct Sweep {
  std::int64_t stamp_ns = 0;  // the time of its first firing (the sensor's clock, or the packet's receive time)
  std::vector<Point> points;
};

// What a decoder knows of its sensor once it has seen a packet (or its metadata).
struct SensorInfo {
  std::string vendor;  // "Velodyne", "Hesai", "RoboSense", "Ouster"
  std::string model;   // "VLP-16", "PandarXT32", "Helios-16P", "OS-1-64", ...
  int channels = 0;
  double rotation_hz = 0;  // 0 until the decoder has seen enough packets to tell
  // Elevation of each channel (degrees, by channel number); ring_of_channel orders them bottom to top.
  std::vector<double> elevation_deg;
  std::vector<std::uint16_t> ring_of_channel;
};

struct DecodeCounts {
  std::size_t packets = 0;    // given to add()
  std::size_t skipped = 0;    // damaged, truncated or of another sensor: left out
  std::size_t sweeps = 0;
  std::size_t points = 0;
  std::string last_problem;   // why the last skipped packet was skipped
};

// Which decoder, and what it needs.
struct DecoderOptions {
  std::string model;             // a model name as SensorInfo::model spells it; empty: told by the packets
  std::string calibration_path;  // the maker's calibration file (Velodyne YAML, Hesai angle CSV, Ouster JSON)
  std::string calibration_text;  // the same as text (an Ouster recording's metadata topic); wins over the path
  double min_range_m = 0.3;      // returns nearer or farther are left out
  double max_range_m = 300.0;
  double cut_azimuth_deg = 0.0;  // a sweep ends where the azimuth crosses this (the drivers' default)
  void validate() const;         // throws pl::Error naming the field
};

class PacketDecoder {
 public:
  virtual ~PacketDecoder() = default;
  // One packet (the UDP payload) received at `stamp_ns`. Sweeps it completes are appended to `out`.
  // A packet that is damaged or of another sensor is skipped and counted. Throws pl::Error only when
  // the decoder cannot go on: the model the packets name needs a calibration it was not given (the
  // message names the file and --lidar-calibration), or the packets name a model it does not know.
  virtual void add(std::string_view packet, std::int64_t stamp_ns, std::vector<Sweep>& out) = 0;
  // The sweep still open (a partial rotation at the end of a recording), when it has points.
  virtual void finish(std::vector<Sweep>& out) = 0;
  virtual SensorInfo info() const = 0;
  const DecodeCounts& counts() const { return counts_; }

 protected:
  DecodeCounts counts_;
};

enum class Vendor { Velodyne, Hesai, RoboSense, Ouster };
const char* vendor_name(Vendor v);

// The vendor whose packets begin as this one does (Velodyne's 1206-byte data packets, Hesai's 0xEEFF
// header, RoboSense's MSOP and DIFOP headers); nullopt for others (Ouster's packets carry no mark:
// its metadata tells them).
std::optional<Vendor> vendor_of_packet(std::string_view packet);

// The decoder for a vendor's packets. Throws pl::Error when the calibration it needs is missing or
// unreadable: naming the file the model needs and the flag that gives it (--lidar-calibration).
std::unique_ptr<PacketDecoder> make_decoder(Vendor vendor, const DecoderOptions& options);

}  // namespace pl::lidar
