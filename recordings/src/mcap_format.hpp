// MCAP's framing (https://mcap.dev/spec), shared by the reader (bag_mcap.cpp) and the writer
// (mcap_writer.cpp): the magic at both ends of a file and the record opcodes they use.
#pragma once

#include <cstdint>
#include <string_view>

namespace pl::mcap_format {

constexpr std::string_view kMagic("\x89MCAP0\r\n", 8);

enum Op : std::uint8_t {
  kHeader = 0x01,
  kFooter = 0x02,
  kSchema = 0x03,
  kChannel = 0x04,
  kMessage = 0x05,
  kChunk = 0x06,
  kMessageIndex = 0x07,
  kChunkIndex = 0x08,
  kStatistics = 0x0b,
  kSummaryOffset = 0x0e,
  kDataEnd = 0x0f,
};

}  // namespace pl::mcap_format
