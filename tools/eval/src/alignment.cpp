#include "pl/eval/alignment.hpp"

#include <Eigen/SVD>
#include <string>

#include "pl/common/error.hpp"

namespace pl::eval {

namespace {

// The shared part of both alignments: centroids, the source's spread, and the rotation
// R = U diag(1, 1, d) V^T that maximises trace(R^T C) for the cross-covariance C = target x source^T
// of the centred points, with d = -1 when U V^T would be a reflection.
struct Fit {
  Eigen::Vector3d mu_s = Eigen::Vector3d::Zero();
  Eigen::Vector3d mu_t = Eigen::Vector3d::Zero();
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  double source_variance = 0.0;  // mean |source - mu_s|^2
  double trace_ds = 0.0;         // trace(D S): the singular values, the last one signed by d
};

Fit fit(const Positions& source, const Positions& target, const char* what) {
  if (source.size() != target.size())
    throw Error(std::string(what) + " needs as many source as target points (" + std::to_string(source.size()) +
                " vs " + std::to_string(target.size()) + ")");
  if (source.empty()) throw Error(std::string(what) + " needs at least one pair of points");
  const double n = static_cast<double>(source.size());
  Fit f;
  for (std::size_t i = 0; i < source.size(); ++i) {
    f.mu_s += source[i];
    f.mu_t += target[i];
  }
  f.mu_s /= n;
  f.mu_t /= n;
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (std::size_t i = 0; i < source.size(); ++i) {
    const Eigen::Vector3d s = source[i] - f.mu_s;
    cov += (target[i] - f.mu_t) * s.transpose();
    f.source_variance += s.squaredNorm();
  }
  cov /= n;
  f.source_variance /= n;
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(cov, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d u = svd.matrixU();
  const Eigen::Matrix3d v = svd.matrixV();
  const Eigen::Vector3d d = svd.singularValues();
  f.trace_ds = d[0] + d[1] + d[2];
  if ((u * v.transpose()).determinant() < 0.0) {
    u.col(2) *= -1.0;
    f.trace_ds -= 2.0 * d[2];
  }
  f.rotation = u * v.transpose();
  return f;
}

}  // namespace

Pose align_rigid(const Positions& source, const Positions& target) {
  const Fit f = fit(source, target, "rigid alignment");
  Pose out = Pose::Identity();
  out.linear() = f.rotation;
  out.translation() = f.mu_t - f.rotation * f.mu_s;
  return out;
}

Eigen::Matrix4d Similarity::matrix() const {
  Eigen::Matrix4d m = rigid.matrix();
  m.topLeftCorner<3, 3>() *= scale;
  return m;
}

Similarity align_similarity(const Positions& source, const Positions& target) {
  const Fit f = fit(source, target, "similarity alignment");
  // Relative to the spread of the centroid itself, so that far-off coordinates (UTM, ECEF) do not
  // hide a real spread, yet a set of identical points is caught.
  if (!(f.source_variance > 1e-24 * (1.0 + f.mu_s.squaredNorm())))
    throw Error("similarity alignment needs source points that are not all the same point (the scale is undefined)");
  Similarity out;
  out.scale = f.trace_ds / f.source_variance;
  out.rigid.linear() = f.rotation;
  out.rigid.translation() = f.mu_t - out.scale * (f.rotation * f.mu_s);
  return out;
}

}  // namespace pl::eval
