// End-to-end tests of the built pl-eval executable, checked against an independent Python 3
// computation (tests/eval/independent_ape.py, stdlib only).
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <random>

#include "eval_test_util.hpp"
#include "pl/common/pose.hpp"

namespace pl::eval {
namespace {

using test::expect_usage_errors;
using test::run;
using test::UsageCase;
using test::RunResult;
using test::TempDir;

const std::string kPython = PL_PYTHON3;
const std::string kScript = std::string(PL_EVAL_TEST_DIR) + "/independent_ape.py";

// A ~500-pose curvy ground truth and a noisy estimate (fixed seed): translation noise sigma 0.25 m
// plus a slow drift, small rotation noise; with `scale`, the estimate's positions are also scaled
// about the origin, rotated and moved (as a monocular or badly calibrated odometry would be).
void write_pair(const TempDir& dir, std::size_t est_poses = 500, double scale = 1.0) {
  const Trajectory gt = test::curvy_path(500, 1.7);
  Trajectory est = gt;
  if (scale != 1.0) {
    const Pose motion = make_pose(25.0, -40.0, 2.0, 0.01, -0.02, 0.7);
    for (auto& p : est.poses) {
      p.translation() *= scale;
      p = motion * p;
    }
  }
  std::mt19937 rng(20240611);
  std::normal_distribution<double> noise(0.0, 0.25), angle(0.0, 0.01);
  for (std::size_t i = 0; i < est.size(); ++i) {
    const double s = static_cast<double>(i);
    est.poses[i] = est.poses[i] * make_pose(0, 0, 0, angle(rng), angle(rng), angle(rng));
    est.poses[i].translation() += Eigen::Vector3d(noise(rng) + 0.002 * s, noise(rng), 0.3 * noise(rng));
  }
  est.poses.resize(est_poses);
  write_kitti_poses(dir.file("gt.txt"), gt);
  write_kitti_poses(dir.file("est.txt"), est);
}

nlohmann::json parse_json(const RunResult& r, const std::string& what) {
  EXPECT_EQ(r.exit_code, 0) << what << "\nstdout:\n" << r.out << "\nstderr:\n" << r.err;
  try {
    return nlohmann::json::parse(r.out);
  } catch (const std::exception& e) {
    ADD_FAILURE() << what << ": output is not JSON (" << e.what() << "):\n" << r.out;
    return nlohmann::json::object();
  }
}

void compare_with_python(const TempDir& dir, const std::string& align) {
  ASSERT_FALSE(kPython.empty() || kPython.find("NOTFOUND") != std::string::npos)
      << "python3 was not found when the build was configured; it is needed for this test";
  const nlohmann::json ours = parse_json(
      run({test::pl_eval_exe(), "ape", "--est", dir.file("est.txt"), "--gt", dir.file("gt.txt"), "--align", align,
           "--json"},
          dir),
      "pl-eval ape");
  const nlohmann::json theirs =
      parse_json(run({kPython, kScript, dir.file("est.txt"), dir.file("gt.txt"), "--align", align}, dir),
                 "independent_ape.py");
  ASSERT_TRUE(ours.is_object() && theirs.is_object());
  EXPECT_EQ(ours.at("alignment"), align);
  EXPECT_EQ(theirs.at("alignment"), align);
  EXPECT_EQ(ours.at("matched"), theirs.at("matched"));
  EXPECT_EQ(ours.at("gt_poses"), theirs.at("gt_poses"));
  EXPECT_NEAR(ours.at("coverage").get<double>(), theirs.at("coverage").get<double>(), 1e-12);
  for (const char* key : {"mean", "median", "rmse", "std", "max"}) {
    EXPECT_NEAR(ours.at(key).get<double>(), theirs.at(key).get<double>(), 1e-6) << key << " (align " << align << ")";
    EXPECT_GT(ours.at(key).get<double>(), 0.01) << key;  // a real, non-trivial error
  }
  for (const char* key : {"lateral", "longitudinal", "vertical"}) {
    EXPECT_TRUE(ours.at(key).contains("mean_abs")) << key;
    EXPECT_TRUE(ours.at(key).contains("rmse")) << key;
  }
  EXPECT_EQ(ours.contains("scale"), align == "sim3");
  if (align == "sim3") {
    EXPECT_NEAR(ours.at("scale").get<double>(), theirs.at("scale").get<double>(), 1e-9);
  }
}

TEST(EvalCli, ApeJsonMatchesIndependentPython) {
  TempDir dir;
  write_pair(dir);
  compare_with_python(dir, "none");
}

TEST(EvalCli, ApeSe3JsonMatchesIndependentPythonHorn) {
  TempDir dir;
  write_pair(dir);
  compare_with_python(dir, "se3");
}

TEST(EvalCli, ApeSim3JsonMatchesIndependentPythonHornWithScale) {
  TempDir dir;
  write_pair(dir, 500, 1.03);
  compare_with_python(dir, "sim3");
  const auto sim3 = parse_json(run({test::pl_eval_exe(), "ape", "--est", dir.file("est.txt"), "--gt",
                                    dir.file("gt.txt"), "--align", "sim3", "--json"},
                                   dir),
                               "ape sim3");
  const auto se3 = parse_json(run({test::pl_eval_exe(), "ape", "--est", dir.file("est.txt"), "--gt", dir.file("gt.txt"),
                                   "--align", "se3", "--json"},
                                  dir),
                              "ape se3");
  // The noise is sigma 0.25 m plus drift; the 3 % scale over a ~850 m path adds metres unless removed.
  EXPECT_NEAR(sim3.at("scale").get<double>(), 1.0 / 1.03, 0.003);
  EXPECT_LT(sim3.at("rmse").get<double>(), 0.6);
  EXPECT_GT(se3.at("rmse").get<double>(), 3.0 * sim3.at("rmse").get<double>());
  // The transform is the one applied: its rotation part has the scale as its determinant's cube root.
  Eigen::Matrix3d m;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) m(r, c) = sim3.at("alignment_transform")[r][c].get<double>();
  EXPECT_NEAR(std::cbrt(m.determinant()), sim3.at("scale").get<double>(), 1e-9);

  const RunResult text = run({test::pl_eval_exe(), "ape", "--est", dir.file("est.txt"), "--gt", dir.file("gt.txt"),
                              "--align", "sim3"},
                             dir);
  EXPECT_EQ(text.exit_code, 0) << text.err;
  EXPECT_NE(text.out.find("alignment     sim3"), std::string::npos) << text.out;
  EXPECT_NE(text.out.find("scale         0.97"), std::string::npos) << text.out;
}

TEST(EvalCli, ApeShorterEstimateMatchesIndependentPython) {
  TempDir dir;
  write_pair(dir, 400);
  compare_with_python(dir, "none");
  const auto j = nlohmann::json::parse(
      run({test::pl_eval_exe(), "ape", "--est", dir.file("est.txt"), "--gt", dir.file("gt.txt"), "--json"}, dir).out);
  EXPECT_DOUBLE_EQ(j.at("coverage").get<double>(), 0.8);
}

TEST(EvalCli, ApeOnTumFilesPairsByTimestamp) {
  TempDir dir;
  Trajectory gt, est;
  gt.format = est.format = PoseFormat::Tum;
  for (int i = 0; i < 300; ++i) {
    const Pose p = make_pose(0.8 * i, 5.0 * std::sin(0.02 * i), 0.0, 0.0, 0.0, 0.1);
    gt.poses.push_back(p);
    gt.times.push_back(1700000000.0 + 0.1 * i);
    if (i % 3 == 2) continue;  // the estimate misses every third scan
    Pose q = p;
    q.translation() += Eigen::Vector3d(0.3, -0.4, 0.0);
    est.poses.push_back(q);
    est.times.push_back(1700000000.0 + 0.1 * i + 0.004);  // 4 ms late
  }
  write_tum_poses(dir.file("gt.tum"), gt);
  write_tum_poses(dir.file("est.tum"), est);
  const auto j = parse_json(
      run({test::pl_eval_exe(), "ape", "--est", dir.file("est.tum"), "--gt", dir.file("gt.tum"), "--json"}, dir),
      "ape on TUM");
  EXPECT_EQ(j.at("matched"), 200);
  EXPECT_EQ(j.at("gt_poses"), 300);
  EXPECT_NEAR(j.at("coverage").get<double>(), 2.0 / 3.0, 1e-12);
  for (const char* key : {"mean", "median", "rmse", "max"}) EXPECT_NEAR(j.at(key).get<double>(), 0.5, 1e-9) << key;
  EXPECT_NEAR(j.at("std").get<double>(), 0.0, 1e-9);
}

TEST(EvalCli, ApeTextSaysTheAlignmentAndPlotsWritesFiles) {
  TempDir dir;
  write_pair(dir);
  const std::string plots = dir.file("figs");
  const RunResult r = run({test::pl_eval_exe(), "ape", "--est", dir.file("est.txt"), "--gt", dir.file("gt.txt"),
                           "--align=se3", "--plot", plots},
                          dir);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("alignment     se3"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("coverage 100.0 %"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("rmse"), std::string::npos) << r.out;
  for (const char* f : {"trajectory.svg", "error_over_distance.svg", "error_histogram.svg"}) {
    const std::string path = plots + "/" + f;
    EXPECT_TRUE(std::filesystem::is_regular_file(path)) << path;
    EXPECT_NE(r.out.find("wrote " + path), std::string::npos) << r.out;
  }

  const RunResult plain = run({test::pl_eval_exe(), "ape", "--est", dir.file("est.txt"), "--gt", dir.file("gt.txt")}, dir);
  EXPECT_NE(plain.out.find("alignment     none"), std::string::npos) << plain.out;
}

TEST(EvalCli, ApeJsonListsPlotsWithoutBreakingTheJson) {
  TempDir dir;
  write_pair(dir);
  const auto j = parse_json(run({test::pl_eval_exe(), "ape", "--est", dir.file("est.txt"), "--gt", dir.file("gt.txt"),
                                 "--json", "--plot", dir.file("p")},
                                dir),
                            "ape --json --plot");
  ASSERT_TRUE(j.contains("plots"));
  EXPECT_EQ(j.at("plots").size(), 3u);
}

TEST(EvalCli, MalformedLineNamesFileAndLine) {
  TempDir dir;
  write_pair(dir);
  // Line 7 loses its last number.
  std::string text = test::read_text(dir.file("est.txt"));
  std::size_t pos = 0;
  for (int k = 0; k < 6; ++k) pos = text.find('\n', pos) + 1;
  const std::size_t eol = text.find('\n', pos);
  const std::size_t last_space = text.rfind(' ', eol);
  text.erase(last_space, eol - last_space);
  test::write_text(dir.file("est.txt"), text);

  const RunResult r = run({test::pl_eval_exe(), "ape", "--est", dir.file("est.txt"), "--gt", dir.file("gt.txt")}, dir);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find(dir.file("est.txt") + ":7"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("12 numbers"), std::string::npos) << r.err;
  EXPECT_TRUE(r.out.empty()) << r.out;
}

TEST(EvalCli, BadInputsExitWithTwo) {
  TempDir dir;
  write_pair(dir);
  const std::string exe = test::pl_eval_exe();
  test::write_text(dir.file("est.tum"), "0.0 1 2 3 0 0 0 1\n0.1 1 2 3 0 0 0 1\n");

  const std::vector<UsageCase> cases = {
      {{exe, "ape", "--est", dir.file("est.txt"), "--gt", dir.file("gt.txt"), "--bogus", "1"},
       "--bogus"},
      {{exe, "ape", "--est", dir.file("est.txt"), "--gt"}, "--gt: 1 required FILE missing"},
      {{exe, "ape", "--est", dir.file("est.tum"), "--gt", dir.file("gt.txt")}, "convert"},
      {{exe, "ape", "--est", dir.file("gt.txt"), "--gt", dir.file("est.txt"), "--align", "affine"},
       "--align takes none, se3 or sim3"},
      {{exe, "ape", "--gt", dir.file("gt.txt")}, "--est is required"},
      {{exe, "ape", "--est", dir.file("nope.txt"), "--gt", dir.file("gt.txt")}, "nope.txt: cannot open"},
      {{exe, "kitti", "--est", dir.file("est.txt"), "--gt", dir.file("gt.txt"), "extra"}, "not expected: extra"},
      {{exe, "timing", "--csv", dir.file("gt.txt")}, "_ms"},
      {{exe, "frobnicate"}, "unknown command"},
      {{exe}, "missing command"},
  };
  expect_usage_errors(cases, dir);
}

TEST(EvalCli, HelpPrintsUsage) {
  TempDir dir;
  for (const std::vector<std::string>& args :
       {std::vector<std::string>{"--help"}, {"ape", "--help"}, {"kitti", "--help"}, {"timing", "--help"}}) {
    std::vector<std::string> argv = {test::pl_eval_exe()};
    argv.insert(argv.end(), args.begin(), args.end());
    const RunResult r = run(argv, dir);
    EXPECT_EQ(r.exit_code, 0) << args.front();
    if (args.size() == 1) {  // the commands, each with what it does
      EXPECT_NE(r.out.find("Usage: pl-eval [OPTIONS] SUBCOMMAND"), std::string::npos) << r.out;
      for (const char* command : {"ape", "kitti", "timing", "map", "topview"})
        EXPECT_NE(r.out.find(std::string("\n  ") + command + " "), std::string::npos) << command << "\n" << r.out;
    } else {  // the command's options
      EXPECT_NE(r.out.find("Usage: pl-eval " + args.front() + " [OPTIONS]"), std::string::npos) << r.out;
      EXPECT_NE(r.out.find(args.front() == "timing" ? "--csv FILE REQUIRED" : "--est FILE REQUIRED"), std::string::npos) << r.out;
    }
  }
}

TEST(EvalCli, KittiOnAScaledCopy) {
  TempDir dir;
  // A straight 1 km drive along (3, 4, 0), 5 m a frame (exact in binary, so every segment ends
  // exactly at its length); the estimate is scaled by 1.01.
  Trajectory gt, est;
  const double yaw = std::atan2(4.0, 3.0);
  for (int i = 0; i <= 200; ++i) {
    gt.poses.push_back(make_pose(3.0 * i, 4.0 * i, 0.0, 0.0, 0.0, yaw));
    est.poses.push_back(make_pose(1.01 * 3.0 * i, 1.01 * 4.0 * i, 0.0, 0.0, 0.0, yaw));
  }
  write_kitti_poses(dir.file("gt.txt"), gt);
  write_kitti_poses(dir.file("est.txt"), est);
  const auto j = parse_json(run({test::pl_eval_exe(), "kitti", "--est", dir.file("est.txt"), "--gt", dir.file("gt.txt"),
                                 "--json", "--plot", dir.file("k")},
                                dir),
                            "kitti --json");
  EXPECT_NEAR(j.at("translation_pct").get<double>(), 1.0, 1e-6);
  EXPECT_NEAR(j.at("rotation_deg_per_100m").get<double>(), 0.0, 1e-6);
  EXPECT_EQ(j.at("by_length").size(), 8u);
  EXPECT_FALSE(j.at("by_speed").empty());
  EXPECT_TRUE(std::filesystem::is_regular_file(dir.file("k/kitti_errors.svg")));

  const RunResult text = run({test::pl_eval_exe(), "kitti", "--est", dir.file("est.txt"), "--gt", dir.file("gt.txt")}, dir);
  EXPECT_EQ(text.exit_code, 0);
  EXPECT_NE(text.out.find("by length"), std::string::npos) << text.out;
  EXPECT_NE(text.out.find("by speed"), std::string::npos) << text.out;
}

TEST(EvalCli, TimingCsv) {
  TempDir dir;
  std::string csv = "scan,load_ms,registration_ms\n";
  for (int i = 1; i <= 200; ++i) csv += std::to_string(i) + ",0.5," + std::to_string(i % 100 + 1) + "\n";
  test::write_text(dir.file("t.csv"), csv);
  const auto j = parse_json(
      run({test::pl_eval_exe(), "timing", "--csv", dir.file("t.csv"), "--json", "--plot", dir.file("tp")}, dir),
      "timing --json");
  EXPECT_EQ(j.at("column"), "registration_ms");
  EXPECT_EQ(j.at("count"), 200);
  // Each of 1..100 twice: h = 199p/100 over 1 1 2 2 ... 100 100 (interpolated percentiles).
  EXPECT_DOUBLE_EQ(j.at("p50").get<double>(), 50.5);   // h = 99.5: between 50 and 51
  EXPECT_DOUBLE_EQ(j.at("p90").get<double>(), 90.1);   // h = 179.1
  EXPECT_DOUBLE_EQ(j.at("p99").get<double>(), 99.01);  // h = 197.01
  EXPECT_EQ(j.at("percentiles"), "linear");
  EXPECT_DOUBLE_EQ(j.at("max").get<double>(), 100.0);
  EXPECT_DOUBLE_EQ(j.at("mean").get<double>(), 50.5);
  EXPECT_TRUE(std::filesystem::is_regular_file(dir.file("tp/timing_histogram.svg")));

  const RunResult text = run({test::pl_eval_exe(), "timing", "--csv", dir.file("t.csv"), "--column", "load_ms"}, dir);
  EXPECT_EQ(text.exit_code, 0) << text.err;
  EXPECT_NE(text.out.find("load_ms"), std::string::npos);
  EXPECT_NE(text.out.find("#"), std::string::npos);  // the histogram
}

}  // namespace
}  // namespace pl::eval
