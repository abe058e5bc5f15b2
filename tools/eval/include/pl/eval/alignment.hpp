// Least-squares alignment of two matched point sets: rigid (Umeyama/Horn without scale) and
// similarity (Umeyama with a uniform scale).
#pragma once

#include "pl/common/pose.hpp"
#include "pl/eval/geometry.hpp"

namespace pl::eval {

// The rotation R and translation t minimising sum |R source[i] + t - target[i]|^2, with R a proper
// rotation (det +1). From the SVD of the cross-covariance of the centred sets. Needs at least one
// pair and equal sizes (pl::Error otherwise); with fewer than three non-collinear points the
// rotation is not unique and one of the minimisers is returned.
Pose align_rigid(const Positions& source, const Positions& target);

// p -> scale * (rotation * p) + translation, i.e. scale about the origin, then `rigid`.
struct Similarity {
  Pose rigid = Pose::Identity();  // rotation and translation
  double scale = 1.0;
  Eigen::Vector3d operator()(const Eigen::Vector3d& p) const { return rigid * (scale * p); }
  // The 4x4 matrix [scale * R, t; 0 0 0 1].
  Eigen::Matrix4d matrix() const;
};

// The similarity minimising sum |s R source[i] + t - target[i]|^2 (Umeyama 1991): R and the
// reflection guard as in align_rigid, s = trace(D S) / var(source), where D holds the singular values
// of the cross-covariance and S = diag(1, 1, +-1). A source twice the target's size gives s = 0.5.
// Throws pl::Error for unequal sizes, no pairs, or a source whose points all coincide (no scale).
Similarity align_similarity(const Positions& source, const Positions& target);

}  // namespace pl::eval
