// The one Gauss-Newton reduction of the project's registrations (the localizer's point-to-plane ICP,
// LOAM's point-to-line and point-to-plane odometry, the loop checks).
//
// Parametrisation: the pose is a rotation R and a translation t from the map's anchor; a step
// (v, w) moves a transformed point q = R s + t to q + w x (R s) + v, so the rotation turns about the
// sensor and the normal matrix stays well conditioned however far the sensor is from the anchor.
// A residual row is n . q + d for a unit direction n; its Jacobian is [n, (R s) x n].
#pragma once

#include <Eigen/Core>

namespace pl::registration {

using Matrix6d = Eigen::Matrix<double, 6, 6>;
using Vector6d = Eigen::Matrix<double, 6, 1>;

// Robust weights of a squared residual e2 at kernel scale k (k2 = k * k).
inline float geman_mcclure_weight(float e2, float k2) {
  const float d = k2 + e2;
  return k2 * k2 / (d * d);
}
inline float cauchy_weight(float e2, float k2) { return 1.0f / (1.0f + e2 / k2); }

// What a scan feature is paired with: a plane (one row) or a line, as the two planes through it
// across its direction (two rows); residual_i = n[i] . q + d[i].
struct FeatureTarget {
  Eigen::Vector3f n[2];
  float d[2];
  int rows = 0;
};

// J^T W J and J^T W r summed over weighted rows. Rows are summed in float in blocks of 256 and the
// blocks in double: fast, and still exact enough for a 6 x 6 system.
class NormalEquations {
 public:
  // One row: unit direction n, rotated sensor point qr = R s, residual r, weight w.
  void add(const Eigen::Vector3f& n, const Eigen::Vector3f& qr, float r, float w) {
    Eigen::Matrix<float, 6, 1> J;
    J.head<3>() = n;
    J.tail<3>() = qr.cross(n);
    Hf_.noalias() += (w * J) * J.transpose();
    gf_.noalias() += (w * r) * J;
    wr2_ += static_cast<double>(w * r * r);
    w_ += static_cast<double>(w);
    ++rows_;
    if (++block_ == 256) flush();
  }
  // The sums so far (cheap; adding may go on afterwards).
  const Matrix6d& H() {
    flush();
    return H_;
  }
  const Vector6d& g() {
    flush();
    return g_;
  }
  int rows() const { return rows_; }
  // Weighted RMS of the residuals: sqrt(sum w r^2 / sum w).
  double weighted_rms() const;

 private:
  Eigen::Matrix<float, 6, 6> Hf_ = Eigen::Matrix<float, 6, 6>::Zero();
  Eigen::Matrix<float, 6, 1> gf_ = Eigen::Matrix<float, 6, 1>::Zero();
  Matrix6d H_ = Matrix6d::Zero();
  Vector6d g_ = Vector6d::Zero();
  double wr2_ = 0, w_ = 0;
  int rows_ = 0, block_ = 0;
  void flush();
};

// The Gauss-Newton step -H^-1 g (LDLT); not finite when H is singular.
Vector6d solve_step(const Matrix6d& H, const Vector6d& g);

// The step with the directions of H weaker than `ratio` times the strongest left out (rotations
// weighed as arcs at `lever_m`, so metres and radians compare); `degenerate` says whether any was.
Vector6d solve_step_truncated(const Matrix6d& H, const Vector6d& g, double ratio, bool& degenerate, double lever_m = 10.0);

// Smallest over largest eigenvalue of the translation information once the rotation is marginalised
// out (Schur complement): a corridor with nothing along it shows as a near-zero value even when the
// rotation is well fixed. 0 when H carries no information.
double translation_conditioning(const Matrix6d& H);

}  // namespace pl::registration
