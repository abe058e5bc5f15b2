#include "pl/common/pose.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <memory>

#include "pl/common/error.hpp"
#include "pl/common/text.hpp"

namespace pl {

Pose make_pose(double x, double y, double z, double roll, double pitch, double yaw) {
  Pose p = Pose::Identity();
  p.linear() = (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
                Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()))
                   .toRotationMatrix();
  p.translation() = Eigen::Vector3d(x, y, z);
  return p;
}

double yaw_of(const Pose& pose) { return std::atan2(pose.linear()(1, 0), pose.linear()(0, 0)); }

Pose in_ground_plane(const Pose& base, const Pose& plane) {
  Pose out = base;
  out.linear() = rotation_from_vector(Eigen::Vector3d(0, 0, yaw_of(plane) - yaw_of(base))) * base.linear();
  out.translation().head<2>() = plane.translation().head<2>();
  return out;
}

Eigen::Matrix3d rotation_from_vector(const Eigen::Vector3d& w) {
  const double a = w.norm();
  if (a < 1e-15) return Eigen::Matrix3d::Identity();
  return Eigen::AngleAxisd(a, w / a).toRotationMatrix();
}

Eigen::Vector3d rotation_vector(const Eigen::Matrix3d& r) {
  const Eigen::AngleAxisd aa(r);
  return aa.angle() * aa.axis();
}

namespace {

Eigen::Matrix3d hat(const Eigen::Vector3d& w) {
  Eigen::Matrix3d m;
  m << 0, -w.z(), w.y(), w.z(), 0, -w.x(), -w.y(), w.x(), 0;
  return m;
}

}  // namespace

// t = V rho with V = I + (1 - cos a) / a^2 W + (a - sin a) / a^3 W^2, W = hat(omega), a = |omega|;
// the series below 1e-4 rad, where the closed forms lose their digits.
Pose pose_from_twist(const Twist& xi) {
  const Eigen::Vector3d rho = xi.head<3>(), w = xi.tail<3>();
  const double a = w.norm(), a2 = a * a;
  const Eigen::Matrix3d W = hat(w);
  const double b = a < 1e-4 ? 0.5 - a2 / 24.0 : (1.0 - std::cos(a)) / a2;
  const double c = a < 1e-4 ? 1.0 / 6.0 - a2 / 120.0 : (a - std::sin(a)) / (a2 * a);
  Pose out = Pose::Identity();
  out.linear() = rotation_from_vector(w);
  out.translation() = (Eigen::Matrix3d::Identity() + b * W + c * W * W) * rho;
  return out;
}

// rho = V^-1 t with V^-1 = I - W / 2 + (1 - a sin a / (2 (1 - cos a))) / a^2 W^2.
Twist twist_of(const Pose& pose) {
  const Eigen::Vector3d w = rotation_vector(pose.linear());
  const double a = w.norm(), a2 = a * a;
  const Eigen::Matrix3d W = hat(w);
  const double d = a < 1e-4 ? 1.0 / 12.0 + a2 / 720.0 : (1.0 - a * std::sin(a) / (2.0 * (1.0 - std::cos(a)))) / a2;
  Twist xi;
  xi.head<3>() = (Eigen::Matrix3d::Identity() - 0.5 * W + d * W * W) * pose.translation();
  xi.tail<3>() = w;
  return xi;
}

Pose scale_motion(const Pose& d, double f) { return pose_from_twist(f * twist_of(d)); }

double rotation_angle(const Pose& pose) {
  // atan2 of sin (from the skew-symmetric part) and cos (from the trace): small angles keep their
  // precision, which acos of the trace alone loses near zero.
  const Eigen::Matrix3d& r = pose.linear();
  Eigen::Vector3d w(r(2, 1) - r(1, 2), r(0, 2) - r(2, 0), r(1, 0) - r(0, 1));
  return std::atan2(0.5 * w.norm(), 0.5 * (r.trace() - 1.0));
}

Eigen::Matrix3d orthonormalize(const Eigen::Matrix3d& r) {
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(r, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d out = svd.matrixU() * svd.matrixV().transpose();
  if (out.determinant() < 0) {
    Eigen::Matrix3d u = svd.matrixU();
    u.col(2) *= -1.0;
    out = u * svd.matrixV().transpose();
  }
  return out;
}

Pose canonical_rotation(const Pose& p) {
  Eigen::Quaterniond q(p.linear());
  q.normalize();
  Eigen::Vector4d c = q.coeffs();  // x, y, z, w
  // The component made from the others is the largest (well conditioned: at least 0.5), the first of
  // those within 1e-6 of the largest, so that last-bit differences between near ties (a 90 deg turn:
  // w and z both 0.7071) cannot pick another one. w first.
  const int order[4] = {3, 0, 1, 2};
  double largest = 0.0;
  for (int i : order) largest = std::max(largest, std::abs(c[i]));
  int big = 3;
  for (int i : order)
    if (std::abs(c[i]) >= largest - 1e-6) {
      big = i;
      break;
    }
  if (c[big] < 0) c = -c;
  double rest = 0.0;
  for (int i = 0; i < 4; ++i) {
    if (i == big) continue;
    c[i] = std::nearbyint(c[i] * 1e9) * 1e-9;
    rest += c[i] * c[i];
  }
  c[big] = std::sqrt(std::max(0.0, 1.0 - rest));
  Pose out = p;
  out.linear() = Eigen::Quaterniond(c[3], c[0], c[1], c[2]).toRotationMatrix();
  return out;
}

Pose interpolate(const Pose& a, const Pose& b, double s) {
  Pose p = Pose::Identity();
  Eigen::Quaterniond qa(a.linear()), qb(b.linear());
  p.linear() = qa.slerp(s, qb).toRotationMatrix();
  p.translation() = (1.0 - s) * a.translation() + s * b.translation();
  return p;
}

namespace {


Pose pose_from_tum(const std::vector<double>& v, const LineReader& reader, const std::string& line) {
  Eigen::Quaterniond q(v[7], v[4], v[5], v[6]);
  double n = q.norm();
  if (!(n > 0.5 && n < 1.5)) reader.fail("a unit quaternion qx qy qz qw in fields 5 to 8", line);
  Pose p = Pose::Identity();
  p.linear() = q.normalized().toRotationMatrix();
  p.translation() = Eigen::Vector3d(v[1], v[2], v[3]);
  return p;
}

struct FileCloser {
  void operator()(std::FILE* f) const { std::fclose(f); }
};
using FilePtr = std::unique_ptr<std::FILE, FileCloser>;

FilePtr open_for_writing(const std::string& path) {
  FilePtr f(std::fopen(path.c_str(), "w"));
  if (!f) throw Error(path + ": cannot write (check that the folder exists and is writable)");
  return f;
}

void finish_writing(FilePtr f, const std::string& path) {
  if (std::ferror(f.get()) || std::fclose(f.release()) != 0) throw Error(path + ": write failed (disk full?)");
}

}  // namespace

Pose pose_from_kitti_row(const std::vector<double>& v) {
  Eigen::Matrix3d r;
  r << v[0], v[1], v[2], v[4], v[5], v[6], v[8], v[9], v[10];
  Pose p = Pose::Identity();
  p.linear() = orthonormalize(r);
  p.translation() = Eigen::Vector3d(v[3], v[7], v[11]);
  return p;
}

namespace {

std::string trim(const std::string& s) {
  const std::size_t a = s.find_first_not_of(" \t\r"), b = s.find_last_not_of(" \t\r");
  return a == std::string::npos ? std::string() : s.substr(a, b - a + 1);
}

// "1-153:2,160,170-172" -> 1, 3, ..., 153, 160, 170, 171, 172.
bool parse_frame_ids(const std::string& text, std::vector<long>& ids) {
  for (std::string_view item : split_fields(text, ",")) {
    std::string_view range = item, step_text = "1";
    if (const auto colon = item.find(':'); colon != std::string_view::npos) range = item.substr(0, colon), step_text = item.substr(colon + 1);
    long long a = 0, b = 0, step = 0;
    const auto dash = range.find('-', 1);
    if (!parse_int(std::string(range.substr(0, dash)), a) || !parse_int(std::string(step_text), step) || step < 1) return false;
    b = a;
    if (dash != std::string_view::npos && !parse_int(std::string(range.substr(dash + 1)), b)) return false;
    if (a < 0 || b < a || (b - a) / step > 100000000) return false;
    for (long long v = a; v <= b; v += step) ids.push_back(static_cast<long>(v));
  }
  return true;
}

std::string format_frame_ids(const std::vector<long>& ids) {
  std::string out;
  for (std::size_t i = 0; i < ids.size();) {
    std::size_t j = i + 1;
    const long step = j < ids.size() ? ids[j] - ids[i] : 1;
    while (step > 0 && j < ids.size() && ids[j] - ids[j - 1] == step) ++j;
    if (!out.empty()) out += ",";
    if (j - i >= 3) {
      out += std::to_string(ids[i]) + "-" + std::to_string(ids[j - 1]) + (step == 1 ? "" : ":" + std::to_string(step));
      i = j;
    } else {
      out += std::to_string(ids[i]);
      ++i;
    }
  }
  return out;
}

// The header comments of a pose file: "# frame: NAME" and "# frames: IDS" (other comments pass).
void read_header(const std::string& path, Trajectory& traj) {
  std::ifstream in(path);
  std::string line;
  std::size_t n = 0;
  while (std::getline(in, line)) {
    ++n;
    const std::size_t i = line.find_first_not_of(" \t\r");
    if (i == std::string::npos) continue;
    if (line[i] != '#') break;
    std::string body = trim(line.substr(i + 1));
    if (body.rfind("frame:", 0) == 0) {
      traj.frame = trim(body.substr(6));
    } else if (body.rfind("frames:", 0) == 0) {
      traj.frame_ids.clear();
      if (!parse_frame_ids(trim(body.substr(7)), traj.frame_ids))
        fail_at(path, n, "frame numbers like 1-153:2,160 (first-last:step, comma-separated)", line);
    }
  }
}

void write_header(std::FILE* f, const Trajectory& traj) {
  if (!traj.frame.empty()) std::fprintf(f, "# frame: %s\n", traj.frame.c_str());
  if (!traj.frame_ids.empty()) std::fprintf(f, "# frames: %s\n", format_frame_ids(traj.frame_ids).c_str());
}

void check_frame_ids(const Trajectory& traj, const std::string& path) {
  if (!traj.frame_ids.empty() && traj.frame_ids.size() != traj.poses.size())
    throw Error(path + ": the header's frames name " + std::to_string(traj.frame_ids.size()) + " frames for " +
                std::to_string(traj.poses.size()) + " poses");
}

}  // namespace

Trajectory read_kitti_poses(const std::string& path) {
  LineReader reader(path);
  Trajectory traj;
  traj.format = PoseFormat::Kitti;
  read_header(path, traj);
  std::string line;
  while (reader.next(line)) {
    auto v = parse_numbers(reader, line, 12, 12, "a KITTI pose: the row-major 3x4 matrix", " \t\r");
    traj.poses.push_back(pose_from_kitti_row(v));
  }
  check_frame_ids(traj, path);
  return traj;
}

Trajectory read_tum_poses(const std::string& path) {
  LineReader reader(path);
  Trajectory traj;
  traj.format = PoseFormat::Tum;
  read_header(path, traj);
  std::string line;
  while (reader.next(line)) {
    auto v = parse_numbers(reader, line, 8, 8, "a TUM pose: t x y z qx qy qz qw", " \t\r");
    if (!traj.times.empty() && v[0] < traj.times.back())
      reader.fail("timestamps in increasing order (previous " + std::to_string(traj.times.back()) + ")", line);
    traj.times.push_back(v[0]);
    traj.poses.push_back(pose_from_tum(v, reader, line));
  }
  check_frame_ids(traj, path);
  return traj;
}

Trajectory read_trajectory(const std::string& path) {
  LineReader reader(path);
  std::string line;
  if (!reader.next(line)) throw Error(path + ": empty trajectory file (expected KITTI or TUM poses)");
  std::size_t n = split_fields(line, " \t\r").size();
  if (n == 12) return read_kitti_poses(path);
  if (n == 8) return read_tum_poses(path);
  reader.fail("12 numbers a line (KITTI) or 8 numbers a line (TUM: t x y z qx qy qz qw)", line);
}

std::optional<PoseFormat> parse_pose_format(const std::string& name) {
  if (name == "kitti") return PoseFormat::Kitti;
  if (name == "tum") return PoseFormat::Tum;
  return std::nullopt;
}

void write_kitti_poses(const std::string& path, const Trajectory& traj) {
  FilePtr f = open_for_writing(path);
  write_header(f.get(), traj);
  for (const Pose& p : traj.poses) {
    const auto& m = p.matrix();
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 4; ++c) std::fprintf(f.get(), (r == 2 && c == 3) ? "%.17g\n" : "%.17g ", m(r, c));
  }
  finish_writing(std::move(f), path);
}

void write_tum_poses(const std::string& path, const Trajectory& traj) {
  if (!traj.has_times()) throw Error(path + ": TUM poses need a time for every pose (write KITTI instead, or attach times)");
  FilePtr f = open_for_writing(path);
  write_header(f.get(), traj);
  for (std::size_t i = 0; i < traj.size(); ++i) {
    const Pose& p = traj.poses[i];
    Eigen::Quaterniond q(p.linear());
    if (q.w() < 0) q.coeffs() *= -1.0;
    std::fprintf(f.get(), "%.6f %.17g %.17g %.17g %.17g %.17g %.17g %.17g\n", traj.times[i], p.translation().x(),
                 p.translation().y(), p.translation().z(), q.x(), q.y(), q.z(), q.w());
  }
  finish_writing(std::move(f), path);
}

void write_trajectory(const std::string& path, const Trajectory& traj, PoseFormat format) {
  if (format == PoseFormat::Kitti)
    write_kitti_poses(path, traj);
  else
    write_tum_poses(path, traj);
}

}  // namespace pl
