// Helpers for the pl_eval tests: synthetic trajectories, temporary folders, running commands.
#pragma once

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "pl/common/pose.hpp"

namespace pl::eval::test {

inline Trajectory kitti_trajectory(const std::vector<Pose, Eigen::aligned_allocator<Pose>>& poses) {
  Trajectory t;
  t.format = PoseFormat::Kitti;
  t.poses = poses;
  return t;
}

inline Trajectory tum_trajectory(const std::vector<Pose, Eigen::aligned_allocator<Pose>>& poses,
                                 const std::vector<double>& times) {
  Trajectory t;
  t.format = PoseFormat::Tum;
  t.poses = poses;
  t.times = times;
  return t;
}

// A curvy, hilly path with n poses about `step` metres apart, heading along the tangent.
inline Trajectory curvy_path(std::size_t n, double step = 1.5) {
  std::vector<Pose, Eigen::aligned_allocator<Pose>> poses;
  double x = 0, y = 0, yaw = 0;
  for (std::size_t k = 0; k < n; ++k) {
    const double s = static_cast<double>(k) * step;
    const double z = 3.0 * std::sin(s / 60.0);
    poses.push_back(make_pose(x, y, z, 0.0, 0.0, yaw));
    const double curvature = 0.02 * std::sin(s / 80.0) + 0.004;
    yaw += curvature * step;
    x += step * std::cos(yaw);
    y += step * std::sin(yaw);
  }
  return kitti_trajectory(poses);
}

// A fresh folder under the system temp folder, removed (with its contents) at the end of scope.
class TempDir {
 public:
  TempDir() {
    std::string tmpl = (std::filesystem::temp_directory_path() / "pl_eval_test_XXXXXX").string();
    if (!::mkdtemp(tmpl.data())) throw std::runtime_error("mkdtemp failed");
    path_ = tmpl;
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  std::string file(const std::string& name) const { return (std::filesystem::path(path_) / name).string(); }
  const std::string& path() const { return path_; }

 private:
  std::string path_;
};

inline std::string read_text(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

inline void write_text(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
}

inline std::string shell_quote(const std::string& s) {
  std::string out = "'";
  for (char c : s) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

struct RunResult {
  int exit_code = -1;
  std::string out;
  std::string err;
};

// Runs argv (quoted) with stdout and stderr captured through files in `dir`.
inline RunResult run(const std::vector<std::string>& argv, const TempDir& dir) {
  std::string cmd;
  for (const auto& a : argv) cmd += shell_quote(a) + " ";
  const std::string out = dir.file("stdout.txt"), err = dir.file("stderr.txt");
  cmd += ">" + shell_quote(out) + " 2>" + shell_quote(err);
  const int status = std::system(cmd.c_str());
  RunResult r;
  r.exit_code = (status != -1 && WIFEXITED(status)) ? WEXITSTATUS(status) : -1;
  r.out = read_text(out);
  r.err = read_text(err);
  return r;
}

// The built pl-eval: $PL_BIN/pl-eval (set by ctest), else the build tree's bin folder.
inline std::string pl_eval_exe() {
  const char* bin = std::getenv("PL_BIN");
  return std::string(bin && *bin ? bin : PL_BINARY_DIR "/bin") + "/pl-eval";
}

// A command line that must be refused, and the text its error message must hold.
struct UsageCase {
  std::vector<std::string> args;
  std::string expected;
};

// Each case exits with code 2 and "pl-eval: error: ..." naming `expected` on stderr.
inline void expect_usage_errors(const std::vector<UsageCase>& cases, const TempDir& dir) {
  for (const auto& c : cases) {
    const RunResult r = run(c.args, dir);
    std::string cmd;
    for (const auto& a : c.args) cmd += a + " ";
    EXPECT_EQ(r.exit_code, 2) << cmd;
    EXPECT_NE(r.err.find("pl-eval: error: "), std::string::npos) << cmd << "\n" << r.err;
    EXPECT_NE(r.err.find(c.expected), std::string::npos) << cmd << "\n" << r.err;
  }
}

inline bool starts_with(const std::string& s, const std::string& prefix) { return s.rfind(prefix, 0) == 0; }

inline std::size_t count_of(const std::string& s, const std::string& needle) {
  std::size_t n = 0;
  for (std::size_t i = s.find(needle); i != std::string::npos; i = s.find(needle, i + needle.size())) ++n;
  return n;
}

}  // namespace pl::eval::test
