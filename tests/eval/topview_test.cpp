// The map top view: cell sizing, the SVG and the PNG it writes (decoded back with libpng), and the
// built pl-eval topview.
#include "pl/eval/topview.hpp"

#include <gtest/gtest.h>
#include <png.h>

#include <cmath>
#include <filesystem>
#include <random>
#include <set>
#include <array>
#include <regex>

#include "error_of.hpp"
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

// A PNG decoded to 8-bit RGB by libpng's own reader.
struct Decoded {
  int width = 0, height = 0;
  std::vector<std::uint8_t> rgb;
  std::array<int, 3> at(int x, int y) const {
    const std::size_t i = 3 * (static_cast<std::size_t>(y) * static_cast<std::size_t>(width) + static_cast<std::size_t>(x));
    return {rgb[i], rgb[i + 1], rgb[i + 2]};
  }
};

Decoded decode_png(const std::string& path) {
  png_image image{};
  image.version = PNG_IMAGE_VERSION;
  Decoded d;
  if (!png_image_begin_read_from_file(&image, path.c_str())) {
    ADD_FAILURE() << path << ": " << image.message;
    return d;
  }
  image.format = PNG_FORMAT_RGB;
  d.rgb.resize(PNG_IMAGE_SIZE(image));
  if (!png_image_finish_read(&image, nullptr, d.rgb.data(), 0, nullptr)) {
    ADD_FAILURE() << path << ": " << image.message;
    return d;
  }
  d.width = static_cast<int>(image.width);
  d.height = static_cast<int>(image.height);
  return d;
}

// The pixel that shows the point (x, y) of the map in a top view written as `r`.
std::pair<int, int> pixel_of(const TopviewResult& r, double x, double y) {
  const double sx = r.width / (r.extent.x_max - r.extent.x_min), sy = r.height / (r.extent.y_max - r.extent.y_min);
  return {static_cast<int>(std::floor((x - r.extent.x_min) * sx)), static_cast<int>(std::floor((r.extent.y_max - y) * sy))};
}

std::array<int, 3> colour_at(const Decoded& d, const TopviewResult& r, double x, double y) {
  const auto [px, py] = pixel_of(r, x, y);
  EXPECT_TRUE(px >= 0 && py >= 0 && px < d.width && py < d.height) << x << ", " << y;
  if (!(px >= 0 && py >= 0 && px < d.width && py < d.height)) return {-1, -1, -1};
  return d.at(px, py);
}

bool is_grey(const std::array<int, 3>& c) { return c[0] == c[1] && c[1] == c[2] && c[0] < 240; }

const std::array<int, 3> kWhite{255, 255, 255}, kBlack{0, 0, 0}, kRed{0xd6, 0x27, 0x28}, kBlue{0x1f, 0x77, 0xb4};

// The block with a 4 m x 4 m hole in its floor at x 24..28, y 2..6, away from the loop.
Points3d holed_block() {
  Points3d cloud;
  for (const auto& p : block_cloud())
    if (!(p.x() >= 24.0 && p.x() < 28.0 && p.y() >= 2.0 && p.y() < 6.0)) cloud.push_back(p);
  return cloud;
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

TEST(EvalTopviewPng, CellsShadedHolesBlankTrajectoryColoured) {
  TempDir dir;
  // The holed block with one point alone in the cell x 2..3, y 20..21.
  Points3d cloud;
  for (const auto& p : holed_block())
    if (!(p.x() >= 2.0 && p.x() < 3.0 && p.y() >= 20.0 && p.y() < 21.0)) cloud.push_back(p);
  cloud.emplace_back(2.5, 20.5, 0.0);
  TopviewOptions options;  // 1 m cells
  const TopviewResult r = write_topview(cloud, {TopviewTrack{"loop", loop_trajectory(PoseFormat::Kitti)}}, options,
                                        dir.file("top.png"));
  EXPECT_TRUE(r.png);
  // 40 x 30 cells and 2 of margin each side, 8 px a cell (the most; 44 cells would allow 36).
  EXPECT_EQ(r.pixels_per_cell, 8);
  EXPECT_EQ(r.width, 44 * 8);
  EXPECT_EQ(r.height, 34 * 8);
  EXPECT_DOUBLE_EQ(r.extent.x_min, -2.0);
  EXPECT_DOUBLE_EQ(r.extent.y_max, 32.0);
  EXPECT_EQ(r.cells, 40u * 30u - 16u);
  EXPECT_EQ(r.points, cloud.size());
  EXPECT_EQ(r.bytes, std::filesystem::file_size(dir.file("top.png")));

  const Decoded d = decode_png(dir.file("top.png"));
  ASSERT_EQ(d.width, r.width);
  ASSERT_EQ(d.height, r.height);
  // Occupied cells are grey, a cell of one point lighter than the floor's of 16; the hole and the
  // margin are white.
  const auto floor = colour_at(d, r, 10.5, 5.5), wall = colour_at(d, r, 10.5, 10.5), lone = colour_at(d, r, 2.5, 20.5);
  EXPECT_TRUE(is_grey(floor)) << floor[0];
  EXPECT_TRUE(is_grey(wall)) << wall[0];
  EXPECT_TRUE(is_grey(lone)) << lone[0];
  EXPECT_LT(floor[0], lone[0]);
  EXPECT_EQ(colour_at(d, r, 26.0, 4.0), kWhite);
  EXPECT_EQ(colour_at(d, r, 24.2, 2.2), kWhite);
  EXPECT_EQ(colour_at(d, r, -1.0, -1.0), kWhite);
  EXPECT_TRUE(is_grey(colour_at(d, r, 23.8, 4.0)));  // the cell beside the hole
  // The trajectory in its colour (the first: red), its start a black dot.
  EXPECT_EQ(colour_at(d, r, 20.0, 24.0), kRed);  // the loop's northmost pose
  EXPECT_EQ(colour_at(d, r, 8.0, 15.0), kRed);   // its westmost
  EXPECT_EQ(colour_at(d, r, 32.0, 15.0), kBlack);
  // Every colour in the image is white, one of the 16 greys, the track's or the start's.
  std::set<std::array<int, 3>> colours;
  for (int y = 0; y < d.height; ++y)
    for (int x = 0; x < d.width; ++x) colours.insert(d.at(x, y));
  EXPECT_LE(colours.size(), 1u + 16u + 2u);
  EXPECT_TRUE(colours.count(kRed) && colours.count(kBlack) && colours.count(kWhite));
  // The legend in the Description chunk (tEXt: keyword, NUL, text).
  const std::string bytes = read_text(dir.file("top.png"));
  EXPECT_TRUE(test::starts_with(bytes, "\x89PNG\r\n\x1a\n"));
  EXPECT_NE(bytes.find(std::string("Description\0", 12) + r.legend), std::string::npos) << r.legend;
  EXPECT_NE(r.legend.find("8 px a cell of 1.00 m"), std::string::npos) << r.legend;
  EXPECT_NE(r.legend.find("red loop"), std::string::npos) << r.legend;
}

TEST(EvalTopviewPng, RemovedPointsInRedOverTheMap) {
  TempDir dir;
  const Points3d before = block_cloud(), after = holed_block();
  const Points3d removed = points_missing_from(before, after);
  EXPECT_EQ(removed.size(), 16u * 16u);  // the hole: 4 m x 4 m of floor points 0.25 m apart
  for (const auto& p : removed) EXPECT_TRUE(p.x() >= 24.0 && p.x() < 28.0 && p.y() >= 2.0 && p.y() < 6.0);
  EXPECT_TRUE(points_missing_from(after, before).empty());
  EXPECT_EQ(points_missing_from(before, {}).size(), before.size());

  TopviewOptions options;
  options.title = "block \u2212 hole";  // not ASCII: an iTXt chunk
  const TopviewResult r = write_topview(after, {TopviewTrack{"loop", loop_trajectory(PoseFormat::Kitti)}}, options,
                                        dir.file("removed.png"), removed);
  const std::string bytes = read_text(dir.file("removed.png"));
  EXPECT_NE(bytes.find("iTXtTitle"), std::string::npos);
  EXPECT_NE(bytes.find(options.title), std::string::npos);
  EXPECT_EQ(r.highlight_points, removed.size());
  EXPECT_EQ(r.highlight_cells, 16u);
  const Decoded d = decode_png(dir.file("removed.png"));
  ASSERT_EQ(d.width, r.width);
  EXPECT_EQ(colour_at(d, r, 26.0, 4.0), kRed);
  EXPECT_EQ(colour_at(d, r, 24.2, 5.8), kRed);
  EXPECT_TRUE(is_grey(colour_at(d, r, 23.8, 4.0)));
  // Red is the removed points' now: the trajectory takes the next colour.
  EXPECT_EQ(colour_at(d, r, 20.0, 24.0), kBlue);
  EXPECT_NE(r.legend.find("Red: 256 highlighted points in 16 cells"), std::string::npos) << r.legend;
  EXPECT_NE(r.legend.find("blue loop"), std::string::npos) << r.legend;
}

TEST(EvalTopviewPng, BoundsCropAndLargeMapsFit) {
  TempDir dir;
  const Points3d cloud = holed_block();
  TopviewOptions options;
  options.cell = 0.5;
  options.bounds = TopviewBounds{10.0, 10.0, 20.0, 15.0};
  const TopviewResult r = write_topview(cloud, {TopviewTrack{"loop", loop_trajectory(PoseFormat::Kitti)}}, options,
                                        dir.file("crop.png"));
  EXPECT_DOUBLE_EQ(r.extent.x_min, 10.0);
  EXPECT_DOUBLE_EQ(r.extent.y_min, 10.0);
  EXPECT_DOUBLE_EQ(r.extent.x_max, 20.0);
  EXPECT_DOUBLE_EQ(r.extent.y_max, 15.0);
  EXPECT_EQ(r.pixels_per_cell, 8);
  EXPECT_EQ(r.width, 20 * 8);
  EXPECT_EQ(r.height, 10 * 8);
  EXPECT_EQ(r.cells, 20u * 10u);
  EXPECT_EQ(r.points, 40u * 20u + 100u * 30u);  // the floor inside and the wall from x 10 to 15
  const Decoded d = decode_png(dir.file("crop.png"));
  EXPECT_EQ(d.width, 160);
  EXPECT_EQ(d.height, 80);
  EXPECT_TRUE(is_grey(colour_at(d, r, 12.0, 12.0)));

  // 500 m x 600 m at 0.1 m cells: the cell grows until the image is within 1600 px.
  Points3d big;
  for (int i = 0; i < 500; i += 2)
    for (int j = 0; j < 600; j += 2) big.emplace_back(i + 0.5, j + 0.5, 0.0);
  TopviewOptions fine;
  fine.cell = 0.1;
  const TopviewResult b = write_topview(big, {}, fine, dir.file("big.png"));
  EXPECT_GT(b.cell, 0.1);
  EXPECT_LE(std::max(b.width, b.height), kTopviewMaxPixels);
  EXPECT_GT(std::max(b.width, b.height), kTopviewMaxPixels * 9 / 10);  // grown by about the needed factor
  EXPECT_EQ(b.pixels_per_cell, 1);
  const Decoded bd = decode_png(dir.file("big.png"));
  EXPECT_EQ(bd.width, b.width);
  EXPECT_EQ(bd.height, b.height);
}

TEST(EvalTopviewPng, BadBoundsAndPathsAreClearErrors) {
  TempDir dir;
  const Points3d cloud = block_cloud();
  using pl::test::error_of;
  const auto bounds_error = [](const std::string& text) { return error_of([&] { parse_bounds(text); }); };
  const TopviewBounds b = parse_bounds("-10.5,2,30,4e1");
  EXPECT_DOUBLE_EQ(b.x_min, -10.5);
  EXPECT_DOUBLE_EQ(b.y_min, 2.0);
  EXPECT_DOUBLE_EQ(b.x_max, 30.0);
  EXPECT_DOUBLE_EQ(b.y_max, 40.0);
  for (const std::string bad : {"", "1,2,3", "1,2,3,4,5", "1,2,3,4,"})
    EXPECT_NE(bounds_error(bad).find("expected four numbers XMIN,YMIN,XMAX,YMAX"), std::string::npos) << bad;
  EXPECT_NE(bounds_error("a,0,1,1").find("XMIN \"a\" is not a finite number"), std::string::npos);
  EXPECT_NE(bounds_error("0,,1,1").find("YMIN \"\" is not a finite number"), std::string::npos);
  EXPECT_NE(bounds_error("0,0,nan,1").find("XMAX \"nan\" is not a finite number"), std::string::npos);
  EXPECT_NE(bounds_error("0,0,1,1e999").find("YMAX \"1e999\" is not a finite number"), std::string::npos);
  EXPECT_NE(bounds_error("0,0,1m,1").find("XMAX \"1m\""), std::string::npos);
  EXPECT_NE(bounds_error("2,0,1,1").find("XMIN must be below XMAX"), std::string::npos);
  EXPECT_NE(bounds_error("0,5,1,5").find("YMIN must be below YMAX"), std::string::npos);

  const TopviewOptions options;
  const std::string no_dir = dir.file("no/such/dir/t.png");
  EXPECT_NE(error_of([&] { write_topview(cloud, {}, options, no_dir); }).find(no_dir + ": cannot write"), std::string::npos);
  EXPECT_FALSE(std::filesystem::exists(no_dir));
  EXPECT_NE(error_of([&] { write_topview(cloud, {}, options, dir.file("t.jpg")); }).find("name it FILE.svg or FILE.png"),
            std::string::npos);
  TopviewOptions cropped;
  cropped.bounds = TopviewBounds{0, 0, 1, 1};
  EXPECT_NE(error_of([&] { write_topview(cloud, {}, cropped, dir.file("t.svg")); }).find("in a PNG only"), std::string::npos);
  EXPECT_NE(error_of([&] { write_topview(cloud, {}, options, dir.file("t.svg"), cloud); }).find("in a PNG only"),
            std::string::npos);
  EXPECT_FALSE(std::filesystem::exists(dir.file("t.jpg")) || std::filesystem::exists(dir.file("t.svg")));
  // A stray point far out of any sane map.
  Points3d stray = cloud;
  stray.emplace_back(1e300, 0.0, 0.0);
  EXPECT_NE(error_of([&] { write_topview(stray, {}, options, dir.file("stray.png")); }).find("span more than"), std::string::npos);
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

TEST(EvalTopviewCli, WritesAPngWithRemovedPointsAndBounds) {
  TempDir dir;
  const Points3d kept = block_cloud(), cleaned = holed_block();
  write_pcd(dir.file("kept.pcd"), kept, std::vector<float>(kept.size(), 0.3f));
  write_pcd(dir.file("cleaned.pcd"), cleaned, std::vector<float>(cleaned.size(), 0.3f));
  write_kitti_poses(dir.file("gt.txt"), loop_trajectory(PoseFormat::Kitti));
  const std::string exe = test::pl_eval_exe();

  const RunResult r = run({exe, "topview", "--cloud", dir.file("cleaned.pcd"), "--removed-from", dir.file("kept.pcd"), "--traj",
                           dir.file("gt.txt") + ":ground truth", "--out", dir.file("top.png")},
                          dir);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("in 1184 cells of 1.00 m"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("256 points of " + dir.file("kept.pcd") + " are not in " + dir.file("cleaned.pcd")), std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("image: 352 x 272 px, 8 px a cell"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("blue ground truth"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("wrote " + dir.file("top.png")), std::string::npos) << r.out;
  const Decoded d = decode_png(dir.file("top.png"));
  EXPECT_EQ(d.width, 352);
  EXPECT_EQ(d.height, 272);
  const std::string bytes = read_text(dir.file("top.png"));
  EXPECT_NE(bytes.find(std::string("Title\0Top view of cleaned.pcd", 29)), std::string::npos);

  // --highlight draws a given cloud; --bounds crops.
  const RunResult crop = run({exe, "topview", "--cloud", dir.file("cleaned.pcd"), "--highlight", dir.file("kept.pcd"), "--bounds",
                              "20,0,30,10", "--cell", "0.5", "--out", dir.file("crop.png")},
                             dir);
  ASSERT_EQ(crop.exit_code, 0) << crop.err;
  EXPECT_NE(crop.out.find("image: 160 x 160 px"), std::string::npos) << crop.out;
  const Decoded c = decode_png(dir.file("crop.png"));
  EXPECT_EQ(c.width, 160);
  EXPECT_EQ(c.at(80, 80), kRed);  // all of kept.pcd is highlighted

  const std::vector<UsageCase> cases = {
      {{exe, "topview", "--cloud", dir.file("kept.pcd"), "--out", dir.file("t.png"), "--bounds", "1,2,3"},
       "--bounds \"1,2,3\": expected four numbers XMIN,YMIN,XMAX,YMAX"},
      {{exe, "topview", "--cloud", dir.file("kept.pcd"), "--out", dir.file("t.png"), "--bounds", "3,0,1,1"},
       "XMIN must be below XMAX"},
      {{exe, "topview", "--cloud", dir.file("kept.pcd"), "--out", dir.file("t.svg"), "--bounds", "0,0,1,1"}, "in a PNG only"},
      {{exe, "topview", "--cloud", dir.file("kept.pcd"), "--out", dir.file("t.svg"), "--highlight", dir.file("kept.pcd")},
       "in a PNG only"},
      {{exe, "topview", "--cloud", dir.file("kept.pcd"), "--out", dir.file("t.png"), "--highlight", dir.file("kept.pcd"),
        "--removed-from", dir.file("kept.pcd")},
       "excludes"},
      {{exe, "topview", "--cloud", dir.file("kept.pcd"), "--out", dir.file("t.gif")}, "name it FILE.svg or FILE.png"},
      {{exe, "topview", "--cloud", dir.file("kept.pcd"), "--out", dir.file("no/such/dir/t.png")}, "cannot write"},
      {{exe, "topview", "--cloud", dir.file("kept.pcd"), "--out", dir.file("t.png"), "--highlight", dir.file("missing.pcd")},
       "missing.pcd"},
  };
  expect_usage_errors(cases, dir);
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
