// Hesai point-cloud packets: where each model keeps its fields, which model a packet's header names,
// and a checked view of one packet (every offset it hands out lies inside the packet).
//
// Three header shapes: none (Pandar40P: the first block's 0xFFEE marker opens the packet), 8 bytes
// (Pandar64: 0xEEFF, lasers, blocks, distance unit) and 12 bytes (XT and QT: 0xEEFF, protocol
// version, lasers, blocks, distance unit, return count, flags). The tail carries the return mode, the
// motor speed and the sensor's clock (date to the second, then microseconds).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

namespace pl::lidar {

enum class HesaiModel : std::uint8_t { Pandar40P, Pandar64, PandarQT64, PandarQT128, PandarXT16, PandarXT32, PandarXT32M };

struct HesaiLayout {
  HesaiModel model;
  const char* name;       // as SensorInfo::model spells it
  int channels;
  int blocks;
  int header_bytes;       // 0 (Pandar40P), 8 (Pandar64) or 12 (XT, QT): where the first block starts
  int protocol_major;     // the 12-byte header's protocol version (6: XT, 3: QT); 0 for the others
  int block_marker;       // 2: each block opens with 0xFFEE (Pandar40P), else 0
  int unit_bytes;         // per channel: distance (2), reflectivity (1), then 1 reserved byte on XT and QT
  int tail;               // where the tail starts
  int return_mode_at;     // tail-relative offsets of its fields
  int motor_rpm_at;
  int micros_at;
  int date_at;
  int loop_flag_at;       // QT128: which firing sequence a dual-return packet holds; -1: none
  int min_bytes;          // the packet's length without its optional trailer (UDP sequence, signature)
  int max_bytes;          // and with it
  double min_range_m;     // the model's measuring range (its data sheet; the makers' driver applies it too)
  double max_range_m;

  int block_bytes() const { return block_marker + 2 + channels * unit_bytes; }
};

const HesaiLayout& hesai_layout(HesaiModel model);
// The layout of the model named (case-insensitive, "Pandar" optional: "XT32" is PandarXT32); nullptr if none.
const HesaiLayout* find_hesai_layout(std::string_view name);
// All model names, for messages ("PandarXT16, PandarXT32, ...").
std::string hesai_model_names();

// The model a packet's header names; nullptr when it names none of ours (`why` says what was seen).
// Throws pl::Error when the header is a Hesai model's this decoder does not read (AT128, Pandar128, OT128).
const HesaiLayout* identify_hesai_packet(std::string_view packet, std::string& why);

// One packet, checked against its model's layout by read_hesai_packet.
class HesaiPacket {
 public:
  const HesaiLayout* layout = nullptr;
  int returns = 1;              // blocks per firing: 1, 2 or 3
  std::uint8_t return_mode = 0; // the tail's code (0x37 strongest, 0x39 last and strongest, ...)
  double unit_m = 0.004;        // distance unit
  std::int64_t time_ns = 0;     // the sensor's clock: UTC date and microseconds
  int motor_rpm = 0;
  int loop = 0;                 // QT128 in dual-return modes: 1 for firing sequence 1, else 0

  std::uint16_t azimuth_cdeg(int block) const { return u16(block_start(block) + layout->block_marker); }
  std::uint16_t distance(int block, int channel) const { return u16(unit_start(block, channel)); }
  std::uint8_t reflectivity(int block, int channel) const { return bytes_[unit_start(block, channel) + 2]; }

 private:
  friend bool read_hesai_packet(const HesaiLayout&, std::string_view, HesaiPacket&, std::string&);
  const std::uint8_t* bytes_ = nullptr;
  std::size_t block_start(int block) const {
    return static_cast<std::size_t>(layout->header_bytes + block * layout->block_bytes());
  }
  std::size_t unit_start(int block, int channel) const {
    return block_start(block) + static_cast<std::size_t>(layout->block_marker + 2 + channel * layout->unit_bytes);
  }
  std::uint16_t u16(std::size_t at) const {
    return static_cast<std::uint16_t>(bytes_[at] | (bytes_[at + 1] << 8));
  }
};

// Checks the packet against the layout (length, markers, header counts, return mode, azimuths below
// 360 deg, a calendar date) and fills `out`, which points into `packet`; false with `problem` set if not.
bool read_hesai_packet(const HesaiLayout& layout, std::string_view packet, HesaiPacket& out, std::string& problem);

// Blocks per firing for a return-mode code; 0 for a code no Hesai model sends.
int hesai_returns_of(std::uint8_t return_mode);

}  // namespace pl::lidar
