// The Velodyne models decoded here and how each lays out its 1206-byte data packet: 12 blocks of 100
// bytes (a 2-byte flag naming the block's bank of 32 lasers, the azimuth in 0.01 degree, then 32
// returns of a 2-byte distance and a 1-byte reflectivity), the sensor's time (4 bytes, microseconds
// past the hour) and two factory bytes (return mode, product id; the HDL-64E sends status bytes there).
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <string_view>

namespace pl::lidar {

constexpr std::size_t kVelodynePacketBytes = 1206;
constexpr int kVelodyneBlocks = 12;
constexpr int kVelodyneSlots = 32;  // returns in a block
constexpr std::size_t kVelodyneTimeOffset = 1200;
constexpr std::size_t kVelodyneReturnModeOffset = 1204;
constexpr std::size_t kVelodyneProductOffset = 1205;

// Factory byte 1204.
constexpr std::uint8_t kVelodyneStrongest = 0x37;
constexpr std::uint8_t kVelodyneLast = 0x38;
constexpr std::uint8_t kVelodyneDual = 0x39;

enum class VelodyneFamily { Vlp16, Vlp32C, Hdl32E, Hdl64E_S2, Hdl64E_S3, Vls128 };

struct VelodyneModel {
  const char* name;              // as SensorInfo::model spells it: "VLP-16", "HDL-64E S3", ...
  std::uint8_t product_id;       // factory byte 1205; 0: the model sends none (HDL-64E)
  int channels;
  float distance_unit_m;         // one count of a return's distance
  const char* calibration_file;  // the maker's file, named as the reference driver ships it
  VelodyneFamily family;
};

const VelodyneModel* velodyne_model_by_product(std::uint8_t product_id);
// Spelling is loose: "VLP-16", "vlp16", "HDL-64E S3", "hdl64e_s3", "VLP32" (= VLP-32C).
const VelodyneModel* velodyne_model_by_name(std::string_view name);
std::string velodyne_model_names();
// A Velodyne product whose packets are not decoded here (VLP-32A/B, Velarray), or nullptr.
const char* velodyne_other_product(std::uint8_t product_id);

// Where each of a packet's blocks and slots sits in time and among the lasers, for one model in one
// return mode. Blocks of one column fire together at one azimuth; in dual mode each firing's second
// return sits in a partner block.
struct VelodyneLayout {
  struct Block {
    bool used = false;         // false: padding (the VLS-128's last four blocks in dual mode)
    std::uint16_t flag = 0;    // the flag it must carry: 0xEEFF, 0xDDFF, 0xCCFF or 0xBBFF
    std::uint8_t column = 0;   // in packet order
    std::uint8_t partner = 0;  // dual mode: the block with the other return; single: itself
  };
  bool dual = false;
  std::array<Block, kVelodyneBlocks> blocks{};
  int columns = 0;
  float column_us = 0;   // from one column's first firing to the next one's
  float toh_lag_us = 0;  // the packet's time stamp after its first firing
  using Table = std::array<std::array<float, kVelodyneSlots>, kVelodyneBlocks>;
  std::array<std::array<std::uint16_t, kVelodyneSlots>, kVelodyneBlocks> laser{};
  Table offset_us{};  // firing time after its column's first firing
  // A firing's share of the azimuth step to the next column is step * interp_mul / interp_div, in
  // the reference decoder's float order, so that a share landing on 0.005 degree rounds alike.
  Table interp_mul{};
  float interp_div = 1;
  // Each firing's time after the packet's time stamp (ns): its column's, its own offset, less the lag.
  std::array<std::array<std::int32_t, kVelodyneSlots>, kVelodyneBlocks> firing_ns{};
};

VelodyneLayout velodyne_layout(const VelodyneModel& model, bool dual);

}  // namespace pl::lidar
