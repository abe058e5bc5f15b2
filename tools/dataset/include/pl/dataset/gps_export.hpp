// A drive's GPS fixes as positions in its world frame, and where the antenna really was at each fix
// (ground truth interpolated at the fix time, plus the lever arm). pl-dataset gps.
#pragma once

#include <cstddef>
#include <optional>

#include "pl/common/pose.hpp"
#include "pl/recordings/dataset.hpp"

namespace pl::dataset {

struct GpsExport {
  Trajectory fixes;    // TUM: the fix times, identity rotations
  Trajectory truth;    // with `with_truth`: the true antenna positions at the same times
  std::size_t skipped = 0;  // fixes outside the drive's ground truth, left out of both
};

// The fixes of one status only when `status` is given (pl::kGpsSingle .. pl::kGpsFixed). Throws
// pl::Error when the drive has no GPS, no fix of that status, or no ground truth for `with_truth`.
GpsExport gps_positions(const Dataset& ds, std::optional<int> status, bool with_truth);

}  // namespace pl::dataset
