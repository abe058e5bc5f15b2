#include "pl/eval/matching.hpp"

#include <Eigen/Core>

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

// The axis along which a trajectory spreads least (the vertical of a ground vehicle's drive), when it
// clearly does: under a fifth of the other two and over 10 m of those; else -1.
int flat_axis(const Trajectory& t) {
  if (t.poses.empty()) return -1;
  Eigen::Vector3d lo = t.poses.front().translation(), hi = lo;
  for (const Pose& p : t.poses) lo = lo.cwiseMin(p.translation()), hi = hi.cwiseMax(p.translation());
  const Eigen::Vector3d e = hi - lo;
  int a = 0;
  e.minCoeff(&a);
  const double others = std::min(e[(a + 1) % 3], e[(a + 2) % 3]);
  return others > 10.0 && e[a] < 0.2 * others ? a : -1;
}

// Frame numbers as text: "50-99" for a run, else the first few.
std::string frames_text(const std::vector<long>& ids) {
  if (ids.empty()) return "";
  bool run = true;
  for (std::size_t i = 1; i < ids.size(); ++i) run = run && ids[i] == ids[i - 1] + 1;
  if (run) return ids.size() == 1 ? std::to_string(ids.front()) : std::to_string(ids.front()) + "-" + std::to_string(ids.back());
  std::string s;
  for (std::size_t i = 0; i < ids.size() && i < 4; ++i) s += (i ? ", " : "") + std::to_string(ids[i]);
  return s + (ids.size() > 4 ? ", ..." : "");
}

// Pairs by the frame numbers both files' headers give.
PosePairs pair_by_frame(const Trajectory& est, const Trajectory& gt, const std::string& est_path, const std::string& gt_path) {
  std::vector<std::pair<long, std::size_t>> index;
  for (std::size_t j = 0; j < gt.frame_ids.size(); ++j) index.emplace_back(gt.frame_ids[j], j);
  std::sort(index.begin(), index.end());
  std::vector<std::pair<std::size_t, std::size_t>> chosen;  // (gt, est)
  for (std::size_t i = 0; i < est.frame_ids.size(); ++i) {
    auto it = std::lower_bound(index.begin(), index.end(), std::make_pair(est.frame_ids[i], std::size_t{0}));
    if (it == index.end() || it->first != est.frame_ids[i])
      throw Error(est_path + ": frame " + std::to_string(est.frame_ids[i]) + " (line " + std::to_string(i + 1) +
                  " of its poses) is not among the ground truth's frames in " + gt_path + " (" + frames_text(gt.frame_ids) +
                  "); give the ground truth of the same drive (pl-dataset poses DRIVE --out FILE)");
    chosen.emplace_back(it->second, i);
  }
  std::sort(chosen.begin(), chosen.end());
  PosePairs pairs;
  for (const auto& [j, i] : chosen) {
    pairs.gt.push_back(j);
    pairs.est.push_back(i);
  }
  return pairs;
}

PosePairs pair_by_line(const Trajectory& est, const Trajectory& gt, const std::string& est_path,
                       const std::string& gt_path) {
  if (!est.frame_ids.empty() && !gt.frame_ids.empty()) return pair_by_frame(est, gt, est_path, gt_path);
  // Only the estimate says which frames its lines are: line by line holds when they are frames 0, 1,
  // 2, ... (a run from the start), or when the ground truth was cut to as many lines (the same scans);
  // otherwise no line of the ground truth can be known to belong to a line of the estimate.
  if (!est.frame_ids.empty() && gt.size() != est.size()) {
    bool from_start = true;
    for (std::size_t i = 0; i < est.frame_ids.size(); ++i) from_start = from_start && est.frame_ids[i] == static_cast<long>(i);
    if (!from_start)
      throw Error(est_path + " holds the poses of frames " + frames_text(est.frame_ids) + ", but the ground truth " + gt_path + " has " +
                  std::to_string(gt.size()) + " lines and no frame numbers, so its lines cannot be matched to them: give the ground "
                  "truth with its frame numbers (pl-dataset poses DRIVE --out FILE writes them), or one cut to the same " +
                  std::to_string(est.size()) + " scans");
  }
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
  if (!est.frame.empty() && !gt.frame.empty() && est.frame != gt.frame)
    throw Error("the estimate " + est_path + " holds poses of the " + est.frame + " frame but the ground truth " + gt_path + " of the " +
                gt.frame + " frame; compare poses of one frame (pl-dataset poses DRIVE writes the LiDAR's)");
  // KITTI odometry's ground truth is the left camera's (y down, z forward): against LiDAR poses (z up)
  // every pose would be metres off. A truth without a header that drives in its x-z plane while the
  // LiDAR estimate drives in its x-y plane is that mistake.
  if (est.frame == "lidar" && gt.frame.empty() && flat_axis(est) == 2 && flat_axis(gt) == 1)
    throw Error("the ground truth " + gt_path + " looks like camera poses (it drives in its x-z plane, y vertical: KITTI's cam0) but " +
                est_path + " holds LiDAR poses (z up); give the LiDAR's ground truth (pl-dataset poses DRIVE --out FILE converts a "
                "KITTI odometry folder's poses.txt with its calib.txt)");
  if (est.format == PoseFormat::Kitti) return pair_by_line(est, gt, est_path, gt_path);
  if (!est.has_times()) throw Error(est_path + ": TUM poses need a time each");
  if (!gt.has_times()) throw Error(gt_path + ": TUM poses need a time each");
  if (!std::is_sorted(gt.times.begin(), gt.times.end()))
    throw Error(gt_path + ": TUM timestamps must not decrease");
  return pair_by_time(est, gt, est_path, gt_path, max_dt);
}

}  // namespace pl::eval
