// Pairing an estimated trajectory with its ground truth: KITTI files pair line by line, TUM files
// by timestamp.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "pl/common/pose.hpp"

namespace pl::eval {

// Largest |t_est - t_gt| for two TUM poses to pair (5 ms). A 1e-9 s slack absorbs the decimal
// rounding of timestamps such as 1.005 - 1.000.
inline constexpr double kMaxTimeDifference = 0.005;

// Index pairs (est[k], gt[k]), in increasing ground-truth order.
struct PosePairs {
  std::vector<std::size_t> est;
  std::vector<std::size_t> gt;
  std::size_t size() const { return gt.size(); }
};

// KITTI + KITTI: est line i pairs with gt line i; the estimate may be shorter (it stopped early),
// never longer. TUM + TUM: each estimate takes the ground-truth pose nearest in time if within
// max_dt; each pose of either side is used at most once (closest time differences are paired
// first). Mixed formats, an estimate longer than a KITTI ground truth, and no pairs at all throw
// pl::Error naming the files and the fix. The paths are only used in messages.
PosePairs pair_poses(const Trajectory& est, const Trajectory& gt, const std::string& est_path,
                     const std::string& gt_path, double max_dt = kMaxTimeDifference);

const char* format_name(PoseFormat format);

}  // namespace pl::eval
