// Packet captures (tcpdump, Wireshark, the Ouster SDK's recordings) -> the UDP datagrams in them,
// each with its capture time and ports, for the packet decoders.
//   Files: classic pcap (either byte order, microsecond or nanosecond timestamps) and pcapng
// (sections of either byte order; enhanced, simple and obsolete packet blocks; each interface's
// timestamp resolution and offset). Links: Ethernet (with VLAN tags), Linux cooked (SLL, SLL2), raw
// IP and BSD loopback; then IPv4 or IPv6 (no extension headers) and UDP. Checksums are not checked
// (captures of offloading hosts carry wrong ones).
//   What is not one whole UDP datagram is skipped and counted by why: other protocols, IP fragments
// (never reassembled: a lidar packet fits one datagram), datagrams the capture cut short (its snap
// length), headers that contradict themselves; the next record is read as usual. A file whose
// framing is broken (a bad magic, a record or block longer than any packet, a pcapng block whose
// two lengths disagree) is refused with pl::Error "FILE: offset N: PROBLEM": past such a record
// nothing can be found again. A last record the file ends inside (a capture stopped mid-write) ends
// the reading, counted as cut short.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>

namespace pl::lidar {

struct UdpDatagram {
  std::int64_t stamp_ns = 0;  // capture time, nanoseconds since 1970 (0 in a pcapng simple packet block)
  std::uint16_t source_port = 0;
  std::uint16_t destination_port = 0;
  std::string_view payload;   // the UDP payload; valid while the reader lives
  std::uint64_t offset = 0;   // where its record begins in the file
};

struct PcapCounts {
  std::size_t records = 0;    // captured packets read
  std::size_t datagrams = 0;  // UDP datagrams given out
  std::size_t not_udp = 0;    // other link types and protocols (ARP, TCP, ICMP, IPv6 extension headers)
  std::size_t fragments = 0;  // IP fragments
  std::size_t cut_short = 0;  // captured shorter than sent, or a record the file ends inside
  std::size_t malformed = 0;  // headers that contradict themselves or their record
  std::string last_problem;   // why the last record was skipped, with its offset
};

class PcapReader {
 public:
  // The file, mapped into memory. Throws pl::Error naming it when unreadable or not a capture.
  static PcapReader open_file(const std::string& path);
  // Bytes held (a test's, a fuzzer's); `name` stands for the file in messages.
  static PcapReader from_bytes(std::string bytes, const std::string& name);
  PcapReader(PcapReader&&) noexcept;
  PcapReader& operator=(PcapReader&&) noexcept;
  ~PcapReader();

  // The next UDP datagram, false at the end. Throws pl::Error "FILE: offset N: PROBLEM" when the
  // file's framing is broken.
  bool next(UdpDatagram& out);
  const PcapCounts& counts() const;
  const char* format() const;  // "pcap" or "pcapng"

 private:
  struct Impl;
  explicit PcapReader(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

// True when the file begins as a pcap or pcapng file does (a look at its first four bytes).
bool is_pcap(const std::string& path);

}  // namespace pl::lidar
