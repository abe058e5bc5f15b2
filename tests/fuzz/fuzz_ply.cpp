// Fuzz target: PLY bytes as read_ply sees them (clouds exported by other tools: CloudCompare,
// MeshLab, Open3D). Refusing with pl::Error is the reader's job; a cloud that comes back must have
// finite points and one finite intensity per point when it has any.
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include "pl/common/cloud_io.hpp"
#include "pl/common/error.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  pl::Cloud c;
  try {
    c = pl::parse_ply(bytes, "fuzz.ply");
  } catch (const pl::Error&) {
    return 0;
  }
  if (!c.intensity.empty() && c.intensity.size() != c.points.size()) std::abort();
  for (const auto& p : c.points)
    if (!p.allFinite()) std::abort();
  for (float i : c.intensity)
    if (!std::isfinite(i)) std::abort();
  if (c.origin) std::abort();  // PLY records none
  if (c.points.size() > size / 3) std::abort();  // at least 3 bytes of input a point
  return 0;
}
