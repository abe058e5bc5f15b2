// pl/common/cli.hpp: the CLI11 helpers every pl-* tool is built on, run in-process: checked numbers,
// choices, coordinates and output paths, and how a Tool reports --help, --version and bad input.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "pl/common/cli.hpp"
#include "pl/common/error.hpp"
#include "pl/common/output_path.hpp"
#include "test_util.hpp"

namespace {

struct Outcome {
  int code;
  std::string out, err;
};

// Runs tool.main on the words (the program name first), capturing stdout and stderr.
Outcome run(pl::cli::Tool& tool, std::vector<std::string> words) {
  std::vector<char*> argv;
  for (auto& w : words) argv.push_back(w.data());
  testing::internal::CaptureStdout();
  testing::internal::CaptureStderr();
  const int code = tool.main(static_cast<int>(argv.size()), argv.data());
  const std::string out = testing::internal::GetCapturedStdout();
  return {code, out, testing::internal::GetCapturedStderr()};
}

// A tool with one command "go" taking every kind of option the helpers make.
struct Demo {
  pl::cli::Tool tool{"pl-demo", "a demo"};
  double voxel = 0.2;
  int count = 3;
  std::size_t every = 1;
  std::string poses = "gt", origin, out;
  bool json = false, ran = false;
  Demo() {
    CLI::App& c = tool.command("go", "do it", [this] {
      ran = true;
      return 0;
    });
    pl::cli::number(c, "--voxel", voxel, "voxel side", pl::cli::above(0));
    pl::cli::number(c, "--count", count, "how many", pl::cli::between(1, 100));
    pl::cli::number(c, "--every", every, "step", pl::cli::at_least(1));
    pl::cli::choice(c, "--poses", poses, "where from", {"gt", "lidar"});
    pl::cli::geo_option(c, "--origin", origin, "origin");
    pl::cli::output_file(c, "--out", out, "output");
    c.add_flag("--json", json, "JSON");
  }
};

}  // namespace

TEST(Cli, ParsesCheckedOptionsAndRunsTheCommand) {
  Demo d;
  const auto r = run(d.tool, {"pl-demo", "go", "--voxel", "0.25", "--count=7", "--json", "--poses", "lidar", "--origin", "-33.9,151.2,10"});
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(d.ran);
  EXPECT_DOUBLE_EQ(d.voxel, 0.25);
  EXPECT_EQ(d.count, 7);
  EXPECT_TRUE(d.json);
  EXPECT_EQ(d.poses, "lidar");
  const pl::GeoPoint g = pl::cli::geo_point(d.origin, "--origin");
  EXPECT_DOUBLE_EQ(g.lat_deg, -33.9);
  EXPECT_DOUBLE_EQ(g.alt_m, 10.0);
}

TEST(Cli, TheLastOfARepeatedOptionWins) {
  Demo d;
  const auto r = run(d.tool, {"pl-demo", "go", "--voxel", "0.3", "--count", "4", "--voxel", "0.5"});
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_DOUBLE_EQ(d.voxel, 0.5);
  EXPECT_EQ(d.count, 4);
}

TEST(Cli, OutOfRangeAndMalformedValuesNameTheFlagAndTheHelp) {
  const std::vector<std::pair<std::vector<std::string>, std::string>> cases = {
      {{"--voxel", "-1"}, "--voxel takes a number > 0, got \"-1\""},
      {{"--voxel", "0"}, "--voxel takes a number > 0"},
      {{"--voxel", "5cm"}, "--voxel takes a number > 0, got \"5cm\""},
      {{"--voxel", "nan"}, "--voxel takes a number"},
      {{"--count", "-3"}, "--count takes a whole number in [1, 100], got \"-3\""},
      {{"--count", "2.5"}, "--count takes a whole number"},
      {{"--every", "0"}, "--every takes a whole number >= 1"},
      {{"--every", "-1"}, "--every takes a whole number >= 1"},
      {{"--poses", "odometry"}, "--poses takes gt or lidar, got \"odometry\""},
      {{"--origin", "49,8"}, "--origin takes 3 comma-separated numbers"},
      {{"--origin", "91,8,0"}, "latitude in [-90, 90]"},
      {{"--out", "/etc/hostname/x.pcd"}, "--out: cannot write /etc/hostname/x.pcd: /etc/hostname is a file, not a folder"},
      {{"--voxel"}, "--voxel"},
      {{"--bogus", "1"}, "--bogus"},
  };
  for (const auto& [args, expected] : cases) {
    Demo d;
    std::vector<std::string> words = {"pl-demo", "go"};
    words.insert(words.end(), args.begin(), args.end());
    const auto r = run(d.tool, words);
    EXPECT_EQ(r.code, 2) << args[0];
    EXPECT_FALSE(d.ran) << args[0];
    EXPECT_EQ(r.err.rfind("pl-demo: error: ", 0), 0u) << r.err;
    EXPECT_NE(r.err.find(expected), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("(run pl-demo go --help)"), std::string::npos) << r.err;
    EXPECT_EQ(r.err.find("--voxel: --voxel"), std::string::npos) << r.err;  // the flag is named once
  }
}

TEST(Cli, CommandsHelpVersionAndErrorsFromTheBody) {
  {
    Demo d;
    const auto r = run(d.tool, {"pl-demo", "--version"});
    EXPECT_EQ(r.code, 0);
    EXPECT_EQ(r.out, pl::cli::version_line("pl-demo") + "\n");
    EXPECT_EQ(r.out.rfind("pl-demo PointLocalization ", 0), 0u);
  }
  {
    Demo d;
    const auto r = run(d.tool, {"pl-demo", "go", "--help"});
    EXPECT_EQ(r.code, 0);
    EXPECT_FALSE(d.ran);
    EXPECT_NE(r.out.find("Usage: pl-demo go"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("--voxel FLOAT:(0,inf)=0.2"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("--count INT:[1,100]=3"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("--poses gt|lidar=gt"), std::string::npos) << r.out;
  }
  {
    Demo d;
    const auto r = run(d.tool, {"pl-demo"});
    EXPECT_EQ(r.code, 2);
    EXPECT_NE(r.err.find("pl-demo: error: missing command: pl-demo go"), std::string::npos) << r.err;
  }
  {
    Demo d;
    const auto r = run(d.tool, {"pl-demo", "og"});
    EXPECT_EQ(r.code, 2);
    EXPECT_NE(r.err.find("unknown command \"og\""), std::string::npos) << r.err;
  }
}

TEST(Cli, ABodysErrorIsPrintedWithTheProgramName) {
  pl::cli::Tool tool("pl-demo", "a demo");
  tool.body([] () -> int { throw pl::Error("the drive has no scans"); });
  const auto r = run(tool, {"pl-demo"});
  EXPECT_EQ(r.code, 2);
  EXPECT_EQ(r.err, "pl-demo: error: the drive has no scans\n");
}

TEST(Cli, OutputPathProblemsNameThePathAndTheFix) {
  pl::test::TempDir dir;
  pl::test::write_file(dir / "file.txt", "x\n");
  EXPECT_EQ(pl::output_file_problem(dir / "ok.pcd"), "");
  EXPECT_EQ(pl::output_file_problem(dir / "file.txt"), "");  // an existing file is replaced
  EXPECT_NE(pl::output_file_problem(dir / "file.txt/x.pcd").find("file.txt is a file, not a folder"), std::string::npos);
  EXPECT_NE(pl::output_file_problem(dir / "no/such/x.pcd").find("the folder " + (dir / "no/such") + " does not exist"),
            std::string::npos);
  EXPECT_NE(pl::output_file_problem(dir.path()).find("it is a folder"), std::string::npos);
  EXPECT_NE(pl::output_file_problem("").find("empty"), std::string::npos);
  EXPECT_THROW(pl::check_output_file(dir / "no/such/x.pcd"), pl::Error);
  // Folders are created with their parents: only a file in the way, or an unwritable folder, stops them.
  EXPECT_EQ(pl::output_folder_problem(dir / "new/deeper"), "");
  EXPECT_EQ(pl::output_folder_problem(dir.path()), "");
  EXPECT_NE(pl::output_folder_problem(dir / "file.txt").find("it is a file, not a folder"), std::string::npos);
  EXPECT_NE(pl::output_folder_problem(dir / "file.txt/sub").find("is a file, not a folder"), std::string::npos);
}

TEST(Cli, FilesBesideAPathTakeItsStem) {
  EXPECT_EQ(pl::beside("maps/town.pcd", ".places"), "maps/town.places");
  EXPECT_EQ(pl::beside("maps/town", ".drives.json"), "maps/town.drives.json");
  EXPECT_EQ(pl::beside("a.b/town", ".places"), "a.b/town.places");      // a dot in a folder is not an extension
  EXPECT_EQ(pl::beside("maps/.hidden", ".places"), "maps/.hidden.places");  // nor a leading dot
  EXPECT_EQ(pl::beside("town.v2.pcd", ".places"), "town.v2.places");
}
