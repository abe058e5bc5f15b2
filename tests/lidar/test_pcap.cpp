// The pcap reader on captures written here from the formats' published layouts (tcpdump's pcap
// file format, the pcapng draft, Ethernet / Linux cooked / IPv4 / IPv6 / UDP headers): every
// datagram with its time and ports; what is not one skipped and counted; broken framing refused.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>

#include "pl/common/error.hpp"
#include "pl/lidar/pcap.hpp"

namespace pl::lidar {
namespace {

// Bytes in either order.
struct Bytes {
  bool big = false;
  std::string b;
  Bytes& n(std::uint64_t v, int size) {
    for (int i = 0; i < size; ++i) b.push_back(static_cast<char>(v >> (8 * (big ? size - 1 - i : i)) & 0xFF));
    return *this;
  }
  Bytes& raw(const std::string& s) {
    b += s;
    return *this;
  }
};

std::string be16(std::uint16_t v) { return {static_cast<char>(v >> 8), static_cast<char>(v & 0xFF)}; }

std::string udp(std::uint16_t from, std::uint16_t to, const std::string& payload) {
  return be16(from) + be16(to) + be16(static_cast<std::uint16_t>(8 + payload.size())) + be16(0) + payload;
}

// An IPv4 packet; `fragment` sets the more-fragments flag.
std::string ipv4(const std::string& l4, std::uint8_t proto = 17, bool fragment = false) {
  std::string h = "\x45";
  h += '\0';
  h += be16(static_cast<std::uint16_t>(20 + l4.size())) + be16(1) + be16(fragment ? 0x2000 : 0x4000);
  h += "\x40";
  h += static_cast<char>(proto);
  h += be16(0) + std::string("\x7f\0\0\x01\x7f\0\0\x01", 8);
  return h + l4;
}

std::string ipv6(const std::string& l4) {
  std::string h = std::string("\x60\0\0\0", 4) + be16(static_cast<std::uint16_t>(l4.size())) + "\x11\x40";
  return h + std::string(32, '\1') + l4;
}

std::string ethernet(const std::string& ip, std::uint16_t type = 0x0800, bool vlan = false) {
  std::string f(12, '\2');
  if (vlan) f += be16(0x8100) + be16(5);
  return f + be16(type) + ip;
}

std::string sll(const std::string& ip) { return std::string(14, '\0') + be16(0x0800) + ip; }

// A classic pcap file: microsecond or nanosecond times, either byte order.
struct Pcap {
  Bytes out;
  bool nano;
  Pcap(bool big, bool nano_, std::uint32_t link = 1) : nano(nano_) {
    out.big = big;
    out.n(nano ? 0xA1B23C4D : 0xA1B2C3D4, 4).n(2, 2).n(4, 2).n(0, 4).n(0, 4).n(65535, 4).n(link, 4);
  }
  Pcap& record(std::uint32_t sec, std::uint32_t frac, const std::string& frame, std::uint32_t original = 0) {
    out.n(sec, 4).n(frac, 4).n(frame.size(), 4).n(original ? original : frame.size(), 4).raw(frame);
    return *this;
  }
};

// A pcapng file: a section, one interface, enhanced packet blocks.
struct PcapNg {
  Bytes out;
  explicit PcapNg(bool big, std::uint32_t link = 1, int tsresol = -1) {
    out.big = big;
    Bytes body{big, {}};
    body.n(0x1A2B3C4D, 4).n(1, 2).n(0, 2).n(~0ull, 8);
    block(0x0A0D0D0A, body.b);
    Bytes idb{big, {}};
    idb.n(link, 2).n(0, 2).n(65535, 4);
    if (tsresol >= 0) idb.n(9, 2).n(1, 2).n(static_cast<std::uint64_t>(tsresol), 1).n(0, 3);
    idb.n(0, 4);  // opt_endofopt
    block(1, idb.b);
  }
  void block(std::uint32_t type, std::string body) {
    while (body.size() % 4) body.push_back('\0');
    out.n(type, 4).n(12 + body.size(), 4).raw(body).n(12 + body.size(), 4);
  }
  PcapNg& packet(std::uint64_t ticks, const std::string& frame) {
    Bytes b{out.big, {}};
    b.n(0, 4).n(ticks >> 32, 4).n(ticks & 0xFFFFFFFF, 4).n(frame.size(), 4).n(frame.size(), 4).raw(frame);
    block(6, b.b);
    return *this;
  }
};

std::vector<UdpDatagram> all(PcapReader& r) {
  std::vector<UdpDatagram> out;
  for (UdpDatagram d; r.next(d);) out.push_back(d);
  return out;
}

std::string refusal(const std::string& bytes) {
  try {
    auto r = PcapReader::from_bytes(bytes, "cap.pcap");
    all(r);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(PcapReader, ClassicFilesInEitherByteOrderAndResolution) {
  for (bool big : {false, true})
    for (bool nano : {false, true}) {
      SCOPED_TRACE(std::string(big ? "big" : "little") + (nano ? " ns" : " us"));
      Pcap p(big, nano);
      p.record(1'600'000'000, nano ? 123'456'789 : 123'456, ethernet(ipv4(udp(7502, 7502, "lidar"))));
      p.record(1'600'000'001, 5, ethernet(ipv4(udp(7503, 7504, std::string(48, 'i'))), 0x0800, true));
      auto r = PcapReader::from_bytes(p.out.b, "cap.pcap");
      EXPECT_STREQ(r.format(), "pcap");
      const auto d = all(r);
      ASSERT_EQ(d.size(), 2u);
      EXPECT_EQ(d[0].payload, "lidar");
      EXPECT_EQ(d[0].source_port, 7502);
      EXPECT_EQ(d[0].stamp_ns, 1'600'000'000'000'000'000 + (nano ? 123'456'789 : 123'456'000));
      EXPECT_EQ(d[0].offset, 24u);
      EXPECT_EQ(d[1].payload.size(), 48u);
      EXPECT_EQ(d[1].destination_port, 7504);
      EXPECT_EQ(d[1].stamp_ns, 1'600'000'001'000'000'000 + (nano ? 5 : 5000));
      EXPECT_EQ(r.counts().records, 2u);
      EXPECT_EQ(r.counts().datagrams, 2u);
    }
}

TEST(PcapReader, LinuxCookedRawIpAndIpv6) {
  Pcap cooked(false, false, 113);
  cooked.record(1, 0, sll(ipv4(udp(1, 2, "sll"))));
  auto r = PcapReader::from_bytes(cooked.out.b, "sll.pcap");
  auto d = all(r);
  ASSERT_EQ(d.size(), 1u);
  EXPECT_EQ(d[0].payload, "sll");

  Pcap raw(false, false, 101);
  raw.record(1, 0, ipv6(udp(3, 4, "six"))).record(1, 1, ipv4(udp(5, 6, "four")));
  r = PcapReader::from_bytes(raw.out.b, "raw.pcap");
  d = all(r);
  ASSERT_EQ(d.size(), 2u);
  EXPECT_EQ(d[0].payload, "six");
  EXPECT_EQ(d[1].payload, "four");
  EXPECT_EQ(d[1].source_port, 5);
}

TEST(PcapReader, PcapngInEitherByteOrder) {
  for (bool big : {false, true}) {
    PcapNg ng(big);
    ng.packet(1'600'000'000'000'001ull, ethernet(ipv4(udp(7502, 7502, "ng"))));
    PcapNg nano(big, 1, 9);
    nano.packet(1'600'000'000'000'000'007ull, ethernet(ipv4(udp(7502, 7502, "ns"))));
    auto r = PcapReader::from_bytes(ng.out.b + nano.out.b.substr(0), "cap.pcapng");  // two sections
    EXPECT_STREQ(r.format(), "pcapng");
    const auto d = all(r);
    ASSERT_EQ(d.size(), 2u);
    EXPECT_EQ(d[0].payload, "ng");
    EXPECT_EQ(d[0].stamp_ns, 1'600'000'000'000'001'000) << "microseconds by default";
    EXPECT_EQ(d[1].payload, "ns");
    EXPECT_EQ(d[1].stamp_ns, 1'600'000'000'000'000'007) << "if_tsresol 9: nanoseconds";
  }
}

TEST(PcapReader, WhatIsNotOneDatagramIsSkippedAndCounted) {
  Pcap p(false, false);
  p.record(1, 0, ethernet(ipv4(udp(1, 2, "a"), 6)));                // TCP
  p.record(1, 0, ethernet("arp...", 0x0806));                       // ARP
  p.record(1, 0, ethernet(ipv4(udp(1, 2, "frag"), 17, true)));      // a fragment
  const std::string whole = ethernet(ipv4(udp(1, 2, std::string(100, 'x'))));
  p.record(1, 0, whole.substr(0, 60), static_cast<std::uint32_t>(whole.size()));  // cut by the snap length
  std::string lying = ethernet(ipv4(udp(1, 2, "short")));
  lying[14 + 20 + 5] = 100;                                         // UDP length beyond its IP packet
  p.record(1, 0, lying);
  p.record(1, 0, ethernet(ipv4(udp(9, 9, "kept"))));
  p.record(1, 0, std::string(30, '\0').substr(0, 10));              // a link header cut short
  auto r = PcapReader::from_bytes(p.out.b, "cap.pcap");
  const auto d = all(r);
  ASSERT_EQ(d.size(), 1u);
  EXPECT_EQ(d[0].payload, "kept");
  const PcapCounts& c = r.counts();
  EXPECT_EQ(c.records, 7u);
  EXPECT_EQ(c.not_udp, 2u);
  EXPECT_EQ(c.fragments, 1u);
  EXPECT_EQ(c.cut_short, 1u);
  EXPECT_EQ(c.malformed, 2u);
  EXPECT_NE(c.last_problem.find("link header"), std::string::npos) << c.last_problem;
}

TEST(PcapReader, AFileEndingInsideARecordEndsTheReading) {
  Pcap p(false, false);
  p.record(1, 0, ethernet(ipv4(udp(1, 2, "one"))));
  p.record(2, 0, ethernet(ipv4(udp(1, 2, "two"))));
  const std::string cut = p.out.b.substr(0, p.out.b.size() - 3);
  auto r = PcapReader::from_bytes(cut, "cut.pcap");
  const auto d = all(r);
  ASSERT_EQ(d.size(), 1u);
  EXPECT_EQ(r.counts().cut_short, 1u);
  EXPECT_NE(r.counts().last_problem.find("ends inside"), std::string::npos);
}

TEST(PcapReader, BrokenFramingIsRefusedWithFileAndOffset) {
  EXPECT_NE(refusal("hello world, not a capture").find("cap.pcap: offset 0: not a pcap"), std::string::npos);
  EXPECT_NE(refusal("").find("cap.pcap"), std::string::npos);
  Pcap p(false, false);
  p.record(1, 0, ethernet(ipv4(udp(1, 2, "one"))));
  const std::size_t second = p.out.b.size();
  p.out.n(1, 4).n(0, 4).n(0x7FFFFFFF, 4).n(10, 4).raw(std::string(64, 'z'));  // a record length beyond any packet
  const std::string what = refusal(p.out.b);
  EXPECT_NE(what.find("cap.pcap: offset " + std::to_string(second) + ":"), std::string::npos) << what;

  PcapNg ng(false);
  ng.packet(1, ethernet(ipv4(udp(1, 2, "ng"))));
  std::string bad = ng.out.b;
  bad[bad.size() - 4] = 0x10;  // the trailing length differs
  EXPECT_NE(refusal(bad).find("trailing length"), std::string::npos) << refusal(bad);
}

TEST(PcapReader, OpensFiles) {
  Pcap p(false, true);
  p.record(3, 4, ethernet(ipv4(udp(1, 2, "file"))));
  const auto path = (std::filesystem::temp_directory_path() / ("pl-pcap-" + std::to_string(::getpid()) + ".pcap")).string();
  std::ofstream(path, std::ios::binary) << p.out.b;
  EXPECT_TRUE(is_pcap(path));
  auto r = PcapReader::open_file(path);
  const auto d = all(r);
  std::filesystem::remove(path);
  ASSERT_EQ(d.size(), 1u);
  EXPECT_EQ(d[0].payload, "file");
  EXPECT_EQ(d[0].stamp_ns, 3'000'000'004);
  EXPECT_THROW(PcapReader::open_file(path), Error);
  EXPECT_FALSE(is_pcap(path));
}

}  // namespace
}  // namespace pl::lidar
