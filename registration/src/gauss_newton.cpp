#include "pl/registration/gauss_newton.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>

namespace pl::registration {

void NormalEquations::flush() {
  H_ += Hf_.cast<double>();
  g_ += gf_.cast<double>();
  Hf_.setZero();
  gf_.setZero();
  block_ = 0;
}

double NormalEquations::weighted_rms() const { return w_ > 0 ? std::sqrt(wr2_ / w_) : 0.0; }

Vector6d solve_step(const Matrix6d& H, const Vector6d& g) { return H.ldlt().solve(-g); }

Vector6d solve_step_truncated(const Matrix6d& H, const Vector6d& g, double ratio, bool& degenerate, double lever_m) {
  Vector6d s;
  s << 1, 1, 1, 1 / lever_m, 1 / lever_m, 1 / lever_m;
  const Matrix6d Hs = s.asDiagonal() * H * s.asDiagonal();
  const Vector6d gs = s.cwiseProduct(g);
  Eigen::SelfAdjointEigenSolver<Matrix6d> es(Hs);
  const Vector6d ev = es.eigenvalues();
  const double floor = ratio * ev(5);
  Vector6d step = Vector6d::Zero();
  degenerate = false;
  for (int i = 0; i < 6; ++i) {
    if (!(ev(i) > floor) || !(ev(i) > 0)) {
      degenerate = true;
      continue;
    }
    const Vector6d v = es.eigenvectors().col(i);
    step -= (v.dot(gs) / ev(i)) * v;
  }
  return s.cwiseProduct(step);
}

double translation_conditioning(const Matrix6d& H) {
  const Eigen::Matrix3d Hww = H.block<3, 3>(3, 3);
  const Eigen::Matrix3d Hvw = H.block<3, 3>(0, 3);
  const Eigen::Matrix3d Hvv = H.block<3, 3>(0, 0) - Hvw * Hww.ldlt().solve(Hvw.transpose());
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(Hvv);
  const Eigen::Vector3d ev = es.eigenvalues();
  return ev(2) > 0 ? std::max(0.0, ev(0)) / ev(2) : 0.0;
}

}  // namespace pl::registration
