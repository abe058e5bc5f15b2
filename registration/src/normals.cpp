#include "pl/registration/normals.hpp"

#include <algorithm>
#include <cmath>
#include <unordered_map>

#include "pl/common/error.hpp"
#include "pl/common/voxel.hpp"

namespace pl::registration {

std::vector<Eigen::Vector3f> estimate_normals(const std::vector<Eigen::Vector3d>& points, double radius,
                                              std::vector<float>* planarity) {
  if (!(radius > 0.0)) throw Error("the normal radius must be positive");
  const double inv = 1.0 / radius, r2 = radius * radius;
  // 64-bit voxel indices in double precision (not the 21-bit cell keys): a map may span far more
  // than 2^20 cells of the normal radius.
  auto cell = [inv](const Eigen::Vector3d& p) { return voxel_index(p, inv); };
  // The points sorted by cell (each cell's in index order), each cell a run of that order.
  std::vector<std::pair<VoxelIndex, std::uint32_t>> by_cell(points.size());
  for (std::uint32_t i = 0; i < points.size(); ++i) by_cell[i] = {cell(points[i]), i};
  std::sort(by_cell.begin(), by_cell.end());
  std::unordered_map<VoxelIndex, std::pair<std::uint32_t, std::uint32_t>, VoxelIndexHash> runs;
  runs.reserve(points.size() / 4 + 1);
  for (std::uint32_t b = 0, e; b < by_cell.size(); b = e) {
    for (e = b + 1; e < by_cell.size() && by_cell[e].first == by_cell[b].first;) ++e;
    runs.emplace(by_cell[b].first, std::make_pair(b, e));
  }
  std::vector<Eigen::Vector3f> normals(points.size(), Eigen::Vector3f::UnitZ());
  if (planarity) planarity->assign(points.size(), 0.0f);
  // Cell by cell: the points of the 27 cells round it gathered once (in the order the sums take
  // them: cell by cell, index order within each), then searched for each of its points.
  std::vector<Eigen::Vector3d> near;
  for (const auto& [c, run] : runs) {
    near.clear();
    for (int dx = -1; dx <= 1; ++dx)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dz = -1; dz <= 1; ++dz) {
          auto it = runs.find({c[0] + dx, c[1] + dy, c[2] + dz});
          if (it == runs.end()) continue;
          for (std::uint32_t k = it->second.first; k < it->second.second; ++k) near.push_back(points[by_cell[k].second]);
        }
    for (std::uint32_t k = run.first; k < run.second; ++k) {
      const std::uint32_t i = by_cell[k].second;
      const Eigen::Vector3d& p = points[i];
      Eigen::Vector3d sum = Eigen::Vector3d::Zero();
      Eigen::Matrix3d outer = Eigen::Matrix3d::Zero();
      int n = 0;
      for (const Eigen::Vector3d& q : near) {
        const Eigen::Vector3d d = q - p;  // relative to the point: no precision lost far from the origin
        if (d.squaredNorm() > r2) continue;
        sum += d;
        outer += d * d.transpose();
        ++n;
      }
      if (n < 5) continue;
      const Eigen::Vector3d mean = sum / n;
      const Eigen::Matrix3d cov = outer / n - mean * mean.transpose();
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es;
      es.computeDirect(cov);
      Eigen::Vector3d nrm = es.eigenvectors().col(0);
      const double s = std::abs(nrm.z()) > 0.1 ? nrm.z() : (std::abs(nrm.x()) >= std::abs(nrm.y()) ? nrm.x() : nrm.y());
      if (s < 0) nrm = -nrm;
      normals[i] = nrm.normalized().cast<float>();
      if (planarity) {
        const double l1 = es.eigenvalues()(1);
        (*planarity)[i] = l1 > 0 ? static_cast<float>(1.0 - es.eigenvalues()(0) / l1) : 0.0f;
      }
    }
  }
  return normals;
}

void principal_axes(const Eigen::Vector3f* pts, int count, Eigen::Vector3d& c,
                    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>& es) {
  c.setZero();
  for (int i = 0; i < count; ++i) c += pts[i].cast<double>();
  c /= static_cast<double>(count);
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (int i = 0; i < count; ++i) {
    const Eigen::Vector3d d = pts[i].cast<double>() - c;
    cov += d * d.transpose();
  }
  es.computeDirect(cov);
}

bool fit_line(const Eigen::Vector3f* pts, int count, double ratio, FeatureTarget& m) {
  if (count < 2) return false;
  Eigen::Vector3d c;
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es;
  principal_axes(pts, count, c, es);
  const Eigen::Vector3d ev = es.eigenvalues();
  if (!(ev(2) > ratio * ev(1))) return false;
  for (int r = 0; r < 2; ++r) {
    const Eigen::Vector3d n = es.eigenvectors().col(r).normalized();
    m.n[r] = n.cast<float>();
    m.d[r] = static_cast<float>(-n.dot(c));
  }
  m.rows = 2;
  return true;
}

bool fit_plane(const Eigen::Vector3f* pts, int count, double max_dist, FeatureTarget& m) {
  if (count < 3) return false;
  Eigen::Vector3d c;
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es;
  principal_axes(pts, count, c, es);
  const Eigen::Vector3d n = es.eigenvectors().col(0).normalized();
  if (!(es.eigenvalues()(1) > 0)) return false;  // all on one line (or one point)
  for (int i = 0; i < count; ++i)
    if (std::abs(n.dot(pts[i].cast<double>() - c)) > max_dist) return false;
  m.n[0] = n.cast<float>();
  m.d[0] = static_cast<float>(-n.dot(c));
  m.rows = 1;
  return true;
}

}  // namespace pl::registration
