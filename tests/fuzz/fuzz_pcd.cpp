// Fuzz target: PCD bytes as read_pcd sees them (a map or reference cloud from anywhere: a tool's
// output, a download, a damaged disk), in every encoding: ascii, binary and binary_compressed (LZF).
// Refusing with pl::Error is the reader's job; a cloud that comes back must be consistent: finite
// points, one finite intensity per point when it has any, a geodetic origin within range.
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include "pl/common/cloud_io.hpp"
#include "pl/common/error.hpp"

namespace {

void check_cloud(const pl::Cloud& c, std::string_view input) {
  if (!c.intensity.empty() && c.intensity.size() != c.points.size()) std::abort();
  for (const auto& p : c.points)
    if (!p.allFinite()) std::abort();
  for (float i : c.intensity)
    if (!std::isfinite(i)) std::abort();
  if (c.origin && !(std::abs(c.origin->lat_deg) <= 90 && std::abs(c.origin->lon_deg) <= 180 && std::isfinite(c.origin->alt_m)))
    std::abort();
  // Every point takes at least 3 bytes of input (three 8-bit binary values), or of LZF data
  // unpacked, which is at most 88 times what it takes in the file: more points than that were made
  // up, not read.
  const bool compressed = input.find("binary_compressed") != std::string_view::npos;
  if (c.points.size() > (compressed ? 88 : 1) * input.size() / 3) std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  pl::Cloud cloud;
  try {
    cloud = pl::parse_pcd(bytes, "fuzz.pcd");
  } catch (const pl::Error&) {
    return 0;
  }
  check_cloud(cloud, bytes);
  // The same bytes through the extension dispatch must give the same cloud.
  const pl::Cloud again = pl::parse_cloud(bytes, "fuzz.PCD");
  if (again.points != cloud.points || again.intensity != cloud.intensity) std::abort();
  return 0;
}
