#include "pl/eval/geometry.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace pl::eval {

Positions positions_of(const Trajectory& traj) {
  Positions out;
  out.reserve(traj.size());
  for (const Pose& p : traj.poses) out.push_back(p.translation());
  return out;
}

std::vector<double> path_distances(const Positions& p) {
  std::vector<double> d(p.size(), 0.0);
  for (std::size_t i = 1; i < p.size(); ++i) d[i] = d[i - 1] + (p[i] - p[i - 1]).norm();
  return d;
}

int auto_vertical_axis(const Positions& gt) {
  if (gt.empty()) return 2;
  Eigen::Vector3d lo = gt.front(), hi = gt.front();
  for (const auto& p : gt) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  const Eigen::Vector3d extent = hi - lo;
  int best = 2;  // z wins ties, then y, then x
  for (int axis : {1, 0})
    if (extent[axis] < extent[best]) best = axis;
  return best;
}

char axis_name(int axis) { return axis == 0 ? 'x' : axis == 1 ? 'y' : 'z'; }

int parse_axis(const std::string& name) {
  if (name == "x") return 0;
  if (name == "y") return 1;
  if (name == "z") return 2;
  return -1;
}

Positions travel_directions(const Positions& p, int vertical_axis) {
  const std::size_t n = p.size();
  constexpr double kMinMove = 1e-3;  // metres
  auto horizontal = [vertical_axis](Eigen::Vector3d v) {
    v[vertical_axis] = 0.0;
    return v;
  };
  Positions dir(n, Eigen::Vector3d::Zero());
  std::vector<bool> valid(n, false);
  for (std::size_t k = 0; k < n; ++k) {
    // Widen [a, b] around k until the horizontal displacement is measurable or both ends are hit.
    std::size_t a = k > 0 ? k - 1 : 0;
    std::size_t b = k + 1 < n ? k + 1 : k;
    while (true) {
      Eigen::Vector3d d = horizontal(p[b] - p[a]);
      double len = d.norm();
      if (len >= kMinMove) {
        dir[k] = d / len;
        valid[k] = true;
        break;
      }
      if (a == 0 && b + 1 >= n) break;
      if (a > 0) --a;
      if (b + 1 < n) ++b;
    }
  }
  // Positions where no movement was found take the direction of the nearest one that has one.
  constexpr std::size_t kNone = std::numeric_limits<std::size_t>::max();
  std::vector<std::size_t> prev(n, kNone), next(n, kNone);
  for (std::size_t k = 0; k < n; ++k) prev[k] = valid[k] ? k : (k > 0 ? prev[k - 1] : kNone);
  for (std::size_t k = n; k-- > 0;) next[k] = valid[k] ? k : (k + 1 < n ? next[k + 1] : kNone);
  const bool any = n > 0 && (prev[n - 1] != kNone);
  for (std::size_t k = 0; k < n; ++k) {
    if (valid[k] || !any) continue;
    if (prev[k] == kNone)
      dir[k] = dir[next[k]];
    else if (next[k] == kNone || k - prev[k] <= next[k] - k)
      dir[k] = dir[prev[k]];
    else
      dir[k] = dir[next[k]];
  }
  if (!any) {
    Eigen::Vector3d axis = Eigen::Vector3d::Zero();
    axis[vertical_axis == 0 ? 1 : 0] = 1.0;
    std::fill(dir.begin(), dir.end(), axis);
  }
  return dir;
}

}  // namespace pl::eval
