// The vendors' decoders, each in its own file; make_decoder (decoder.cpp) picks one.
#pragma once

#include <memory>

#include "pl/lidar/decoder.hpp"

namespace pl::lidar {

std::unique_ptr<PacketDecoder> make_velodyne_decoder(const DecoderOptions& options);
std::unique_ptr<PacketDecoder> make_hesai_decoder(const DecoderOptions& options);
std::unique_ptr<PacketDecoder> make_robosense_decoder(const DecoderOptions& options);
std::unique_ptr<PacketDecoder> make_ouster_decoder(const DecoderOptions& options);

}  // namespace pl::lidar
