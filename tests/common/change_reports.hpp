// Change reports for tests: one drive's report with its header filled in (0.5 m voxels, 20 m
// tiles) and no tiles yet; the test adds the evidence it is about.
#pragma once

#include <cstdint>
#include <string>

#include "pl/schema/change_report.hpp"

namespace pl::test {

inline schema::ChangeReport drive_report(const std::string& map, std::int64_t version, const std::string& vehicle,
                                         const std::string& drive, double start, double span_s = 60) {
  schema::ChangeReport r;
  r.map = map;
  r.version = version;
  r.vehicle = vehicle;
  r.drive = drive;
  r.start = start;
  r.end = start + span_s;
  r.voxel_m = 0.5;
  r.tile_m = 20;
  return r;
}

}  // namespace pl::test
