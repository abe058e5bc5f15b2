// Where a replay starts (pl-localize --init): ground truth, the first GPS fix, a pose given or the
// map's places; and the warning for a start that lies outside the map.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include "pl/client/replay.hpp"
#include "pl/common/cli.hpp"
#include "pl/common/error.hpp"
#include "pl/common/geo.hpp"

namespace pl::client {

std::optional<Eigen::Vector3d> choose_start(const Dataset& ds, const ReplayPlan& plan, VehicleLocalizerConfig& cfg,
                                            ReplayOptions& replay) {
  const std::string init = plan.init.empty() ? (ds.gps.empty() ? "gt" : "gps") : plan.init;
  bool search = plan.init_search == "on";
  const double t0 = ds.times[replay.scans.front()];
  Eigen::Isometry3d start = Eigen::Isometry3d::Identity();
  if (init == "global") {
    replay.start = [t0](VehicleLocalizer& loc) { loc.start_global(t0); };
    return std::nullopt;
  }
  if (init == "gt") {
    if (!ds.has_ground_truth()) throw Error("--init gt: " + ds.dir + " has no ground-truth poses; give --init x,y,z,yaw");
    start = ds.ground_truth.poses[replay.scans.front()];
    search = false;
  } else if (init == "gps") {
    const auto fix = std::find_if(ds.gps.begin(), ds.gps.end(), [&](const GpsFix& g) { return g.status != kGpsNone && g.t >= t0 - 0.5; });
    if (fix == ds.gps.end()) throw Error("--init gps: no GPS fix at the start of " + ds.dir + "; give --init x,y,z,yaw");
    start.translation() = ds.to_world(fix->position) - ds.meta.vehicle.gps_lever_arm;  // level, facing +x
    cfg.search = cfg.gps_search;
    // A drive whose world frame is ENU about its own origin (a recording: its first fix) places the
    // fix about the map's origin instead: the map may come from another drive.
    if (ds.projection.kind == WorldProjection::Kind::Enu && ds.projection.world_from_projected.isApprox(Eigen::Isometry3d::Identity())) {
      const GeoPoint at = fix->position;
      const Eigen::Vector3d lever = ds.meta.vehicle.gps_lever_arm;
      replay.start = [at, lever, t0](VehicleLocalizer& loc) {
        Eigen::Isometry3d p = Eigen::Isometry3d::Identity();
        p.translation() = EnuFrame(loc.map_origin()).to_enu(at) - lever;
        loc.start_near(p, t0);
      };
      return std::nullopt;
    }
    search = true;
  } else {
    const auto v = parse_number_list(init, 4, "--init");
    start = make_pose(v[0], v[1], v[2], 0, 0, v[3] * M_PI / 180.0);
  }
  replay.start = [start, t0, search](VehicleLocalizer& loc) { search ? loc.start_near(start, t0) : loc.start(start, t0); };
  return start.translation();
}

std::string start_outside_map(const VehicleLocalizer& loc, const std::optional<Eigen::Vector3d>& start, const std::string& map) {
  const auto extent = loc.map_extent();
  if (!start || !extent) return "";
  const double off = extent->distance(start->x(), start->y());
  if (off <= 0) return "";
  // Measured first: --init takes any finite number, so the text has no bound.
  const auto print = [&](char* to, std::size_t size) {
    return std::snprintf(to, size,
                         "the start (%.1f, %.1f) lies %.0f m outside map '%s' (its points span x %.0f..%.0f m, y %.0f..%.0f m): "
                         "the scans will find no map there; --init global (the map's places) or --init gps (the drive's first "
                         "GPS fix) finds the vehicle",
                         start->x(), start->y(), off, map.c_str(), extent->min_x, extent->max_x, extent->min_y, extent->max_y);
  };
  std::string text(static_cast<std::size_t>(print(nullptr, 0)) + 1, '\0');
  text.resize(static_cast<std::size_t>(print(text.data(), text.size())));
  return text;
}

}  // namespace pl::client
