// Fuzz target: tile bytes as the server's upload check and the vehicle's decoder see them (any
// bytes may arrive: an upload, a damaged disk, anything between the server and the vehicle).
// A valid decode must give finite points, unit normals and finite intensities, one per point.
#include <cmath>
#include <cstdint>
#include <algorithm>
#include <cstdlib>
#include <string_view>

#include "pl/common/error.hpp"
#include "pl/common/tile_codec.hpp"
#include "pl/server/api.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  pl::TileCloud cloud;
  try {
    cloud = pl::decode_tile(bytes);
  } catch (const pl::Error&) {
    return 0;  // refused with a message: what the decoder must do with bad bytes
  }
  const std::size_t n = cloud.size();
  if (!cloud.normals.empty() && cloud.normals.size() != n) std::abort();
  if (!cloud.intensity.empty() && cloud.intensity.size() != n) std::abort();
  for (const auto& p : cloud.points)
    if (!p.allFinite()) std::abort();
  for (const auto& u : cloud.normals)
    if (!u.allFinite() || std::abs(u.norm() - 1.0f) > 1e-3f) std::abort();
  for (float i : cloud.intensity)
    if (!std::isfinite(i)) std::abort();
  const pl::TileSummary s = pl::inspect_tile(bytes);
  if (s.points != n || s.has_normals != !cloud.normals.empty() || s.has_intensity != !cloud.intensity.empty()) std::abort();
  if (n == 0) return 0;
  // The upload check for the key of the first point: accepts or refuses with a message.
  const double tile = 20.0;
  const pl::TileKey key{static_cast<std::int32_t>(std::floor(std::clamp(cloud.points[0].x() / tile, -1e9, 1e9))),
                        static_cast<std::int32_t>(std::floor(std::clamp(cloud.points[0].y() / tile, -1e9, 1e9)))};
  try {
    const pl::server::TileUpload up = pl::server::check_tile_upload(bytes, tile, key);
    if (up.points != n) std::abort();
  } catch (const pl::Error&) {
  }
  return 0;
}
