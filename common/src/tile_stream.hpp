// The walk over a Draco point-cloud stream that decode_tile does before Draco sees it: the published
// bitstream's header, metadata, point count, attribute descriptors and the k-d tree coder's own
// counts, refused when what Draco would allocate to decode it is out of proportion. Private to
// pl_common (tile_codec.cpp).
#pragma once

#include <string>
#include <string_view>

namespace pl::tile_stream {

// Throws pl::Error("not a valid Draco point cloud: " + reason).
[[noreturn]] void invalid(const std::string& reason);

// Throws (invalid) for a stream that is malformed, of an unsupported version or coder, or that
// declares more than its budget (see tile_stream.cpp).
void check_stream(std::string_view bytes);

}  // namespace pl::tile_stream
