// Elevations from the makers' data sheets. Only models whose every unit has the same beams are here;
// the others (HDL-64E, Pandar64, the Ouster OS series) need their unit's calibration.
#include "pl/lidar/beam_table.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>

namespace pl::lidar {
namespace {

std::vector<double> uniform(double lowest, double step, int n) {
  std::vector<double> v;
  for (int i = 0; i < n; ++i) v.push_back(lowest + step * i);
  return v;
}

std::string key(const std::string& model) {
  std::string k;
  for (char c : model)
    if (c != '-' && c != '_' && c != ' ') k += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return k;
}

}  // namespace

const std::vector<BeamTable>& nominal_beam_tables() {
  static const std::vector<BeamTable> tables = {
      {{"VLP-16", "RS-LiDAR-16", "PandarXT16"}, uniform(-15, 2, 16)},
      {{"VLP-16 Hi-Res"}, uniform(-10, 4.0 / 3.0, 16)},
      {{"HDL-32E"}, uniform(-30.67, 4.0 / 3.0, 32)},
      {{"PandarXT32"}, uniform(-16, 1, 32)},
      {{"VLP-32C"}, {-25, -15.639, -11.31, -8.843, -7.254, -6.148, -5.333, -4.667, -4, -3.667, -3.333, -3, -2.667, -2.333, -2, -1.667,
                     -1.333, -1, -0.667, -0.333, 0, 0.333, 0.667, 1, 1.333, 1.667, 2.333, 3.333, 4.667, 7, 10.333, 15}},
  };
  return tables;
}

const BeamTable* nominal_beam_table(const std::string& model) {
  for (const BeamTable& t : nominal_beam_tables())
    for (const std::string& m : t.models)
      if (key(m) == key(model)) return &t;
  return nullptr;
}

BeamFit fit_beams(const Scan& scan, const std::vector<double>& elevation_deg, double tolerance_deg) {
  BeamFit fit;
  if (elevation_deg.empty()) return fit;
  std::vector<std::size_t> per_beam(elevation_deg.size(), 0);
  std::size_t counted = 0, within = 0;
  for (const PointXYZI& p : scan) {
    const double xy = std::hypot(p.x, p.y);
    if (xy * xy + static_cast<double>(p.z) * p.z < 9.0) continue;
    ++counted;
    const double el = std::atan2(static_cast<double>(p.z), xy) * 180.0 / M_PI;
    auto hi = std::lower_bound(elevation_deg.begin(), elevation_deg.end(), el);
    std::size_t best = hi == elevation_deg.end() ? elevation_deg.size() - 1 : static_cast<std::size_t>(hi - elevation_deg.begin());
    if (hi != elevation_deg.begin() && (hi == elevation_deg.end() || el - *(hi - 1) < *hi - el)) best = static_cast<std::size_t>(hi - elevation_deg.begin()) - 1;
    if (std::abs(el - elevation_deg[best]) <= tolerance_deg) ++within, ++per_beam[best];
  }
  if (counted == 0) return fit;
  fit.share = static_cast<double>(within) / static_cast<double>(counted);
  for (std::size_t n : per_beam) fit.beams_used += n * 500 >= counted;
  return fit;
}

const BeamTable* find_beam_table(const Scan& scan, const std::vector<const BeamTable*>& candidates) {
  std::vector<const BeamTable*> all = candidates;
  if (all.empty())
    for (const BeamTable& t : nominal_beam_tables()) all.push_back(&t);
  const BeamTable* best = nullptr;
  double best_share = 0;
  for (const BeamTable* t : all) {
    const BeamFit f = fit_beams(scan, t->elevation_deg);
    if (f.trusted(*t) && f.share > best_share) best = t, best_share = f.share;
  }
  return best;
}

}  // namespace pl::lidar
