// One captured frame -> its UDP datagram: the link layer, IPv4 or IPv6, UDP (pcap.hpp says which).
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

namespace pl::lidar::pcap {

enum class Outcome { Datagram, NotUdp, Fragment, CutShort, Malformed };

struct Dissected {
  Outcome outcome = Outcome::Malformed;
  std::uint16_t source_port = 0;
  std::uint16_t destination_port = 0;
  std::string_view payload;
  std::string problem;  // why it is not a datagram
};

// `frame` as captured (maybe cut short of `original_length`) on a link of type `link_type` (the
// tcpdump LINKTYPE_ numbers).
Dissected dissect(std::uint32_t link_type, std::string_view frame, std::uint32_t original_length);

}  // namespace pl::lidar::pcap
