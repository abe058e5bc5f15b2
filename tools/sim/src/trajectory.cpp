#include "pl/sim/trajectory.hpp"

#include <algorithm>
#include <cmath>

#include "pl/common/error.hpp"
#include "pl/common/text.hpp"

namespace pl::sim {

SimTrajectory::SimTrajectory(std::vector<double> times, std::vector<Pose, Eigen::aligned_allocator<Pose>> poses)
    : times_(std::move(times)), poses_(std::move(poses)) {
  if (times_.size() != poses_.size() || times_.size() < 2) throw Error("a trajectory needs at least two timed poses");
  for (std::size_t i = 1; i < times_.size(); ++i)
    if (!(times_[i] > times_[i - 1])) throw Error("trajectory times must increase (pose " + std::to_string(i) + ")");
  cumulative_.assign(poses_.size(), 0.0);
  for (std::size_t i = 1; i < poses_.size(); ++i)
    cumulative_[i] = cumulative_[i - 1] + (poses_[i].translation() - poses_[i - 1].translation()).norm();
}

std::size_t SimTrajectory::segment(double t, double& frac) const {
  if (t <= times_.front()) {
    frac = 0.0;
    return 0;
  }
  if (t >= times_.back()) {
    frac = 1.0;
    return times_.size() - 2;
  }
  std::size_t i = static_cast<std::size_t>(std::upper_bound(times_.begin(), times_.end(), t) - times_.begin()) - 1;
  frac = (t - times_[i]) / (times_[i + 1] - times_[i]);
  return i;
}

SimTrajectory SimTrajectory::retimed(double speed_scale) const {
  if (!(speed_scale > 0) || !std::isfinite(speed_scale)) throw Error("the speed scale must be a positive number");
  std::vector<double> t(times_.size());
  for (std::size_t i = 0; i < t.size(); ++i) t[i] = times_.front() + (times_[i] - times_.front()) / speed_scale;
  return SimTrajectory(std::move(t), poses_);
}

SimTrajectory SimTrajectory::reversed() const {
  Pose turn = Pose::Identity();  // 180 deg about z, exactly: x and y flip, z (up) stays
  turn.linear().diagonal() << -1.0, -1.0, 1.0;
  const double mirror = times_.front() + times_.back();
  std::vector<double> t;
  std::vector<Pose, Eigen::aligned_allocator<Pose>> p;
  for (std::size_t i = times_.size(); i-- > 0;) {
    t.push_back(mirror - times_[i]);
    p.push_back(poses_[i] * turn);
  }
  return SimTrajectory(std::move(t), std::move(p));
}

double SimTrajectory::max_speed() const {
  double v = 0.0;
  for (std::size_t i = 1; i < times_.size(); ++i) v = std::max(v, (cumulative_[i] - cumulative_[i - 1]) / (times_[i] - times_[i - 1]));
  return v;
}

Pose SimTrajectory::pose_at(double t) const {
  double f = 0.0;
  std::size_t i = segment(t, f);
  return interpolate(poses_[i], poses_[i + 1], f);
}

double SimTrajectory::distance_at(double t) const {
  double f = 0.0;
  std::size_t i = segment(t, f);
  return cumulative_[i] + f * (cumulative_[i + 1] - cumulative_[i]);
}

double SimTrajectory::time_at_distance(double s) const {
  if (s <= 0.0) return times_.front();
  if (s >= cumulative_.back()) return times_.back();
  std::size_t i = static_cast<std::size_t>(std::upper_bound(cumulative_.begin(), cumulative_.end(), s) - cumulative_.begin()) - 1;
  double len = cumulative_[i + 1] - cumulative_[i];
  double f = len > 0 ? (s - cumulative_[i]) / len : 0.0;
  return times_[i] + f * (times_[i + 1] - times_[i]);
}

std::string find_times_for(const std::string& poses_path) {
  std::string dir = ".", name = poses_path;
  auto slash = poses_path.find_last_of('/');
  if (slash != std::string::npos) dir = poses_path.substr(0, slash), name = poses_path.substr(slash + 1);
  std::string candidate = dir + "/times-" + name;
  if (file_exists(candidate)) return candidate;
  candidate = dir + "/times.txt";
  if (file_exists(candidate) && candidate != poses_path) return candidate;
  return {};
}

namespace {

SimTrajectory trajectory_from_file(const std::string& poses_path, const std::string& times_path, bool cam0) {
  Trajectory cam = read_kitti_poses(poses_path);
  if (cam.size() < 2) throw Error(poses_path + ": needs at least two poses");
  std::vector<double> times;
  if (!times_path.empty()) {
    LineReader reader(times_path);
    std::string line;
    while (reader.next(line)) times.push_back(parse_numbers(reader, line, 1, 1, "a time in seconds")[0]);
    if (times.size() < cam.size())
      throw Error(times_path + ": has " + std::to_string(times.size()) + " times for " + std::to_string(cam.size()) + " poses in " + poses_path);
    times.resize(cam.size());
  } else {
    for (std::size_t i = 0; i < cam.size(); ++i) times.push_back(0.1 * static_cast<double>(i));
  }
  Pose tr = Pose::Identity();  // LiDAR -> cam0, the nominal axis change
  if (cam0) tr.linear() << 0, -1, 0, 0, 0, -1, 1, 0, 0;
  std::vector<Pose, Eigen::aligned_allocator<Pose>> poses;
  for (const Pose& p : cam.poses) poses.push_back(tr.inverse() * p * tr);
  return SimTrajectory(std::move(times), std::move(poses));
}

}  // namespace

SimTrajectory trajectory_from_kitti(const std::string& poses_path, const std::string& times_path) {
  return trajectory_from_file(poses_path, times_path, true);
}

SimTrajectory trajectory_from_lidar_poses(const std::string& poses_path, const std::string& times_path) {
  return trajectory_from_file(poses_path, times_path, false);
}

namespace {

// A closed route from 2-D waypoints, smoothed into arcs, driven at `cruise` m/s with slowing where
// the path curves; heights follow `grade(s)`.
template <typename Grade>
SimTrajectory route_from_waypoints(const std::vector<Eigen::Vector2d>& corners, double corner_radius, double cruise,
                                   Grade&& grade) {
  // Dense polyline: straight edges joined by circular arcs of corner_radius.
  std::vector<Eigen::Vector2d> pts;
  std::size_t n = corners.size();
  for (std::size_t i = 0; i < n; ++i) {
    Eigen::Vector2d prev = corners[(i + n - 1) % n], c = corners[i], next = corners[(i + 1) % n];
    Eigen::Vector2d din = (c - prev).normalized(), dout = (next - c).normalized();
    double turn = std::atan2(din.x() * dout.y() - din.y() * dout.x(), din.dot(dout));
    double cut = corner_radius * std::tan(std::abs(turn) / 2);
    Eigen::Vector2d a = c - din * cut;
    Eigen::Vector2d left(-din.y(), din.x());
    Eigen::Vector2d centre = a + left * (turn > 0 ? corner_radius : -corner_radius);
    int steps = std::max(2, static_cast<int>(std::abs(turn) * corner_radius / 0.25));
    double start = std::atan2(a.y() - centre.y(), a.x() - centre.x());
    for (int k = 0; k <= steps; ++k) {
      double ang = start + turn * k / steps;
      pts.push_back(centre + corner_radius * Eigen::Vector2d(std::cos(ang), std::sin(ang)));
    }
  }
  // Resample at 0.25 m, close the loop.
  std::vector<Eigen::Vector2d> dense;
  for (std::size_t i = 0; i < pts.size(); ++i) {
    Eigen::Vector2d a = pts[i], b = pts[(i + 1) % pts.size()];
    int steps = std::max(1, static_cast<int>((b - a).norm() / 0.25));
    for (int k = 0; k < steps; ++k) dense.push_back(a + (b - a) * (static_cast<double>(k) / steps));
  }
  // Speed: slower where the heading changes fast (lateral acceleration <= 2 m/s^2), smoothed.
  std::size_t m = dense.size();
  std::vector<double> heading(m), speed(m);
  for (std::size_t i = 0; i < m; ++i) {
    Eigen::Vector2d d = dense[(i + 1) % m] - dense[i];
    heading[i] = std::atan2(d.y(), d.x());
  }
  for (std::size_t i = 0; i < m; ++i) {
    double dh = std::remainder(heading[(i + 1) % m] - heading[i], 2 * M_PI);
    double ds = (dense[(i + 1) % m] - dense[i]).norm();
    double curvature = ds > 0 ? std::abs(dh) / ds : 0.0;
    speed[i] = std::min(cruise, curvature > 1e-6 ? std::sqrt(2.0 / curvature) : cruise);
  }
  for (int pass = 0; pass < 2; ++pass) {  // limit acceleration to ~1 m/s^2 both ways
    for (std::size_t i = 1; i < m; ++i) speed[i] = std::min(speed[i], std::sqrt(speed[i - 1] * speed[i - 1] + 2.0 * 0.25));
    for (std::size_t i = m - 1; i-- > 0;) speed[i] = std::min(speed[i], std::sqrt(speed[i + 1] * speed[i + 1] + 2.0 * 0.25));
  }
  std::vector<double> times;
  std::vector<Pose, Eigen::aligned_allocator<Pose>> poses;
  double t = 0.0, s = 0.0;
  for (std::size_t i = 0; i < m; ++i) {
    double z = grade(s) + kLidarHeight;
    double dz = grade(s + 0.5) - grade(s - 0.5);
    double pitch = -std::atan2(dz, 1.0);
    poses.push_back(make_pose(dense[i].x(), dense[i].y(), z, 0.0, pitch, heading[i]));
    times.push_back(t);
    double ds = (dense[(i + 1) % m] - dense[i]).norm();
    t += ds / std::max(0.5, speed[i]);
    s += ds;
  }
  // Unwrap the yaw through the slerp: consecutive headings differ by little, so interpolation is safe.
  return SimTrajectory(std::move(times), std::move(poses));
}

}  // namespace

bool is_builtin_route(const std::string& name) { return name == "loop" || name == "estate"; }

SimTrajectory builtin_route(const std::string& name) {
  if (name == "loop") {
    // A rounded 210 m x 105 m block with a kink on its north side: ~600 m, corners of 12 m radius.
    std::vector<Eigen::Vector2d> corners = {{0, 0}, {210, 0}, {210, 105}, {135, 105}, {110, 90}, {0, 90}};
    return route_from_waypoints(corners, 12.0, 9.0, [](double s) { return 1.2 * std::sin(s / 95.0) + 0.4 * std::sin(s / 31.0); });
  }
  if (name == "estate") {
    // Wide estate roads around warehouse blocks, one side along an open square: ~900 m.
    std::vector<Eigen::Vector2d> corners = {{0, 0}, {260, 0}, {260, 120}, {150, 190}, {0, 190}};
    return route_from_waypoints(corners, 18.0, 10.0, [](double s) { return 0.5 * std::sin(s / 140.0); });
  }
  throw Error("unknown route \"" + name + "\" (loop or estate)");
}

}  // namespace pl::sim
