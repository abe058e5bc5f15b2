// Hesai packets (placeholder until its decoder lands).
#include "decoders.hpp"
#include "pl/common/error.hpp"

namespace pl::lidar {

std::unique_ptr<PacketDecoder> make_hesai_decoder(const DecoderOptions&) {
  throw Error("Hesai packets are not decoded yet");
}

}  // namespace pl::lidar
