// What pl-sim writes besides the scans: a top-view preview and a dense reference cloud.
#pragma once

#include <string>

#include "pl/common/voxel.hpp"
#include "pl/sim/traffic.hpp"
#include "pl/sim/world.hpp"

namespace pl::sim {

// SVG top view: object footprints by class, the trajectory, traffic at the start.
void write_preview(const std::string& path, const World& world, const SimTrajectory& traj, double t0, double t1,
                   const Traffic* traffic);

// Points on every surface of the world (ground, buildings, parked things...; no traffic) about
// `spacing` metres apart; ground only within `ground_band` of the path.
Points3d sample_world(const World& world, double spacing, std::vector<float>& intensity);

}  // namespace pl::sim
