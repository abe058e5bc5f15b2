// A captured frame peeled to its UDP payload: link header, IP header, UDP header, each length
// checked against the bytes there are before anything past it is read.
#include "pcap_frames.hpp"

namespace pl::lidar::pcap {

namespace {

enum : std::uint32_t {
  kLinkNull = 0, kLinkEthernet = 1, kLinkRawOld = 12, kLinkRaw = 101, kLinkSll = 113, kLinkIpv4 = 228,
  kLinkIpv6 = 229, kLinkSll2 = 276,
};
enum : std::uint16_t { kEtherIpv4 = 0x0800, kEtherIpv6 = 0x86DD, kEtherVlan = 0x8100, kEtherQinQ = 0x88A8, kEtherVlanOld = 0x9100 };
constexpr std::uint8_t kProtoUdp = 17;
constexpr std::uint8_t kIpv6Fragment = 44;

std::uint16_t be16(std::string_view b, std::size_t at) {
  return static_cast<std::uint16_t>(static_cast<std::uint8_t>(b[at]) << 8 | static_cast<std::uint8_t>(b[at + 1]));
}

Dissected outcome(Outcome o, std::string problem) {
  Dissected d;
  d.outcome = o;
  d.problem = std::move(problem);
  return d;
}

// The IP header begins `ip`; `cut` tells whether the capture holds less than was sent.
Dissected udp_of(std::string_view ip, std::uint8_t proto, std::size_t ip_payload_at, std::size_t ip_end) {
  if (proto != kProtoUdp) return outcome(Outcome::NotUdp, "IP protocol " + std::to_string(proto));
  if (ip_end - ip_payload_at < 8) return outcome(Outcome::Malformed, "a UDP header longer than its IP packet");
  const std::uint16_t udp_length = be16(ip, ip_payload_at + 4);
  if (udp_length < 8 || udp_length > ip_end - ip_payload_at)
    return outcome(Outcome::Malformed, "UDP length " + std::to_string(udp_length) + " in an IP payload of " +
                                           std::to_string(ip_end - ip_payload_at) + " bytes");
  Dissected d;
  d.outcome = Outcome::Datagram;
  d.source_port = be16(ip, ip_payload_at);
  d.destination_port = be16(ip, ip_payload_at + 2);
  d.payload = ip.substr(ip_payload_at + 8, udp_length - 8u);
  return d;
}

Dissected ipv4(std::string_view ip, bool cut) {
  if (ip.size() < 20) return outcome(cut ? Outcome::CutShort : Outcome::Malformed, "an IPv4 header cut short");
  if ((static_cast<std::uint8_t>(ip[0]) >> 4) != 4) return outcome(Outcome::Malformed, "an IPv4 header of another version");
  const std::size_t header = (static_cast<std::uint8_t>(ip[0]) & 0x0Fu) * 4u;
  const std::size_t total = be16(ip, 2);
  if (header < 20 || total < header) return outcome(Outcome::Malformed, "IPv4 header length " + std::to_string(header) +
                                                                            ", total length " + std::to_string(total));
  if (total > ip.size())
    return outcome(cut ? Outcome::CutShort : Outcome::Malformed, "an IPv4 packet of " + std::to_string(total) +
                                                                     " bytes, " + std::to_string(ip.size()) + " captured");
  if (be16(ip, 6) & 0x3FFFu) return outcome(Outcome::Fragment, "an IPv4 fragment");
  return udp_of(ip, static_cast<std::uint8_t>(ip[9]), header, total);
}

Dissected ipv6(std::string_view ip, bool cut) {
  if (ip.size() < 40) return outcome(cut ? Outcome::CutShort : Outcome::Malformed, "an IPv6 header cut short");
  if ((static_cast<std::uint8_t>(ip[0]) >> 4) != 6) return outcome(Outcome::Malformed, "an IPv6 header of another version");
  const std::size_t total = 40u + be16(ip, 4);
  if (total > ip.size())
    return outcome(cut ? Outcome::CutShort : Outcome::Malformed, "an IPv6 packet of " + std::to_string(total) +
                                                                     " bytes, " + std::to_string(ip.size()) + " captured");
  const auto next = static_cast<std::uint8_t>(ip[6]);
  if (next == kIpv6Fragment) return outcome(Outcome::Fragment, "an IPv6 fragment");
  return udp_of(ip, next, 40, total);
}

Dissected by_ethertype(std::uint16_t type, std::string_view ip, bool cut) {
  if (type == kEtherIpv4) return ipv4(ip, cut);
  if (type == kEtherIpv6) return ipv6(ip, cut);
  return outcome(Outcome::NotUdp, "ethertype 0x" + [&] {
    static const char* hex = "0123456789abcdef";
    std::string s;
    for (int shift = 12; shift >= 0; shift -= 4) s.push_back(hex[(type >> shift) & 0xF]);
    return s;
  }());
}

Dissected by_version(std::string_view ip, bool cut) {
  if (ip.empty()) return outcome(cut ? Outcome::CutShort : Outcome::Malformed, "an empty IP packet");
  const int version = static_cast<std::uint8_t>(ip[0]) >> 4;
  if (version == 4) return ipv4(ip, cut);
  if (version == 6) return ipv6(ip, cut);
  return outcome(Outcome::NotUdp, "IP version " + std::to_string(version));
}

}  // namespace

Dissected dissect(std::uint32_t link_type, std::string_view frame, std::uint32_t original_length) {
  const bool cut = frame.size() < original_length;
  const auto short_link = [&] { return outcome(cut ? Outcome::CutShort : Outcome::Malformed, "a link header cut short"); };
  switch (link_type) {
    case kLinkEthernet: {
      std::size_t at = 12;
      for (int tags = 0;; ++tags) {
        if (frame.size() < at + 2) return short_link();
        const std::uint16_t type = be16(frame, at);
        if ((type == kEtherVlan || type == kEtherQinQ || type == kEtherVlanOld) && tags < 2) {
          at += 4;
          continue;
        }
        return by_ethertype(type, frame.substr(at + 2), cut);
      }
    }
    case kLinkSll:
      if (frame.size() < 16) return short_link();
      return by_ethertype(be16(frame, 14), frame.substr(16), cut);
    case kLinkSll2:
      if (frame.size() < 20) return short_link();
      return by_ethertype(be16(frame, 0), frame.substr(20), cut);
    case kLinkNull: {
      if (frame.size() < 4) return short_link();
      // The address family in the capturing host's byte order: 2 is IPv4, 24, 28 or 30 IPv6.
      const auto b0 = static_cast<std::uint8_t>(frame[0]), b3 = static_cast<std::uint8_t>(frame[3]);
      const std::uint8_t family = b0 ? b0 : b3;
      if (family == 2) return ipv4(frame.substr(4), cut);
      if (family == 24 || family == 28 || family == 30) return ipv6(frame.substr(4), cut);
      return outcome(Outcome::NotUdp, "loopback address family " + std::to_string(family));
    }
    case kLinkRaw:
    case kLinkRawOld:
      return by_version(frame, cut);
    case kLinkIpv4:
      return ipv4(frame, cut);
    case kLinkIpv6:
      return ipv6(frame, cut);
    default:
      return outcome(Outcome::NotUdp, "link type " + std::to_string(link_type));
  }
}

}  // namespace pl::lidar::pcap
