#include "pl/dataset/gps_export.hpp"

#include <algorithm>

#include "pl/common/error.hpp"
#include "pl/common/geo.hpp"

namespace pl::dataset {

GpsExport gps_positions(const Dataset& ds, std::optional<int> status, bool with_truth) {
  if (ds.gps.empty()) throw Error(ds.dir + ": no GPS (a raw drive's oxts/ or a gps.csv)");
  if (with_truth && !ds.has_ground_truth()) throw Error(ds.dir + ": --truth needs ground-truth poses");
  GpsExport r;
  r.fixes.format = r.truth.format = PoseFormat::Tum;
  const auto& gt = ds.ground_truth;
  for (const auto& f : ds.gps) {
    if (status && f.status != *status) continue;
    Pose p = Pose::Identity();
    p.translation() = ds.to_world(f.position);
    if (with_truth) {
      // Ground truth at the fix time (interpolated between scans); fixes outside the drive are left out.
      if (f.t < gt.times.front() || f.t > gt.times.back()) {
        ++r.skipped;
        continue;
      }
      std::size_t i = static_cast<std::size_t>(std::upper_bound(gt.times.begin(), gt.times.end(), f.t) - gt.times.begin());
      i = std::min(std::max<std::size_t>(i, 1), gt.size() - 1);
      const double s = (f.t - gt.times[i - 1]) / std::max(1e-9, gt.times[i] - gt.times[i - 1]);
      Pose a = Pose::Identity();
      a.translation() = interpolate(gt.poses[i - 1], gt.poses[i], s) * ds.meta.vehicle.gps_lever_arm;
      r.truth.poses.push_back(a);
      r.truth.times.push_back(f.t);
    }
    r.fixes.poses.push_back(p);
    r.fixes.times.push_back(f.t);
  }
  if (r.fixes.poses.empty())
    throw Error(ds.dir + ": no GPS fixes" + (status ? " with status " + std::string(gps_status_name(*status)) : std::string()));
  return r;
}

}  // namespace pl::dataset
