// Fuzz target: the record of a map's drives (MAP.drives.json) as pl-map build --base-map reads it.
// Refusing with pl::Error is fine; a record that decodes encodes to a record that decodes to the same
// poses, times and settings, bit for bit.
#include <cstdint>
#include <cstdlib>
#include <string>

#include "pl/common/error.hpp"
#include "pl/maps/drive_record.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string bytes(reinterpret_cast<const char*>(data), size);
  pl::maps::DriveRecord r;
  try {
    r = pl::maps::decode_drive_record(bytes, "fuzz.drives.json");
  } catch (const pl::Error&) {
    return 0;
  }
  if (r.drives.empty() || r.drives.size() > 64 || !(r.merge.voxel_m > 0) || r.merge.every < 1) std::abort();
  const pl::maps::DriveRecord again = pl::maps::decode_drive_record(pl::maps::encode_drive_record(r), "again");
  if (again.drives.size() != r.drives.size() || again.merge.last != r.merge.last || again.origin.has_value() != r.origin.has_value())
    std::abort();
  for (std::size_t d = 0; d < r.drives.size(); ++d) {
    const auto &a = r.drives[d], &b = again.drives[d];
    if (a.dataset != b.dataset || a.poses.times != b.poses.times || a.poses.size() != b.poses.size()) std::abort();
    for (std::size_t i = 0; i < a.poses.size(); ++i)
      if (!(a.poses.poses[i].matrix() == b.poses.poses[i].matrix())) std::abort();
  }
  return 0;
}
