// Fuzz target: a change report as the map service parses it from a vehicle's upload. Refusing with
// pl::Error is fine; a report that parses writes JSON that parses to the same report, and holds
// the bounds the parser promises.
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include "pl/common/error.hpp"
#include "pl/schema/change_report.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  pl::schema::ChangeReportLimits limits;
  limits.max_bytes = 1 << 20;
  pl::schema::ChangeReport r;
  try {
    r = pl::schema::parse_change_report(text, limits);
  } catch (const pl::Error&) {
    return 0;
  }
  if (r.tiles.size() > limits.max_tiles || r.end < r.start || !(r.voxel_m > 0)) std::abort();
  const pl::schema::ChangeReport again = pl::schema::parse_change_report(pl::schema::change_report_json(r));
  if (again.map != r.map || again.version != r.version || again.drive != r.drive || again.tiles.size() != r.tiles.size()) std::abort();
  for (std::size_t i = 0; i < r.tiles.size(); ++i)
    if (!(again.tiles[i].key == r.tiles[i].key) || again.tiles[i].cells != r.tiles[i].cells || again.tiles[i].points != r.tiles[i].points)
      std::abort();
  return 0;
}
