// Free space by ray crossing: a LiDAR ray that passed through a map surface on its way to a farther
// return says that surface was not there when the ray was fired. The vehicle's change evidence
// (pl/client/change_evidence.hpp) and the map builder's free-space filter (pl/maps/free_space.hpp)
// share this one test, so a map is cleaned by the same rule that later reports it changed.
//
// The rule: the ray is probed every step_m from start_m to margin_m short of its return; at each
// probe the nearest map point within pass_radius_m is asked whether the ray crosses its tangent plane
// within cross_radius_m of it, at |cos incidence| >= min_incidence, and still margin_m short of the
// return. A ray grazing a surface (the ground, on its way to a far return) or passing beside an edge
// comes near map points without crossing them, and a return that noisy or slightly misplaced lies
// just behind its own surface is never counted against that surface.
#pragma once

#include <Eigen/Core>

#include <cmath>
#include <cstdint>

#include "pl/registration/point_map.hpp"

namespace pl::registration {

struct RayCrossingConfig {
  double start_m = 3.0;         // probes start this far from the ray's origin (the vehicle itself)
  double step_m = 0.5;          // a probe every this
  double margin_m = 1.0;        // ... up to this short of the ray's own return
  double pass_radius_m = 0.35;  // a probe this near a map point asks whether the ray passed through it:
  double cross_radius_m = 0.15;  // whether it crossed the point's tangent plane this near the point
  double min_incidence = 0.4;    // ... at |cos| of the ray and the point's normal of at least this
  // Throws pl::Error naming the field and its allowed range.
  void validate() const;
};

// Walks the ray from `from` to its return `to` (map frame). At each probe, first probe(x, s) with the
// probe's position x and its distance s from `from`: it returns false to end the walk (true to go
// on). Then, for the map point nearest the probe when the ray crosses its surface,
// crossed(point, point_in_map). A point may be reported by several probes of one ray; counting once
// is the caller's. `block` is any CellBlock valid for `map` (kept across rays for speed).
template <class Probe, class Crossed>
void walk_ray(const PointMap& map, const Eigen::Vector3d& from, const Eigen::Vector3d& to, const RayCrossingConfig& cfg,
              CellBlock& block, Probe&& probe, Crossed&& crossed) {
  const Eigen::Vector3d anchor = map.anchor();
  const float pass2 = static_cast<float>(cfg.pass_radius_m * cfg.pass_radius_m);
  const float min_cos = static_cast<float>(cfg.min_incidence);
  const double cross2 = cfg.cross_radius_m * cfg.cross_radius_m;
  const Eigen::Vector3d d = to - from;
  const double range = d.norm();
  if (!(range > 0)) return;
  const Eigen::Vector3d dir = d / range;
  const Eigen::Vector3f dirf = dir.cast<float>();
  const double stop = range - cfg.margin_m;
  for (double s = cfg.start_m; s < stop; s += cfg.step_m) {
    const Eigen::Vector3d x = from + s * dir;
    if (!probe(x, s)) break;
    const Neighbour nb = map.nearest((x - anchor).cast<float>(), pass2, block);
    if (!nb.point) continue;
    // The ray passes through the map's surface there only when it crosses the point's tangent plane
    // near the point (a ray beside a corner or along a wall's end comes near without).
    const float cos_in = nb.point->n.dot(dirf);
    if (std::abs(cos_in) < min_cos) continue;
    const Eigen::Vector3d mp = anchor + nb.point->p.cast<double>();
    const double cross = s + nb.point->n.cast<double>().dot(mp - x) / static_cast<double>(cos_in);
    if (cross >= stop || ((from + cross * dir) - mp).squaredNorm() > cross2) continue;
    crossed(*nb.point, mp);
  }
}

// The same without a probe.
template <class Crossed>
void walk_ray(const PointMap& map, const Eigen::Vector3d& from, const Eigen::Vector3d& to, const RayCrossingConfig& cfg,
              CellBlock& block, Crossed&& crossed) {
  walk_ray(map, from, to, cfg, block, [](const Eigen::Vector3d&, double) { return true; }, crossed);
}

}  // namespace pl::registration
