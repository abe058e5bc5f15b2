// Absolute position error (APE): the translation error of each estimated pose against the
// ground-truth pose it pairs with, optionally after a rigid (se3) or similarity (sim3) alignment
// of the estimate.
#pragma once

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include "pl/common/pose.hpp"
#include "pl/eval/geometry.hpp"
#include "pl/eval/matching.hpp"
#include "pl/eval/stats.hpp"

namespace pl::eval {

enum class Alignment { None, Se3, Sim3 };
std::optional<Alignment> parse_alignment(const std::string& name);
const char* alignment_name(Alignment alignment);

struct ApeOptions {
  Alignment alignment = Alignment::None;
  int vertical_axis = -1;  // 0/1/2 = x/y/z, -1 = auto_vertical_axis(gt)
};

struct ComponentError {
  double mean_abs = 0.0;
  double rmse = 0.0;
};

struct ApeResult {
  Alignment alignment = Alignment::None;
  // The estimate's positions p become alignment_transform * (alignment_scale * p): identity and 1
  // for none, scale 1 for se3. For sim3 a scale below 1 means the estimate was too large.
  Pose alignment_transform = Pose::Identity();
  double alignment_scale = 1.0;
  int vertical_axis = 2;
  bool vertical_axis_auto = true;
  std::size_t matched = 0;
  std::size_t gt_poses = 0;
  double coverage = 0.0;  // matched / gt_poses
  Summary error;          // of |est - gt| in metres
  // Error vector split along the ground-truth direction of travel (longitudinal), the horizontal
  // perpendicular (lateral) and the vertical axis; their squares add up to the squared error.
  ComponentError longitudinal, lateral, vertical;

  // Per pair, in ground-truth order (for figures).
  PosePairs pairs;
  std::vector<double> errors;        // metres
  std::vector<double> gt_distance;   // distance travelled along the ground truth at the pair's GT pose
  Positions est_positions;           // every estimated position, after the alignment
  Positions gt_positions;            // every ground-truth position
};

// Throws pl::Error when there are no pairs.
ApeResult compute_ape(const Trajectory& est, const Trajectory& gt, const PosePairs& pairs,
                      const ApeOptions& options = {});

}  // namespace pl::eval
