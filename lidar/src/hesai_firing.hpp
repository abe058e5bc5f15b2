// When each laser of a Hesai packet fired, relative to the packet's clock: a block's firing round plus
// the channel's offset within the round (the makers' manuals, appendix "Absolute Time"; the QT128's
// offsets depend on which of its two firing sequences the block holds).
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "hesai_packet.hpp"

namespace pl::lidar {

// Nanoseconds from the packet's time to the firing of `channel` in `block`, with `returns` blocks per
// firing round; `loop` is the QT128's firing sequence flag of a dual-return packet.
std::int32_t hesai_firing_offset_ns(HesaiModel model, int block, int channel, int returns, int loop);

// The offsets of one model, tabled per return count and firing sequence on first use.
class HesaiFiringTable {
 public:
  explicit HesaiFiringTable(const HesaiLayout& layout) : layout_(&layout) {}
  // Offsets of the packet's every (block, channel), block-major.
  const std::vector<std::int32_t>& offsets(const HesaiPacket& packet);
  // The earliest offset in the firing round starting at `first_block`.
  std::int32_t earliest(const HesaiPacket& packet, int first_block);

 private:
  struct Entry {
    std::vector<std::int32_t> offsets;
    std::vector<std::int32_t> earliest;  // per block: the round's earliest (set at a round's first block)
  };
  Entry& entry(const HesaiPacket& packet);

  const HesaiLayout* layout_;
  std::array<Entry, 6> entries_;  // returns 1..3 x firing sequence 0..1
};

}  // namespace pl::lidar
