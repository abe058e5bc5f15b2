#include "pl/eval/matching.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <tuple>

#include "pl/common/error.hpp"

namespace pl::eval {

namespace {

std::string seconds(double t) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.6f", t);
  return buf;
}

PosePairs pair_by_line(const Trajectory& est, const Trajectory& gt, const std::string& est_path,
                       const std::string& gt_path) {
  if (est.size() > gt.size())
    throw Error(est_path + ": the estimate has " + std::to_string(est.size()) + " poses but the ground truth " +
                gt_path + " has " + std::to_string(gt.size()) +
                "; KITTI poses pair line by line, so the estimate cannot be longer (check that both files are "
                "the same sequence)");
  PosePairs pairs;
  pairs.est.reserve(est.size());
  pairs.gt.reserve(est.size());
  for (std::size_t i = 0; i < est.size(); ++i) {
    pairs.est.push_back(i);
    pairs.gt.push_back(i);
  }
  return pairs;
}

PosePairs pair_by_time(const Trajectory& est, const Trajectory& gt, const std::string& est_path,
                       const std::string& gt_path, double max_dt) {
  const double tol = max_dt + 1e-9;
  // Every (|dt|, est, gt) within the tolerance; the closest are paired first so that each pose of
  // either side is used at most once and a pose never loses its partner to a worse candidate.
  std::vector<std::tuple<double, std::size_t, std::size_t>> candidates;
  for (std::size_t i = 0; i < est.size(); ++i) {
    const double t = est.times[i];
    auto it = std::lower_bound(gt.times.begin(), gt.times.end(), t - tol);
    for (; it != gt.times.end() && *it <= t + tol; ++it)
      candidates.emplace_back(std::fabs(*it - t), i, static_cast<std::size_t>(it - gt.times.begin()));
  }
  std::sort(candidates.begin(), candidates.end());
  std::vector<bool> est_used(est.size(), false), gt_used(gt.size(), false);
  std::vector<std::pair<std::size_t, std::size_t>> chosen;  // (gt, est)
  for (const auto& [dt, i, j] : candidates) {
    if (est_used[i] || gt_used[j]) continue;
    est_used[i] = gt_used[j] = true;
    chosen.emplace_back(j, i);
  }
  std::sort(chosen.begin(), chosen.end());
  PosePairs pairs;
  for (const auto& [j, i] : chosen) {
    pairs.gt.push_back(j);
    pairs.est.push_back(i);
  }
  if (pairs.size() == 0 && !est.poses.empty() && !gt.poses.empty())
    throw Error("no estimated pose of " + est_path + " (times " + seconds(est.times.front()) + " to " +
                seconds(est.times.back()) + ") is within " + std::to_string(static_cast<int>(max_dt * 1000 + 0.5)) +
                " ms of a ground-truth pose of " + gt_path + " (times " + seconds(gt.times.front()) + " to " +
                seconds(gt.times.back()) + "); check that both use the same clock and seconds");
  return pairs;
}

}  // namespace

const char* format_name(PoseFormat format) { return format == PoseFormat::Kitti ? "KITTI" : "TUM"; }

PosePairs pair_poses(const Trajectory& est, const Trajectory& gt, const std::string& est_path,
                     const std::string& gt_path, double max_dt) {
  if (est.format != gt.format)
    throw Error("the estimate " + est_path + " is " + format_name(est.format) + " but the ground truth " + gt_path +
                " is " + format_name(gt.format) +
                "; convert one so both are KITTI (12 numbers a line, paired line by line) or both are TUM "
                "(t x y z qx qy qz qw, paired by timestamp)");
  if (est.poses.empty()) throw Error(est_path + ": no poses");
  if (gt.poses.empty()) throw Error(gt_path + ": no poses");
  if (est.format == PoseFormat::Kitti) return pair_by_line(est, gt, est_path, gt_path);
  if (!est.has_times()) throw Error(est_path + ": TUM poses need a time each");
  if (!gt.has_times()) throw Error(gt_path + ": TUM poses need a time each");
  if (!std::is_sorted(gt.times.begin(), gt.times.end()))
    throw Error(gt_path + ": TUM timestamps must not decrease");
  return pair_by_time(est, gt, est_path, gt_path, max_dt);
}

}  // namespace pl::eval
