// Map accuracy against a reference cloud of the same world (pl-eval map): for every map point the
// distance to the reference surface (or to the nearest reference point), its distribution, and how
// much of the reference the map covers.
#pragma once

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include "pl/common/cloud_io.hpp"
#include "pl/eval/stats.hpp"

namespace pl::eval {

struct MapAccuracyOptions {
  // surface: each map point's distance to the reference surface — the plane through the reference
  // points within 2.5 spacings of its nearest one, when they are planar and the nearest lies within
  // 2 spacings (else the point distance); point: the distance to the nearest reference point, which
  // a reference sampled every s metres inflates by up to ~s/sqrt(2). The surface distance does not
  // see a shift along the surface (a map slid along a wall scores 0): report both.
  bool surface = true;
  double within = 0.05;           // metres: the headline share
  double coverage_radius = 0.5;   // metres: a reference point is covered when a map point is this close
  std::size_t spacing_sample = 10000;  // reference points sampled (evenly) for its spacing
};

struct ShareWithin {
  double distance = 0.0;  // metres
  std::size_t points = 0;  // map points at most `distance` from the reference (by the metric used)
  double share = 0.0;      // points / map points
};

struct MapAccuracy {
  std::size_t map_points = 0;
  bool surface = true;            // the metric used (see MapAccuracyOptions)
  std::size_t surface_points = 0; // map points measured to a fitted plane (the rest: to the nearest point)
  std::size_t reference_points = 0;
  double within = 0.05;
  // 0.02, 0.05, 0.10, 0.20 m and `within`, ascending, without repeats.
  std::vector<ShareWithin> shares;
  Summary distance;  // of the map-to-reference distances (median: the mean of the two middle values)
  double p90 = 0.0, p95 = 0.0, p99 = 0.0;  // pl::percentile (linear between the closest ranks)
  // The median distance from a reference point to its nearest other reference point, over an even
  // sample: distances well below half of it are not resolved by a point-to-point comparison.
  double reference_spacing = 0.0;
  double coverage_radius = 0.5;
  std::size_t reference_covered = 0;  // reference points with a map point within coverage_radius
  double reference_coverage = 0.0;    // reference_covered / reference_points
  std::vector<double> distances;      // per map point, in map order
};

// Throws pl::Error when either cloud is empty or an option is not positive. Draws a progress bar
// when stderr is a terminal (pl::Progress).
MapAccuracy compute_map_accuracy(const Points3d& map, const Points3d& reference, const MapAccuracyOptions& options = {});

// Clouds that both record a geodetic origin (PCD "# origin LAT LON ALT") must record the same one
// (within 1 mm): otherwise pl::Error naming both files and origins.
void check_same_origin(const Cloud& map, const std::string& map_path, const Cloud& reference,
                       const std::string& reference_path);

}  // namespace pl::eval
