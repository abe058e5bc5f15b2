// The beam elevations of LiDAR models whose beams are fixed by design, as their makers publish them,
// for clouds that lost their ring field: a point's ring is the beam nearest its elevation.
#pragma once

#include <string>
#include <vector>

#include "pl/common/scan.hpp"

namespace pl::lidar {

struct BeamTable {
  std::vector<std::string> models;   // the models that share it ("VLP-16", "RS-LiDAR-16", ...)
  std::vector<double> elevation_deg;  // bottom to top
};

const std::vector<BeamTable>& nominal_beam_tables();
// The table of a model named as the tables name it (case and '-' ignored); nullptr when none.
const BeamTable* nominal_beam_table(const std::string& model);

// How a scan's points fit a table: the share of points (3 m away or more, where a beam's offset from
// the sensor's centre is below 0.2 degrees) within `tolerance_deg` of a beam, and the beams that hold
// at least 0.2 % of them.
struct BeamFit {
  double share = 0;
  int beams_used = 0;
  bool trusted(const BeamTable& t) const { return share >= 0.9 && beams_used * 10 >= static_cast<int>(t.elevation_deg.size()) * 9; }
};
BeamFit fit_beams(const Scan& scan, const std::vector<double>& elevation_deg, double tolerance_deg = 0.25);

// The table a scan fits best among `candidates` (all the tables when empty), when the fit can be trusted.
const BeamTable* find_beam_table(const Scan& scan, const std::vector<const BeamTable*>& candidates = {});

}  // namespace pl::lidar
