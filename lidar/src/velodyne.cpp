// Velodyne packets (placeholder until its decoder lands).
#include "decoders.hpp"
#include "pl/common/error.hpp"

namespace pl::lidar {

std::unique_ptr<PacketDecoder> make_velodyne_decoder(const DecoderOptions&) {
  throw Error("Velodyne packets are not decoded yet");
}

}  // namespace pl::lidar
