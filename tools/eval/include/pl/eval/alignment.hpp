// Rigid least-squares alignment of two matched point sets (Umeyama/Horn without scale).
#pragma once

#include "pl/common/pose.hpp"
#include "pl/eval/geometry.hpp"

namespace pl::eval {

// The rotation R and translation t minimising sum |R source[i] + t - target[i]|^2, with R a proper
// rotation (det +1). From the SVD of the cross-covariance of the centred sets. Needs at least one
// pair and equal sizes (pl::Error otherwise); with fewer than three non-collinear points the
// rotation is not unique and one of the minimisers is returned.
Pose align_rigid(const Positions& source, const Positions& target);

}  // namespace pl::eval
