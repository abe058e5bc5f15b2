// One map from several drives: pl-sim drives a stretch of the town one way and back, and pl-map
// build places both in one pose graph, joined by their GPS fixes and the loops between them; a drive
// without GPS is joined by its loops alone; a drive that joins nothing is refused by name.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include <nlohmann/json.hpp>

#include "pl/common/cloud_io.hpp"
#include "pl/common/pose.hpp"
#include "pl/recordings/dataset.hpp"
#include "test_util.hpp"

using pl::test::run;
using pl::test::TempDir;
using pl::test::tool;

namespace {

// The stretch forward and back (different traffic and noise), and an estate drive elsewhere.
std::string drives() {
  return pl::test::made_once("two-drives", [](const std::string& d) {
    const std::string sim = tool("pl-sim") + " --route loop --frames 100 --seed 5 --traffic 4 ";
    auto a = run(sim + "--drive-seed 1 --out " + d + "/forward");
    ASSERT_EQ(a.exit_code, 0) << a.output;
    auto b = run(sim + "--drive-seed 2 --reverse --out " + d + "/back");
    ASSERT_EQ(b.exit_code, 0) << b.output;
    auto c = run(tool("pl-sim") + " --route estate --frames 20 --lidar vlp16 --out " + d + "/elsewhere");
    ASSERT_EQ(c.exit_code, 0) << c.output;
    std::filesystem::remove(d + "/elsewhere/gps.csv");
  });
}

// A copy of a drive without its GPS fixes (the scans linked, not copied).
std::string without_gps(const std::string& drive, const std::string& out) {
  std::filesystem::create_directories(out);
  for (const auto& e : std::filesystem::directory_iterator(drive)) {
    const std::string name = e.path().filename().string();
    if (name == "gps.csv") continue;
    if (e.is_directory()) std::filesystem::create_directory_symlink(e.path(), out + "/" + name);
    else std::filesystem::copy_file(e.path(), out + "/" + name);
  }
  return out;
}

double mean_error(const std::string& trajectory, const std::string& drive) {
  const pl::Trajectory t = pl::read_trajectory(trajectory);
  const pl::Dataset ds = pl::open_dataset(drive);
  EXPECT_EQ(t.size(), ds.size());
  double sum = 0;
  for (std::size_t i = 0; i < t.size() && i < ds.size(); ++i)
    sum += (t.poses[i].translation() - ds.ground_truth.poses[i].translation()).norm();
  return sum / static_cast<double>(t.size());
}

}  // namespace

TEST(MultiDrive, AStretchDrivenBothWaysIsOneMapJoinedByLoopsBetweenTheDrives) {
  const std::string d = drives();
  TempDir dir;
  auto r = run(tool("pl-map") + " build --dataset " + d + "/forward --dataset " + d + "/back --poses lidar --gps --loops --report " +
               (dir / "report.json") + " --traj-out " + (dir / "forward.txt") + " --traj-out " + (dir / "back.txt") + " --out " +
               (dir / "map.pcd"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("lidar odometry, drive 2 of 2"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("of 2 drives"), std::string::npos) << r.output;
  const auto report = nlohmann::json::parse(pl::test::read_file(dir / "report.json"));
  const auto& ds = report.at("drives");
  ASSERT_EQ(ds.size(), 2u);
  // The two drives pass the same places, facing the other way: loops join them.
  EXPECT_GE(ds[0].at("loops_to")[1].get<int>(), 3);
  EXPECT_EQ(ds[0].at("loops_to")[1], ds[1].at("loops_to")[0]);
  for (const auto& drive : ds) {
    EXPECT_GT(drive.at("keyframes").get<int>(), 20);
    EXPECT_GT(drive.at("gps_edges").get<int>(), 50);
    EXPECT_LT(drive.at("mean_error_after_m").get<double>(), 0.1) << drive.dump();
  }
  for (const auto& loop : report.at("loops").at("edges")) EXPECT_TRUE(loop.contains("query_drive"));
  // The trajectories in the map's frame, against each drive's truth; the report says the same.
  const double forward = mean_error(dir / "forward.txt", d + "/forward"), back = mean_error(dir / "back.txt", d + "/back");
  EXPECT_NEAR(forward, ds[0].at("mean_error_after_m").get<double>(), 1e-6);
  EXPECT_NEAR(back, ds[1].at("mean_error_after_m").get<double>(), 1e-6);
  // Which drive each tile's points came from: both drives saw the stretch.
  std::size_t shared = 0, points = 0;
  for (const auto& tile : report.at("tiles")) {
    const auto& by = tile.at("points_by_drive");
    shared += by[0].get<int>() > 0 && by[1].get<int>() > 0;
    points += tile.at("points").get<std::size_t>();
    EXPECT_LE(by[0].get<std::size_t>(), tile.at("points").get<std::size_t>());
  }
  EXPECT_GE(shared, 5u);
  EXPECT_EQ(points, pl::read_cloud(dir / "map.pcd").points.size());
}

TEST(MultiDrive, ADriveWithoutGpsIsJoinedByItsLoopsAlone) {
  const std::string d = drives();
  TempDir dir;
  const std::string back = without_gps(d + "/back", dir / "back");
  auto r = run(tool("pl-map") + " build --dataset " + d + "/forward --dataset " + back + " --poses lidar --gps --loops --report " +
               (dir / "report.json") + " --traj-out " + (dir / "forward.txt") + " --traj-out " + (dir / "back.txt") + " --out " +
               (dir / "map.pcd"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto report = nlohmann::json::parse(pl::test::read_file(dir / "report.json"));
  const auto& ds = report.at("drives");
  EXPECT_EQ(ds[1].at("gps_edges").get<int>(), 0);
  EXPECT_GE(ds[1].at("loops_to")[0].get<int>(), 1);
  EXPECT_GE(report.at("loops").at("proposed_by_place").get<int>(), 1);  // the first tie: by place, not position
  // Placed through the loops on a drive placed by its fixes, it lies where it was driven.
  EXPECT_LT(mean_error(dir / "back.txt", back), 0.1);  // 9 mm here, 6 cm in the sanitizer build
}

TEST(MultiDrive, ADriveThatJoinsNothingIsRefusedByName) {
  const std::string d = drives();
  TempDir dir;
  const std::string build = tool("pl-map") + " build --out " + (dir / "map.pcd") + " --poses lidar --dataset " + d + "/forward";
  auto r = run(build + " --dataset " + d + "/elsewhere --gps --loops");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find(d + "/elsewhere: nothing joins this drive"), std::string::npos) << r.output;
  EXPECT_FALSE(std::filesystem::exists(dir / "map.pcd"));
  // Without --gps a drive lacking fixes is no different; without either, nothing can join a second drive.
  r = run(build + " --dataset " + d + "/back");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("need --gps or --loops"), std::string::npos) << r.output;
  // One trajectory per drive.
  r = run(build + " --dataset " + d + "/back --gps --traj-out " + (dir / "one.txt"));
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("--traj-out: 1 given for 2 drives"), std::string::npos) << r.output;
}
