// Fuzz target: a capture file as PcapReader sees it (a pcap or pcapng from anywhere: tcpdump,
// Wireshark, a truncated copy, a damaged disk). Refusing with pl::Error is the reader's job; every
// datagram that comes back must lie inside the file's bytes, within its record, and the counts
// must agree with what came out.
#include <cstdint>
#include <cstdlib>
#include <string>

#include "pl/common/error.hpp"
#include "pl/lidar/pcap.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::string bytes(reinterpret_cast<const char*>(data), size);
  try {
    auto reader = pl::lidar::PcapReader::from_bytes(bytes, "fuzz.pcap");
    std::size_t datagrams = 0;
    std::uint64_t last_offset = 0;
    for (pl::lidar::UdpDatagram d; reader.next(d);) {
      ++datagrams;
      // The payload is a view into the reader's copy of the bytes: the same length as the input.
      if (d.offset >= size || d.payload.size() > size - d.offset) std::abort();
      if (datagrams > 1 && d.offset <= last_offset) std::abort();
      last_offset = d.offset;
    }
    const auto& c = reader.counts();
    if (c.datagrams != datagrams || c.records < datagrams) std::abort();
    if (c.records != datagrams + c.not_udp + c.fragments + c.malformed + c.cut_short &&
        c.records + 1 != datagrams + c.not_udp + c.fragments + c.malformed + c.cut_short)
      std::abort();  // each record counted once (a file ending inside a record adds one cut short)
  } catch (const pl::Error&) {
  }
  return 0;
}
