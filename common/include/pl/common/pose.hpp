// Poses (Eigen::Isometry3d) and the two trajectory file formats: KITTI (12 numbers a line, the
// row-major 3x4 pose) and TUM (`t x y z qx qy qz qw`).
#pragma once

#include <Eigen/Geometry>
#include <optional>
#include <string>
#include <string>
#include <vector>

namespace pl {

using Pose = Eigen::Isometry3d;

enum class PoseFormat { Kitti, Tum };

// A trajectory: poses, with a time for each when the format carries one (TUM) or when it was
// attached (e.g. KITTI poses with the dataset's times.txt).
struct Trajectory {
  std::vector<Pose, Eigen::aligned_allocator<Pose>> poses;
  std::vector<double> times;  // empty, or one per pose
  PoseFormat format = PoseFormat::Kitti;
  // What the poses are, when known, written as header comments ("# frame: lidar", "# frames: 1-153:2")
  // and read back: the coordinate frame whose poses they are (e.g. "lidar"; KITTI's odometry ground
  // truth is "cam0"), and the dataset's frame number of each pose, so that files whose lines do not
  // correspond are not compared (pl-eval).
  std::string frame;
  std::vector<long> frame_ids;  // empty, or one per pose

  std::size_t size() const { return poses.size(); }
  bool has_times() const { return times.size() == poses.size() && !poses.empty(); }
};

// Builds a pose from a translation and roll/pitch/yaw (R = Rz(yaw) Ry(pitch) Rx(roll)).
Pose make_pose(double x, double y, double z, double roll = 0.0, double pitch = 0.0, double yaw = 0.0);
// Heading of the pose's x axis in the xy plane.
double yaw_of(const Pose& pose);
// The pose `plane` gives in the ground plane (x, y and heading), with the height, roll and pitch of `base`.
Pose in_ground_plane(const Pose& base, const Pose& plane);
// The rotation of rotation vector w (axis * angle, radians), and back: SO(3)'s exp and log.
Eigen::Matrix3d rotation_from_vector(const Eigen::Vector3d& w);
Eigen::Vector3d rotation_vector(const Eigen::Matrix3d& r);
// SE(3)'s exp and log: the twist (translation part rho, then rotation vector omega) whose constant
// motion over unit time is the pose, and back. (No Debian 12 package has a Lie group library:
// Sophus is not in bookworm.)
using Twist = Eigen::Matrix<double, 6, 1>;
Pose pose_from_twist(const Twist& xi);
Twist twist_of(const Pose& pose);
// A motion d continued at constant twist for f times its duration: exp(f log d). A vehicle turning
// at a steady rate stays on its arc, where scaling the translation and the angle apart (the chord)
// puts it off the curve: 0.6 m after 3.4 m on drive 0005's bends.
Pose scale_motion(const Pose& d, double f);
// Rotation angle of a pose's rotation part, in radians [0, pi] (precise for small angles too).
double rotation_angle(const Pose& pose);
// Projects a nearly-orthonormal 3x3 matrix (e.g. parsed from text rounded to 7 digits) onto SO(3).
Eigen::Matrix3d orthonormalize(const Eigen::Matrix3d& r);
// The pose with its rotation on a fixed grid: the unit quaternion, its largest component positive and
// made from the three others, rounded to 1e-9 (a rotation changes by at most a few nanoradians).
// Rotations that differ only in their last bits (one read as a rotation matrix, the other as a
// quaternion written from it) come out bit for bit the same, and applying it again changes nothing,
// so that a drive gives the same map and poses whichever container carried it.
Pose canonical_rotation(const Pose& p);
// Interpolates between two poses (linear translation, slerp rotation), s in [0, 1].
Pose interpolate(const Pose& a, const Pose& b, double s);

// A pose from the 12 numbers of a KITTI line (row-major 3x4), rotation projected onto SO(3).
Pose pose_from_kitti_row(const std::vector<double>& v);

// Readers throw pl::Error naming the file, the line and what was expected.
Trajectory read_kitti_poses(const std::string& path);
Trajectory read_tum_poses(const std::string& path);
// Decides the format from the first data line: 12 numbers = KITTI, 8 = TUM.
Trajectory read_trajectory(const std::string& path);
std::optional<PoseFormat> parse_pose_format(const std::string& name);

void write_kitti_poses(const std::string& path, const Trajectory& traj);
void write_tum_poses(const std::string& path, const Trajectory& traj);  // needs times
void write_trajectory(const std::string& path, const Trajectory& traj, PoseFormat format);

}  // namespace pl
