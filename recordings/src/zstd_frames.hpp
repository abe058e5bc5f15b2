// zstd data from a file of unknown origin, decompressed within bounds (ROS 2 bags compressed per
// file or per message). Private to pl_common.
#pragma once

#include <zstd.h>

#include <cstdint>
#include <string>
#include <string_view>

namespace pl::bag {

// The bytes that the zstd frames `in` hold (one frame, or several back to back), at most `limit`
// bytes and at most what the input justifies (64 MiB, and beyond that 1024 times the input). A
// damaged, cut-short or oversized frame is refused with an error that begins with `what`
// ("FILE: ...: ").
std::string unzstd(ZSTD_DCtx* z, std::string_view in, std::uint64_t limit, const std::string& what);

}  // namespace pl::bag
