// The map top view: cell sizing, the SVG it writes, and the built pl-eval topview.
#include "pl/eval/topview.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <random>
#include <regex>

#include "eval_test_util.hpp"
#include "pl/common/cloud_io.hpp"
#include "pl/common/error.hpp"

namespace pl::eval {
namespace {

using test::count_of;
using test::read_text;
using test::expect_usage_errors;
using test::run;
using test::UsageCase;
using test::RunResult;
using test::TempDir;

const std::string kPython = PL_PYTHON3;

// A 40 m x 30 m "block": a floor of points every 0.25 m and a 20 m wall along y = 10, 3 m high.
Points3d block_cloud() {
  Points3d cloud;
  for (int i = 0; i < 160; ++i)
    for (int j = 0; j < 120; ++j) cloud.emplace_back(0.25 * i + 0.1, 0.25 * j + 0.1, 0.0);
  for (int i = 0; i < 200; ++i)
    for (int k = 0; k < 30; ++k) cloud.emplace_back(5.0 + 0.1 * i, 10.05, 0.1 * k);
  return cloud;
}

Trajectory loop_trajectory(PoseFormat format) {
  Trajectory t;
  t.format = format;
  for (int k = 0; k < 100; ++k) {
    const double a = 2.0 * M_PI * k / 100.0;
    t.poses.push_back(make_pose(20.0 + 12.0 * std::cos(a), 15.0 + 9.0 * std::sin(a), 1.7, 0, 0, a + M_PI / 2));
    t.times.push_back(1000.0 + 0.1 * k);
  }
  if (format == PoseFormat::Kitti) t.times.clear();
  return t;
}

TEST(EvalTopview, TrackArgumentsAndOccupiedCells) {
  TempDir dir;
  EXPECT_EQ(parse_track_argument("runs/est.txt"), std::make_pair(std::string("runs/est.txt"), std::string("est")));
  EXPECT_EQ(parse_track_argument("runs/est.txt:LiDAR only"),
            std::make_pair(std::string("runs/est.txt"), std::string("LiDAR only")));
  // A file whose name has a colon is taken whole.
  test::write_text(dir.file("a:b.txt"), "x");
  EXPECT_EQ(parse_track_argument(dir.file("a:b.txt")).second, "a:b");
  EXPECT_THROW(parse_track_argument("est.txt:"), pl::Error);
  EXPECT_THROW(parse_track_argument(":label"), pl::Error);

  const Points3d cloud = block_cloud();
  EXPECT_EQ(count_occupied_cells(cloud, 1.0), 40u * 30u);  // the wall falls in floor cells
  EXPECT_EQ(count_occupied_cells(cloud, 2.0), 20u * 15u);
  EXPECT_EQ(count_occupied_cells(cloud, 0.25), 160u * 120u);
  EXPECT_THROW(count_occupied_cells(cloud, 0.0), pl::Error);
}

TEST(EvalTopview, CellsGrowUntilFewEnoughAreOccupied) {
  TempDir dir;
  const Points3d cloud = block_cloud();
  TopviewOptions options;
  options.cell = 0.25;
  options.max_cells = 2000;
  const TopviewResult r = write_topview(cloud, {}, options, dir.file("t.svg"));
  EXPECT_GT(r.cell, 0.25);
  EXPECT_LE(r.cells, 2000u);
  EXPECT_EQ(r.cells, count_occupied_cells(cloud, r.cell));
  EXPECT_GT(r.cells, 500u);  // grown by about the needed factor, not far beyond
  EXPECT_EQ(r.points, cloud.size());
  EXPECT_EQ(r.bytes, std::filesystem::file_size(dir.file("t.svg")));

  EXPECT_THROW(write_topview({}, {}, options, dir.file("e.svg")), pl::Error);
  options.cell = -1.0;
  EXPECT_THROW(write_topview(cloud, {}, options, dir.file("e.svg")), pl::Error);
}

TEST(EvalTopview, LargeMapStaysSmall) {
  // 500 m x 600 m, one point per square metre with random heights (so that neighbouring cells rarely
  // share a shade and merge): the cells are enlarged to stay within 60000, the file within 3 MB.
  TempDir dir;
  Points3d cloud;
  std::mt19937 rng(2);
  std::uniform_real_distribution<double> z(0.0, 10.0);
  for (int i = 0; i < 500; ++i)
    for (int j = 0; j < 600; ++j) cloud.emplace_back(i + 0.5, j + 0.5, z(rng));
  TopviewOptions options;
  options.shade = TopviewShade::Height;
  const TopviewResult r = write_topview(cloud, {TopviewTrack{"loop", loop_trajectory(PoseFormat::Kitti)}}, options,
                                        dir.file("big.svg"));
  EXPECT_LE(r.cells, 60000u);
  EXPECT_GT(r.cell, 1.0);
  EXPECT_LT(r.bytes, 3u * 1024u * 1024u) << r.bytes;
  EXPECT_GT(r.bytes, 100u * 1024u);  // the raster is really there
}

TEST(EvalTopviewCli, WritesAnSvgWithTrajectoriesLegendAndCells) {
  TempDir dir;
  const Points3d cloud = block_cloud();
  write_pcd(dir.file("map.pcd"), cloud, std::vector<float>(cloud.size(), 0.3f));
  write_kitti_poses(dir.file("gt.txt"), loop_trajectory(PoseFormat::Kitti));
  Trajectory est = loop_trajectory(PoseFormat::Tum);
  for (auto& p : est.poses) p.translation() += Eigen::Vector3d(0.8, -0.5, 0.0);
  write_tum_poses(dir.file("est.tum"), est);
  const std::string exe = test::pl_eval_exe();

  const RunResult r = run({exe, "topview", "--cloud", dir.file("map.pcd"), "--traj", dir.file("gt.txt") + ":ground truth",
                           "--traj", dir.file("est.tum"), "--out", dir.file("top.svg")},
                          dir);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("in 1200 cells of 1.00 m"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("2 trajectories"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("wrote " + dir.file("top.svg")), std::string::npos) << r.out;
  const std::string svg = read_text(dir.file("top.svg"));
  EXPECT_TRUE(test::starts_with(svg, "<svg")) << svg.substr(0, 100);
  EXPECT_NE(svg.find("</svg>"), std::string::npos);
  EXPECT_EQ(count_of(svg, "<polyline"), 2u);  // one per trajectory
  EXPECT_NE(svg.find(">ground truth</text>"), std::string::npos);
  EXPECT_NE(svg.find(">est</text>"), std::string::npos);  // the file name as the default label
  EXPECT_NE(svg.find(">start</text>"), std::string::npos);
  EXPECT_EQ(count_of(svg, "<circle"), 2u + 1u);  // two starts, one legend marker
  EXPECT_NE(svg.find("m cells"), std::string::npos);  // the cells' legend entry
  EXPECT_GE(count_of(svg, "<path fill="), 1u);
  // Equal aspect: 40 m x 30 m of data in a picture wider than high.
  std::smatch m;
  ASSERT_TRUE(std::regex_search(svg, m, std::regex("width=\"(\\d+)\" height=\"(\\d+)\"")));
  EXPECT_GT(std::stoi(m[1]), std::stoi(m[2]));
  if (!kPython.empty() && kPython.find("NOTFOUND") == std::string::npos) {
    const RunResult xml =
        run({kPython, "-c", "import sys, xml.etree.ElementTree as E; E.parse(sys.argv[1]); print('parsed')",
             dir.file("top.svg")},
            dir);
    EXPECT_EQ(xml.exit_code, 0) << xml.err;
    EXPECT_NE(xml.out.find("parsed"), std::string::npos) << xml.err;
  }

  // Smaller cells: more of them (and a larger file); --shade height works too.
  const RunResult fine = run({exe, "topview", "--cloud", dir.file("map.pcd"), "--out", dir.file("fine.svg"), "--cell",
                              "0.5", "--shade", "height", "--traj", dir.file("gt.txt")},
                             dir);
  ASSERT_EQ(fine.exit_code, 0) << fine.err;
  EXPECT_NE(fine.out.find("in 4800 cells of 0.50 m"), std::string::npos) << fine.out;
  EXPECT_NE(read_text(dir.file("fine.svg")).find("darker = higher"), std::string::npos);
  const RunResult coarse =
      run({exe, "topview", "--cloud", dir.file("map.pcd"), "--out", dir.file("coarse.svg"), "--cell", "2"}, dir);
  ASSERT_EQ(coarse.exit_code, 0) << coarse.err;
  EXPECT_NE(coarse.out.find("in 300 cells of 2.00 m"), std::string::npos) << coarse.out;
  EXPECT_NE(coarse.out.find("0 trajectories"), std::string::npos) << coarse.out;
}

TEST(EvalTopviewCli, BadInputNamesTheProblem) {
  TempDir dir;
  const Points3d cloud = block_cloud();
  write_pcd(dir.file("map.pcd"), cloud, std::vector<float>(cloud.size(), 0.3f));
  test::write_text(dir.file("bad.txt"), "1 0 0 0 0 1 0 0 0 0 1\n");
  const std::string exe = test::pl_eval_exe();
  const std::vector<UsageCase> cases = {
      {{exe, "topview", "--cloud", dir.file("map.pcd")}, "--out is required"},
      {{exe, "topview", "--out", dir.file("t.svg")}, "--cloud is required"},
      {{exe, "topview", "--cloud", dir.file("map.pcd"), "--out", dir.file("t.svg"), "--cell", "0"}, "--cell takes"},
      {{exe, "topview", "--cloud", dir.file("map.pcd"), "--out", dir.file("t.svg"), "--shade", "z"}, "--shade takes count or height"},
      {{exe, "topview", "--cloud", dir.file("map.pcd"), "--out", dir.file("t.svg"), "--traj", dir.file("bad.txt")},
       dir.file("bad.txt") + ":1"},
      {{exe, "topview", "--cloud", dir.file("map.pcd"), "--out", dir.file("t.svg"), "--traj", dir.file("gt.txt") + ":"},
       "empty label"},
      {{exe, "topview", "--cloud", dir.file("map.pcd"), "--out", dir.file("no/such/dir/t.svg")}, "cannot write"},
      {{exe, "topview", "--cloud", dir.file("missing.pcd"), "--out", dir.file("t.svg")}, "missing.pcd"},
  };
  expect_usage_errors(cases, dir);
}

}  // namespace
}  // namespace pl::eval
