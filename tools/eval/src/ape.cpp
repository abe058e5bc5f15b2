#include "pl/eval/ape.hpp"

#include <cmath>

#include "pl/common/error.hpp"
#include "pl/eval/alignment.hpp"

namespace pl::eval {

std::optional<Alignment> parse_alignment(const std::string& name) {
  if (name == "none") return Alignment::None;
  if (name == "se3") return Alignment::Se3;
  if (name == "sim3") return Alignment::Sim3;
  return std::nullopt;
}

const char* alignment_name(Alignment alignment) {
  switch (alignment) {
    case Alignment::Se3: return "se3";
    case Alignment::Sim3: return "sim3";
    default: return "none";
  }
}

namespace {

ComponentError component(const std::vector<double>& v) {
  ComponentError c;
  if (v.empty()) return c;
  double abs_sum = 0.0, sq_sum = 0.0;
  for (double x : v) {
    abs_sum += std::fabs(x);
    sq_sum += x * x;
  }
  const double n = static_cast<double>(v.size());
  c.mean_abs = abs_sum / n;
  c.rmse = std::sqrt(sq_sum / n);
  return c;
}

}  // namespace

ApeResult compute_ape(const Trajectory& est, const Trajectory& gt, const PosePairs& pairs, const ApeOptions& options) {
  if (pairs.size() == 0) throw Error("no estimated pose pairs with a ground-truth pose; nothing to evaluate");
  if (pairs.est.size() != pairs.gt.size()) throw Error("pose pairs of unequal length");
  ApeResult r;
  r.alignment = options.alignment;
  r.gt_positions = positions_of(gt);
  r.est_positions = positions_of(est);
  r.vertical_axis_auto = options.vertical_axis < 0 || options.vertical_axis > 2;
  r.vertical_axis = r.vertical_axis_auto ? auto_vertical_axis(r.gt_positions) : options.vertical_axis;
  r.pairs = pairs;
  r.matched = pairs.size();
  r.gt_poses = gt.size();
  r.coverage = r.gt_poses == 0 ? 0.0 : static_cast<double>(r.matched) / static_cast<double>(r.gt_poses);

  Positions src, dst;
  src.reserve(r.matched);
  dst.reserve(r.matched);
  for (std::size_t k = 0; k < r.matched; ++k) {
    if (pairs.est[k] >= est.size() || pairs.gt[k] >= gt.size()) throw Error("pose pair index out of range");
    src.push_back(r.est_positions[pairs.est[k]]);
    dst.push_back(r.gt_positions[pairs.gt[k]]);
  }
  if (options.alignment == Alignment::Se3) {
    r.alignment_transform = align_rigid(src, dst);
  } else if (options.alignment == Alignment::Sim3) {
    const Similarity s = align_similarity(src, dst);
    r.alignment_transform = s.rigid;
    r.alignment_scale = s.scale;
  }
  if (options.alignment != Alignment::None) {
    for (auto& p : r.est_positions) p = r.alignment_transform * (r.alignment_scale * p);
    for (auto& p : src) p = r.alignment_transform * (r.alignment_scale * p);
  }

  const std::vector<double> distance = path_distances(r.gt_positions);
  const Positions forward = travel_directions(r.gt_positions, r.vertical_axis);
  Eigen::Vector3d up = Eigen::Vector3d::Zero();
  up[r.vertical_axis] = 1.0;
  std::vector<double> lon, lat, vert;
  r.errors.reserve(r.matched);
  r.gt_distance.reserve(r.matched);
  for (std::size_t k = 0; k < r.matched; ++k) {
    const std::size_t j = pairs.gt[k];
    const Eigen::Vector3d e = src[k] - dst[k];
    r.errors.push_back(e.norm());
    r.gt_distance.push_back(distance[j]);
    // forward is horizontal and unit, so (forward, up x forward, up) is an orthonormal basis.
    const Eigen::Vector3d side = up.cross(forward[j]);
    lon.push_back(e.dot(forward[j]));
    lat.push_back(e.dot(side));
    vert.push_back(e[r.vertical_axis]);
  }
  r.error = summarize(r.errors);
  r.longitudinal = component(lon);
  r.lateral = component(lat);
  r.vertical = component(vert);
  return r;
}

}  // namespace pl::eval
