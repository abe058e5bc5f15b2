#include "pl/eval/kitti_metrics.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>

#include "pl/common/error.hpp"
#include "pl/eval/geometry.hpp"

namespace pl::eval {

namespace {

constexpr double kPi = 3.14159265358979323846;

struct Accumulator {
  std::size_t n = 0;
  double translation = 0.0;
  double rotation = 0.0;
  void add(const SegmentError& s) {
    ++n;
    translation += s.translation;
    rotation += s.rotation;
  }
  ErrorGroup group(double lo, double hi) const {
    ErrorGroup g;
    g.lo = lo;
    g.hi = hi;
    g.segments = n;
    if (n > 0) {
      g.translation_pct = translation / static_cast<double>(n) * 100.0;
      g.rotation_deg_per_100m = rotation / static_cast<double>(n) * (180.0 / kPi) * 100.0;
    }
    return g;
  }
};

}  // namespace

KittiResult compute_kitti_metrics(const Trajectory& est, const Trajectory& gt, const PosePairs& pairs,
                                  const KittiOptions& options) {
  if (pairs.size() == 0 || pairs.est.size() != pairs.gt.size())
    throw Error("no estimated pose pairs with a ground-truth pose; nothing to evaluate");
  if (options.lengths.empty() || options.step == 0 || !(options.frame_rate_hz > 0) || !(options.speed_bin_kmh > 0))
    throw Error("KITTI metric options need segment lengths, a step, a frame rate and a speed bin width");
  for (std::size_t k = 0; k < pairs.size(); ++k)
    if (pairs.est[k] >= est.size() || pairs.gt[k] >= gt.size()) throw Error("pose pair index out of range");

  std::vector<double> lengths = options.lengths;
  std::sort(lengths.begin(), lengths.end());
  if (!(lengths.front() > 0.0)) throw Error("KITTI segment lengths must be positive");

  KittiResult r;
  r.pairs = pairs.size();
  r.times_from_files = gt.has_times();
  const std::vector<double> gt_dist = path_distances(positions_of(gt));
  std::vector<double> dist(r.pairs);  // ground-truth path distance at each pair
  for (std::size_t k = 0; k < r.pairs; ++k) dist[k] = gt_dist[pairs.gt[k]];
  r.path_length = dist.back() - dist.front();

  auto time_of = [&](std::size_t k) {
    const std::size_t j = pairs.gt[k];
    return r.times_from_files ? gt.times[j] : static_cast<double>(j) / options.frame_rate_hz;
  };

  std::map<double, Accumulator> by_length;
  std::map<long long, Accumulator> by_speed;
  Accumulator overall;
  for (std::size_t i = 0; i < r.pairs; i += options.step) {
    const Pose& gt_i = gt.poses[pairs.gt[i]];
    const Pose& est_i = est.poses[pairs.est[i]];
    std::size_t j = i;
    for (double length : lengths) {
      // First frame j whose path distance from i reaches the length; lengths ascend, so the
      // search goes on from the previous length's frame, and stops once the data runs out.
      while (j < r.pairs && dist[j] - dist[i] < length) ++j;
      if (j >= r.pairs) break;
      const Pose gt_delta = gt_i.inverse() * gt.poses[pairs.gt[j]];
      const Pose est_delta = est_i.inverse() * est.poses[pairs.est[j]];
      const Pose error = gt_delta.inverse() * est_delta;
      SegmentError s;
      s.first = i;
      s.last = j;
      s.length = length;
      s.translation = error.translation().norm() / length;
      s.rotation = pl::rotation_angle(error) / length;
      const double dt = time_of(j) - time_of(i);
      s.speed_kmh = dt > 0.0 ? length / dt * 3.6 : -1.0;
      r.segments.push_back(s);
      overall.add(s);
      by_length[length].add(s);
      if (s.speed_kmh >= 0.0)
        by_speed[static_cast<long long>(std::floor(s.speed_kmh / options.speed_bin_kmh))].add(s);
    }
  }
  if (r.segments.empty()) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.1f", r.path_length);
    const double shortest = lengths.front();
    throw Error("the paired ground truth covers " + std::string(buf) + " m, shorter than the shortest KITTI segment (" +
                std::to_string(static_cast<long long>(shortest)) +
                " m); use a longer sequence, or `pl-eval ape` for short runs");
  }
  r.overall = overall.group(0.0, 0.0);
  for (const auto& [length, acc] : by_length) r.by_length.push_back(acc.group(length, length));
  for (const auto& [bin, acc] : by_speed)
    r.by_speed.push_back(acc.group(static_cast<double>(bin) * options.speed_bin_kmh,
                                   static_cast<double>(bin + 1) * options.speed_bin_kmh));
  return r;
}

}  // namespace pl::eval
