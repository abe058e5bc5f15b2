// RoboSense packets (placeholder until its decoder lands).
#include "decoders.hpp"
#include "pl/common/error.hpp"

namespace pl::lidar {

std::unique_ptr<PacketDecoder> make_robosense_decoder(const DecoderOptions&) {
  throw Error("RoboSense packets are not decoded yet");
}

}  // namespace pl::lidar
