// The relative errors of the KITTI odometry benchmark, written from its definition: for segments
// of 100, 200, ..., 800 m of ground-truth path starting at every 10th frame, the error of the
// estimated relative motion over the segment, per metre of segment length.
#pragma once

#include <cstddef>
#include <vector>

#include "pl/common/pose.hpp"
#include "pl/eval/matching.hpp"

namespace pl::eval {

struct KittiOptions {
  std::vector<double> lengths = {100, 200, 300, 400, 500, 600, 700, 800};  // metres
  std::size_t step = 10;         // a segment starts at every step-th frame
  double frame_rate_hz = 10.0;   // frame times when the files carry none (KITTI)
  double speed_bin_kmh = 10.0;
};

// One segment: frames i (first) and j (last) are indices into the pairs; j is the first frame
// whose ground-truth path distance from i is >= length.
struct SegmentError {
  std::size_t first = 0;
  std::size_t last = 0;
  double length = 0.0;       // metres
  double speed_kmh = 0.0;    // length / (time_j - time_i); negative when the times do not increase
  double translation = 0.0;  // |t(E)| / length, E = (gt_i^-1 gt_j)^-1 (est_i^-1 est_j)
  double rotation = 0.0;     // angle(E) / length, rad/m
};

// Averages over a group of segments, in the benchmark's units.
struct ErrorGroup {
  double lo = 0.0;  // the length (by length) or the lower bin edge in km/h (by speed)
  double hi = 0.0;  // equal to lo by length; upper bin edge by speed
  std::size_t segments = 0;
  double translation_pct = 0.0;         // mean translation error * 100
  double rotation_deg_per_100m = 0.0;   // mean rotation error in deg/m * 100
};

struct KittiResult {
  std::size_t pairs = 0;
  bool times_from_files = false;  // TUM times, else frames at frame_rate_hz
  double path_length = 0.0;       // ground-truth path over the paired frames, metres
  std::vector<SegmentError> segments;
  ErrorGroup overall;
  std::vector<ErrorGroup> by_length;  // lengths that have segments, ascending
  std::vector<ErrorGroup> by_speed;   // non-empty speed bins, ascending
};

// Throws pl::Error when the paired ground truth is shorter than the shortest segment length.
KittiResult compute_kitti_metrics(const Trajectory& est, const Trajectory& gt, const PosePairs& pairs,
                                  const KittiOptions& options = {});

}  // namespace pl::eval
