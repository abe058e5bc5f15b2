// Constant-velocity motion compensation over a sweep.
#include "pl/registration/motion.hpp"

#include <cmath>

#include "pl/common/error.hpp"

namespace pl::registration {

void compensate_motion(std::vector<Eigen::Vector3f>& points, const Eigen::Isometry3d& sweep, const std::vector<float>& shares) {
  if (!shares.empty() && shares.size() != points.size()) throw Error("compensate_motion: one share per point, or none");
  if (!sweep.matrix().allFinite()) throw Error("compensate_motion: the sweep's motion is not finite");
  const Eigen::AngleAxisd aa(sweep.linear());
  // A small angle per point: the rotation by s * angle about the axis, Rodrigues' formula in float.
  const Eigen::Vector3f axis = aa.axis().cast<float>(), t = sweep.translation().cast<float>();
  const float angle = static_cast<float>(aa.angle());
  for (std::size_t i = 0; i < points.size(); ++i) {
    Eigen::Vector3f& p = points[i];
    const float s = shares.empty() ? sweep_share_from_azimuth(p) : shares[i];
    const float a = s * angle, c = std::cos(a), sn = std::sin(a);
    p = c * p + sn * axis.cross(p) + (1.0f - c) * axis.dot(p) * axis + s * t;
  }
}

}  // namespace pl::registration
