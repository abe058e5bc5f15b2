// RoboSense's packets, as the makers' user manuals (RS-LiDAR-16, RS-Helios-16P, RS-Helios) and drivers
// lay them out. Both kinds are 1248 bytes, big-endian:
//   MSOP (the measurements): a 42-byte header (its time at byte 20), 12 blocks of 100 bytes (0xFFEE,
//   the azimuth of the block's first firing in 0.01°, 32 slots of distance u16 + reflectivity u8),
//   6 bytes of tail. The RS-LiDAR-16 header opens with 8 magic bytes and a calendar time; the Helios
//   header with 4 and seconds + microseconds since 1970, and says its distance unit at byte 17.
//   DIFOP (the device's settings, once a second): the rotation rate (rpm) at byte 8, the return mode at
//   300 and the lasers' angles: a Helios's as sign + u16 in 0.01° (elevations at 468, azimuth offsets at
//   564), an RS-LiDAR-16's elevations as u24 in 0.0001° at 1165 (its first 8 lasers point down).
// What a model is (slot timing, lens offset) and how one packet's slots map to lasers and returns.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

namespace pl::lidar::robosense {

constexpr std::size_t kPacketBytes = 1248;
constexpr std::size_t kBlocks = 12;
constexpr std::size_t kSlots = 32;
constexpr std::size_t kFirstBlock = 42;
constexpr std::size_t kBlockBytes = 100;
constexpr std::size_t kTimeAt = 20;         // MSOP: the time of the packet's first firing
constexpr std::size_t kRangeUnitAt = 17;    // Helios MSOP: 0 = 5 mm, 1 = 2.5 mm
constexpr std::size_t kRpmAt = 8;           // DIFOP
constexpr std::size_t kReturnModeAt = 300;  // DIFOP
constexpr std::size_t kHeliosElevationsAt = 468, kHeliosOffsetsAt = 564, kRs16PitchAt = 1165;

constexpr unsigned char kRs16Magic[8] = {0x55, 0xAA, 0x05, 0x0A, 0x5A, 0xA5, 0x50, 0xA0};
constexpr unsigned char kHeliosMagic[4] = {0x55, 0xAA, 0x05, 0x5A};
constexpr unsigned char kDifopMagic[8] = {0xA5, 0xFF, 0x00, 0x5A, 0x11, 0x11, 0x55, 0x55};

enum class Family { Rs16, Helios };  // which MSOP header and DIFOP layout

struct Model {
  std::string_view name;
  Family family;
  int lasers;                         // 16 or 32
  float firing_us;                    // one firing of every laser
  float lens_offset_m;                // the optics' distance from the rotation axis
  bool two_firings;                   // single return: a block's 32 slots are two firings of 16 lasers
  float single_block_us;              // single return: from one block to the next
  std::array<float, kSlots> slot_us;  // the maker's firing table: each slot's time after the block's first
};

// A model by its name as SensorInfo spells it, or one of its other names; nullptr when unknown.
const Model* find_model(std::string_view name);
const Model& model_for(Family family, int lasers);  // Rs16: RS-LiDAR-16; Helios: Helios-16P or Helios-32
std::string model_names();                          // "RS-LiDAR-16, Helios-16P, Helios-32"

// How the 32 slots of a block map to lasers, returns, azimuths and times in one return mode.
struct SlotPlan {
  std::array<std::uint8_t, kSlots> laser{};
  std::array<bool, kSlots> second_return{};  // dual return in halves: slots 16-31
  std::array<float, kSlots> fraction{};      // of the azimuth step to the next block, after the block's azimuth
  std::array<float, kSlots> time_us{};       // after the block's time
  float block_us = 0;                        // from one block (or pair, block_pairs) to the next
  int step_firings = 1;                      // from one block to the next: the nominal step's multiple
  bool block_pairs = false;                  // dual return in block pairs (Helios-32): odd blocks, second returns
};
SlotPlan plan_slots(const Model& m, bool dual);

inline std::uint32_t be16(const unsigned char* p) { return static_cast<std::uint32_t>(p[0]) << 8 | p[1]; }
inline std::uint32_t be24(const unsigned char* p) { return be16(p) << 8 | p[2]; }
inline std::uint64_t be32(const unsigned char* p) { return static_cast<std::uint64_t>(be16(p)) << 16 | be16(p + 2); }

}  // namespace pl::lidar::robosense
