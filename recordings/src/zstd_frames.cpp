#include "zstd_frames.hpp"

#include <algorithm>
#include <new>

#include "pl/common/error.hpp"

namespace pl::bag {
namespace {

// zstd turns 4 bytes into 128 KiB of one repeated byte, so the size of the input says little about
// the size of the output. Output may grow to 64 MiB whatever the input, and beyond that to 1024
// times the input: more than recordings compress, and a few hostile bytes cannot claim gigabytes.
constexpr std::uint64_t kFreeOutput = 64ull << 20;
constexpr std::uint64_t kMaxRatio = 1024;
// The bytes that the zstd frames `in` state they hold, added up; ZSTD_CONTENTSIZE_UNKNOWN when a
// frame does not say, or the frames are damaged.
std::uint64_t stated_size(std::string_view in) {
  std::uint64_t total = 0;
  std::size_t at = 0;
  while (at < in.size()) {
    const unsigned long long n = ZSTD_getFrameContentSize(in.data() + at, in.size() - at);
    const std::size_t frame = ZSTD_findFrameCompressedSize(in.data() + at, in.size() - at);
    if (n == ZSTD_CONTENTSIZE_UNKNOWN || n == ZSTD_CONTENTSIZE_ERROR || ZSTD_isError(frame) || frame == 0 ||
        n > UINT64_MAX - total)
      return ZSTD_CONTENTSIZE_UNKNOWN;
    total += n;
    at += frame;
  }
  return total;
}

}  // namespace

std::string unzstd(ZSTD_DCtx* z, std::string_view in, std::uint64_t limit, const std::string& what) {
  if (in.empty()) throw Error(what + "empty, where a zstd frame was expected (the data is damaged)");
  const std::uint64_t cap = std::min<std::uint64_t>(limit, kFreeOutput + kMaxRatio * static_cast<std::uint64_t>(in.size()));
  const auto too_large = [&](std::uint64_t n) {
    return Error(what + "the zstd data decompresses to " + (n ? std::to_string(n) : "more than " + std::to_string(cap)) +
                 " bytes, more than this reader accepts from " + std::to_string(in.size()) +
                 " compressed bytes (the data is damaged or crafted)");
  };
  const auto allocate = [&](std::string& out, std::uint64_t n) {
    try {
      out.resize(static_cast<std::size_t>(n));
    } catch (const std::bad_alloc&) {
      throw Error(what + "cannot allocate " + std::to_string(n) + " bytes to decompress it");
    }
  };
  ZSTD_DCtx_reset(z, ZSTD_reset_session_only);
  std::string out;
  // When every frame states its size (rosbag2's always do), one call decompresses them all into a
  // buffer of exactly that size; zstd checks that each frame holds what it states.
  const std::uint64_t total = stated_size(in);
  if (total != ZSTD_CONTENTSIZE_UNKNOWN) {
    if (total > cap) throw too_large(total);
    allocate(out, total);
    const std::size_t got = ZSTD_decompressDCtx(z, out.data(), out.size(), in.data(), in.size());
    if (ZSTD_isError(got)) throw Error(what + "damaged zstd data (" + ZSTD_getErrorName(got) + ")");
    if (got != total)
      throw Error(what + "the zstd data holds " + std::to_string(got) + " bytes where it states " + std::to_string(total));
    return out;
  }
  // Otherwise the output grows as it comes.
  allocate(out, std::min<std::uint64_t>(cap, std::max<std::uint64_t>(in.size(), 64 << 10)));
  ZSTD_inBuffer src{in.data(), in.size(), 0};
  std::size_t pos = 0;
  for (;;) {
    if (pos == out.size()) {
      if (out.size() >= cap) throw too_large(0);
      allocate(out, std::min<std::uint64_t>(cap, 2 * static_cast<std::uint64_t>(out.size())));
    }
    ZSTD_outBuffer dst{out.data(), out.size(), pos};
    const std::size_t in_before = src.pos;
    const std::size_t r = ZSTD_decompressStream(z, &dst, &src);
    if (ZSTD_isError(r)) throw Error(what + "damaged zstd data (" + ZSTD_getErrorName(r) + ")");
    const bool moved = dst.pos != pos || src.pos != in_before;
    pos = dst.pos;
    if (r == 0 && src.pos == src.size) break;  // every frame complete
    if (dst.pos < dst.size) {                  // room was left, so the decoder wants input
      if (src.pos == src.size) throw Error(what + "the zstd data is cut short (the file was truncated?)");
      if (!moved) throw Error(what + "damaged zstd data (the decoder makes no progress)");
    }
  }
  out.resize(pos);
  return out;
}

}  // namespace pl::bag
