#include "pl/eval/alignment.hpp"

#include <Eigen/SVD>
#include <string>

#include "pl/common/error.hpp"

namespace pl::eval {

Pose align_rigid(const Positions& source, const Positions& target) {
  if (source.size() != target.size())
    throw Error("rigid alignment needs as many source as target points (" + std::to_string(source.size()) +
                " vs " + std::to_string(target.size()) + ")");
  if (source.empty()) throw Error("rigid alignment needs at least one pair of points");
  const double n = static_cast<double>(source.size());
  Eigen::Vector3d mu_s = Eigen::Vector3d::Zero(), mu_t = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < source.size(); ++i) {
    mu_s += source[i];
    mu_t += target[i];
  }
  mu_s /= n;
  mu_t /= n;
  // Cross-covariance target x source^T of the centred points; R = U diag(1, 1, d) V^T maximises
  // trace(R^T C), with d = -1 when U V^T would be a reflection.
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (std::size_t i = 0; i < source.size(); ++i) cov += (target[i] - mu_t) * (source[i] - mu_s).transpose();
  cov /= n;
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(cov, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d u = svd.matrixU();
  const Eigen::Matrix3d v = svd.matrixV();
  if ((u * v.transpose()).determinant() < 0.0) u.col(2) *= -1.0;
  Pose out = Pose::Identity();
  out.linear() = u * v.transpose();
  out.translation() = mu_t - out.linear() * mu_s;
  return out;
}

}  // namespace pl::eval
