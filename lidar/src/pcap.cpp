// The capture file's framing: classic pcap records and pcapng blocks, each length checked against
// the bytes left before it is used; pcap_frames.cpp peels each record to its datagram.
#include "pl/lidar/pcap.hpp"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <limits>
#include <vector>

#include "pcap_frames.hpp"
#include "pl/common/error.hpp"

namespace pl::lidar {

namespace {

constexpr std::uint32_t kPcapMicro = 0xA1B2C3D4, kPcapNano = 0xA1B23C4D;
constexpr std::uint32_t kNgSection = 0x0A0D0D0A, kNgByteOrder = 0x1A2B3C4D;
constexpr std::uint32_t kNgInterface = 1, kNgObsoletePacket = 2, kNgSimplePacket = 3, kNgEnhancedPacket = 6;
constexpr std::uint32_t kMaxRecord = 256 * 1024;       // beyond any frame tcpdump writes (its snap length)
constexpr std::uint32_t kMaxBlock = 16 * 1024 * 1024;  // a pcapng block beyond this is damage

std::uint32_t swap32(std::uint32_t v) { return __builtin_bswap32(v); }

struct Interface {
  std::uint32_t link_type = 0;
  long double ns_per_tick = 1000;  // microseconds unless if_tsresol says otherwise
  std::int64_t offset_s = 0;
};

std::int64_t clamp_ns(long double ns) {
  constexpr auto kMax = static_cast<long double>(std::numeric_limits<std::int64_t>::max());
  if (!(ns < kMax) || !(ns > -kMax)) return ns < 0 ? -std::numeric_limits<std::int64_t>::max() : std::numeric_limits<std::int64_t>::max();
  return static_cast<std::int64_t>(ns);
}

}  // namespace

struct PcapReader::Impl {
  std::string name;
  std::string held;
  const char* mapped = nullptr;
  std::size_t mapped_size = 0;
  std::string_view bytes;
  bool ng = false;
  bool big = false;      // the current file or section is big-endian
  bool nano = false;     // classic pcap: nanosecond timestamps
  std::uint32_t link_type = 0;
  std::vector<Interface> interfaces;  // pcapng: the current section's
  std::size_t at = 0;
  PcapCounts counts;

  ~Impl() {
    if (mapped) munmap(const_cast<char*>(mapped), mapped_size);
  }

  [[noreturn]] void refuse(std::size_t offset, const std::string& problem) const {
    throw Error(name + ": offset " + std::to_string(offset) + ": " + problem);
  }

  std::uint32_t u32(std::size_t p) const {
    std::uint32_t v;
    std::memcpy(&v, bytes.data() + p, 4);
    return big ? swap32(v) : v;
  }
  std::uint16_t u16(std::size_t p) const {
    const auto a = static_cast<std::uint8_t>(bytes[p]), b = static_cast<std::uint8_t>(bytes[p + 1]);
    return static_cast<std::uint16_t>(big ? (a << 8 | b) : (b << 8 | a));
  }
  std::size_t left() const { return bytes.size() - at; }

  void open() {
    if (bytes.size() < 4) refuse(0, "not a pcap or pcapng file: " + std::to_string(bytes.size()) + " bytes");
    std::uint32_t magic;
    std::memcpy(&magic, bytes.data(), 4);
    if (magic == kNgSection) {
      ng = true;
      return;  // the section header is read as the first block
    }
    if (magic == kPcapMicro || magic == kPcapNano) big = false;
    else if (swap32(magic) == kPcapMicro || swap32(magic) == kPcapNano) big = true, magic = swap32(magic);
    else refuse(0, "not a pcap or pcapng file (magic 0x" + hex(magic) + ")");
    nano = magic == kPcapNano;
    if (bytes.size() < 24) refuse(0, "a pcap file header cut short");
    link_type = u32(20) & 0xFFFFu;
    at = 24;
  }

  static std::string hex(std::uint32_t v) {
    char s[9];
    std::snprintf(s, sizeof s, "%08x", v);
    return s;
  }

  void cut_short(std::size_t offset, const std::string& what) {
    ++counts.cut_short;
    counts.last_problem = "offset " + std::to_string(offset) + ": " + what;
    at = bytes.size();
  }

  // A captured frame: dissect it, count what it is; true when it gives a datagram.
  bool frame(std::size_t offset, std::uint32_t link, std::string_view data, std::uint32_t original, std::int64_t stamp_ns,
             UdpDatagram& out) {
    ++counts.records;
    pcap::Dissected d = pcap::dissect(link, data, original);
    switch (d.outcome) {
      case pcap::Outcome::Datagram:
        ++counts.datagrams;
        out.stamp_ns = stamp_ns;
        out.source_port = d.source_port;
        out.destination_port = d.destination_port;
        out.payload = d.payload;
        out.offset = offset;
        return true;
      case pcap::Outcome::NotUdp: ++counts.not_udp; break;
      case pcap::Outcome::Fragment: ++counts.fragments; break;
      case pcap::Outcome::CutShort: ++counts.cut_short; break;
      case pcap::Outcome::Malformed: ++counts.malformed; break;
    }
    counts.last_problem = "offset " + std::to_string(offset) + ": " + d.problem;
    return false;
  }

  bool next_record(UdpDatagram& out) {
    while (left() > 0) {
      const std::size_t offset = at;
      if (left() < 16) return cut_short(offset, "a record header the file ends inside"), false;
      const std::uint32_t sec = u32(at), frac = u32(at + 4), captured = u32(at + 8), original = u32(at + 12);
      if (captured > kMaxRecord) refuse(offset, "a record of " + std::to_string(captured) + " bytes, longer than any packet");
      if (left() - 16 < captured)
        return cut_short(offset, "a record of " + std::to_string(captured) + " bytes the file ends inside"), false;
      at += 16 + captured;
      const std::int64_t stamp = static_cast<std::int64_t>(sec) * 1'000'000'000 + static_cast<std::int64_t>(frac) * (nano ? 1 : 1000);
      if (frame(offset, link_type, bytes.substr(offset + 16, captured), original, stamp, out)) return true;
    }
    return false;
  }

  void section(std::size_t offset) {
    if (left() < 12) refuse(offset, "a pcapng section header cut short");
    std::uint32_t order;
    std::memcpy(&order, bytes.data() + at + 8, 4);
    if (order == kNgByteOrder) big = false;
    else if (swap32(order) == kNgByteOrder) big = true;
    else refuse(offset, "a pcapng section header without its byte-order magic");
    interfaces.clear();
  }

  void interface(std::size_t body, std::size_t end) {
    Interface i;
    if (end - body < 8) {
      ++counts.malformed;
      counts.last_problem = "offset " + std::to_string(body - 8) + ": an interface block cut short";
      interfaces.push_back(i);
      return;
    }
    i.link_type = u16(body);
    for (std::size_t p = body + 8; p + 4 <= end;) {
      const std::uint16_t code = u16(p), length = u16(p + 2);
      const std::size_t value = p + 4;
      if (code == 0 || length > end - value) break;
      if (code == 9 && length >= 1) {  // if_tsresol
        const auto r = static_cast<std::uint8_t>(bytes[value]);
        const int e = r & 0x7F;
        i.ns_per_tick = (r & 0x80) ? 1e9L / std::ldexp(1.0L, e) : 1e9L / std::pow(10.0L, e);
      } else if (code == 14 && length >= 8) {  // if_tsoffset, seconds
        i.offset_s = static_cast<std::int64_t>(static_cast<std::uint64_t>(u32(value + (big ? 0 : 4))) << 32 | u32(value + (big ? 4 : 0)));
      }
      p = value + ((length + 3u) & ~3u);
    }
    interfaces.push_back(i);
  }

  bool next_block(UdpDatagram& out) {
    while (left() > 0) {
      const std::size_t offset = at;
      if (left() < 12) return cut_short(offset, "a block header the file ends inside"), false;
      std::uint32_t type;
      std::memcpy(&type, bytes.data() + at, 4);
      if (type == kNgSection) section(offset);
      else type = u32(at);
      const std::uint32_t length = u32(at + 4);
      if (length < 12 || length % 4 != 0 || length > kMaxBlock)
        refuse(offset, "a pcapng block length of " + std::to_string(length));
      if (length > left()) return cut_short(offset, "a block of " + std::to_string(length) + " bytes the file ends inside"), false;
      if (u32(at + length - 4) != length) refuse(offset, "a pcapng block whose trailing length differs from its leading one");
      at += length;
      const std::size_t body = offset + 8, end = offset + length - 4;
      if (type == kNgInterface) interface(body, end);
      else if (type == kNgEnhancedPacket || type == kNgObsoletePacket || type == kNgSimplePacket)
        if (packet_block(type, offset, body, end, out)) return true;
    }
    return false;
  }

  bool packet_block(std::uint32_t type, std::size_t offset, std::size_t body, std::size_t end, UdpDatagram& out) {
    const std::size_t fixed = type == kNgSimplePacket ? 4 : 20;
    std::uint32_t id = 0, captured = 0, original = 0;
    std::uint64_t ticks = 0;
    if (end - body >= fixed) {
      if (type == kNgSimplePacket) {
        original = u32(body);
        captured = static_cast<std::uint32_t>(std::min<std::size_t>(original, end - body - 4));
      } else {
        id = type == kNgEnhancedPacket ? u32(body) : u16(body);
        ticks = static_cast<std::uint64_t>(u32(body + 4)) << 32 | u32(body + 8);
        captured = u32(body + 12);
        original = u32(body + 16);
      }
    }
    std::string problem;
    if (end - body < fixed || captured > end - body - fixed) problem = "a packet block longer than the block holding it";
    else if (id >= interfaces.size()) problem = "a packet block of interface " + std::to_string(id) + ", which no interface block describes";
    if (!problem.empty()) {
      ++counts.records;
      ++counts.malformed;
      counts.last_problem = "offset " + std::to_string(offset) + ": " + problem;
      return false;
    }
    const Interface& i = interfaces[id];
    const std::int64_t stamp = type == kNgSimplePacket ? 0 : clamp_ns(static_cast<long double>(ticks) * i.ns_per_tick + i.offset_s * 1e9L);
    return frame(offset, i.link_type, bytes.substr(body + fixed, captured), original, stamp, out);
  }
};

PcapReader::PcapReader(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) { impl_->open(); }
PcapReader::PcapReader(PcapReader&&) noexcept = default;
PcapReader& PcapReader::operator=(PcapReader&&) noexcept = default;
PcapReader::~PcapReader() = default;

PcapReader PcapReader::from_bytes(std::string bytes, const std::string& name) {
  auto impl = std::make_unique<Impl>();
  impl->name = name;
  impl->held = std::move(bytes);
  impl->bytes = impl->held;
  return PcapReader(std::move(impl));
}

PcapReader PcapReader::open_file(const std::string& path) {
  auto impl = std::make_unique<Impl>();
  impl->name = path;
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) throw Error(path + ": cannot open it: " + std::strerror(errno));
  struct stat st {};
  if (fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
    ::close(fd);
    throw Error(path + ": not a regular file");
  }
  const auto size = static_cast<std::size_t>(st.st_size);
  if (size > 0) {
    void* data = mmap(nullptr, size, PROT_READ, MAP_PRIVATE, fd, 0);
    if (data == MAP_FAILED) {
      const int e = errno;
      ::close(fd);
      throw Error(path + ": cannot map it into memory: " + std::strerror(e));
    }
    madvise(data, size, MADV_SEQUENTIAL);
    impl->mapped = static_cast<const char*>(data);
    impl->mapped_size = size;
    impl->bytes = std::string_view(impl->mapped, size);
  }
  ::close(fd);
  return PcapReader(std::move(impl));
}

bool PcapReader::next(UdpDatagram& out) { return impl_->ng ? impl_->next_block(out) : impl_->next_record(out); }
const PcapCounts& PcapReader::counts() const { return impl_->counts; }
const char* PcapReader::format() const { return impl_->ng ? "pcapng" : "pcap"; }

bool is_pcap(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  unsigned char b[4] = {};
  if (!in.read(reinterpret_cast<char*>(b), 4)) return false;
  std::uint32_t magic;
  std::memcpy(&magic, b, 4);
  for (std::uint32_t m : {kPcapMicro, kPcapNano})
    if (magic == m || swap32(magic) == m) return true;
  return magic == kNgSection;
}

}  // namespace pl::lidar
