// The command lines of the real tools (pl-map, pl-dataset, pl-sim, pl-eval, pl-server, pl-localize): --help
// prints the defaults of the library config structs, --version the project version, and every
// numeric option is range-checked with an error naming the flag.
#include <gtest/gtest.h>

#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "pl/client/vehicle_localizer.hpp"
#include "pl/dataset/degrade_gps.hpp"
#include "pl/dataset/info.hpp"
#include "pl/dataset/scan_stats.hpp"
#include "pl/eval/map_accuracy.hpp"
#include "pl/eval/topview.hpp"
#include "pl/maps/gloam.hpp"
#include "pl/maps/import.hpp"
#include "pl/server/server.hpp"
#include "pl/sim/simulate.hpp"
#include "test_util.hpp"

namespace {

std::string help_of(const std::string& command) {
  const auto r = pl::test::run(pl::test::tool(command) + " --help");
  EXPECT_EQ(r.exit_code, 0) << command << "\n" << r.output;
  return r.output;
}

// The default --help shows for a flag ("--voxel FLOAT:(0,inf)=0.2" -> "0.2"); "" when it shows none.
std::string default_of(const std::string& help, const std::string& flag) {
  std::smatch m;
  // The flag itself, not a longer one it begins (--lidar, not --lidar-poses).
  const std::regex re("(^|\\s)" + flag + "(?![-\\w])( [^ =\\n]*)?(=(\\S+))?");
  if (!std::regex_search(help, m, re)) {
    ADD_FAILURE() << flag << " is not in the help:\n" << help;
    return "";
  }
  return m[4].str();
}

double number_default(const std::string& help, const std::string& flag) {
  const std::string text = default_of(help, flag);
  EXPECT_FALSE(text.empty()) << flag << " shows no default:\n" << help;
  return text.empty() ? -12345.0 : std::stod(text);
}

}  // namespace

TEST(ToolsCli, PlMapHelpShowsTheConfigDefaults) {
  const pl::maps::GloamConfig g;
  const std::string build = help_of("pl-map build");
  EXPECT_DOUBLE_EQ(number_default(build, "--voxel"), g.merge.voxel_m);
  EXPECT_DOUBLE_EQ(number_default(build, "--every"), static_cast<double>(g.merge.every));
  EXPECT_DOUBLE_EQ(number_default(build, "--min-range"), g.merge.scan.min_range_m);
  EXPECT_DOUBLE_EQ(number_default(build, "--max-range"), g.merge.scan.max_range_m);
  EXPECT_EQ(default_of(build, "--poses"), g.poses == pl::maps::PoseSource::GroundTruth ? "gt" : "lidar");
  EXPECT_EQ(default_of(build, "--deskew"), "auto");
  EXPECT_EQ(g.deskew, pl::maps::Deskew::Auto);
  const pl::maps::ImportConfig i;
  const std::string tile = help_of("pl-map tile");
  EXPECT_DOUBLE_EQ(number_default(tile, "--voxel"), i.voxel_m);
  EXPECT_DOUBLE_EQ(number_default(tile, "--tile-size"), i.tile_size_m);
  EXPECT_DOUBLE_EQ(number_default(tile, "--max-error"), i.codec.max_error_m);
  EXPECT_DOUBLE_EQ(number_default(tile, "--normal-bits"), i.codec.normal_bits);
  EXPECT_DOUBLE_EQ(number_default(tile, "--intensity-bits"), i.codec.intensity_bits);
  EXPECT_NE(tile.find("default: 3 x --voxel"), std::string::npos) << tile;
}

TEST(ToolsCli, PlDatasetHelpShowsTheConfigDefaults) {
  const pl::ScanPrepConfig s = pl::dataset::scan_stats_defaults();
  const std::string scans = help_of("pl-dataset scans");
  EXPECT_DOUBLE_EQ(number_default(scans, "--beams"), s.beams);
  EXPECT_DOUBLE_EQ(number_default(scans, "--fov"), s.fov_deg);
  EXPECT_DOUBLE_EQ(number_default(scans, "--min-range"), s.min_range_m);
  EXPECT_DOUBLE_EQ(number_default(scans, "--max-range"), s.max_range_m);
  EXPECT_DOUBLE_EQ(number_default(scans, "--voxel"), s.voxel_m);
  EXPECT_DOUBLE_EQ(number_default(help_of("pl-dataset info"), "--sample"), static_cast<double>(pl::dataset::InfoConfig{}.sample));
  const pl::dataset::DegradeGpsConfig d;
  const std::string degrade = help_of("pl-dataset degrade-gps");
  EXPECT_DOUBLE_EQ(number_default(degrade, "--rate"), d.rate_hz);
  EXPECT_DOUBLE_EQ(number_default(degrade, "--sigma"), d.sigma_m);
  EXPECT_DOUBLE_EQ(number_default(degrade, "--seed"), static_cast<double>(d.seed));
  EXPECT_EQ(default_of(help_of("pl-dataset poses"), "--format"), "kitti");
}

TEST(ToolsCli, PlSimHelpShowsTheConfigDefaults) {
  const pl::sim::SimOptions o;
  const std::string help = help_of("pl-sim");
  EXPECT_DOUBLE_EQ(number_default(help, "--frames"), static_cast<double>(o.frames));
  EXPECT_DOUBLE_EQ(number_default(help, "--seed"), static_cast<double>(o.world.seed));
  EXPECT_DOUBLE_EQ(number_default(help, "--epoch"), o.world.epoch);
  EXPECT_DOUBLE_EQ(number_default(help, "--change-share"), o.world.change_share);
  EXPECT_DOUBLE_EQ(number_default(help, "--traffic"), o.traffic.count);
  EXPECT_DOUBLE_EQ(number_default(help, "--truck-share"), o.traffic.truck_share);
  EXPECT_DOUBLE_EQ(number_default(help, "--pedestrian-share"), o.traffic.pedestrian_share);
  EXPECT_DOUBLE_EQ(number_default(help, "--fov"), o.fov_deg);
  EXPECT_DOUBLE_EQ(number_default(help, "--map-spacing"), o.map_spacing);
  EXPECT_DOUBLE_EQ(number_default(help, "--threads"), o.threads);
  EXPECT_EQ(default_of(help, "--lidar"), o.lidar);
  EXPECT_DOUBLE_EQ(number_default(help, "--speed-scale"), o.speed_scale);
  EXPECT_DOUBLE_EQ(number_default(help, "--calibration-error"), o.calibration_error);
  EXPECT_EQ(default_of(help, "--sweep"), o.sweep ? "on" : "off");
  std::istringstream origin(default_of(help, "--origin"));
  double lat = 0, lon = 0, alt = 0;
  char c1 = 0, c2 = 0;
  ASSERT_TRUE(origin >> lat >> c1 >> lon >> c2 >> alt) << help;
  EXPECT_NEAR(lat, o.origin.lat_deg, 1e-9);
  EXPECT_NEAR(lon, o.origin.lon_deg, 1e-9);
  EXPECT_NEAR(alt, o.origin.alt_m, 1e-9);
}

TEST(ToolsCli, PlEvalAndPlServerHelpShowTheConfigDefaults) {
  const pl::eval::MapAccuracyOptions m;
  const std::string map = help_of("pl-eval map");
  EXPECT_DOUBLE_EQ(number_default(map, "--within"), m.within);
  EXPECT_DOUBLE_EQ(number_default(map, "--coverage-radius"), m.coverage_radius);
  EXPECT_DOUBLE_EQ(number_default(help_of("pl-eval topview"), "--cell"), pl::eval::TopviewOptions{}.cell);
  const pl::server::ServerConfig s;
  const std::string server = help_of("pl-server");
  EXPECT_DOUBLE_EQ(number_default(server, "--cache-mb"), static_cast<double>(s.api.blob_cache_bytes >> 20));
  EXPECT_EQ(default_of(server, "--listen"), s.host + ":" + std::to_string(s.port));
}

TEST(ToolsCli, PlLocalizeHelpShowsTheConfigDefaults) {
  // The defaults the replay really uses: VehicleLocalizerConfig's (once pl-localize said 16 beams,
  // 0.4 m voxels and 1.0 m cells while the code used 64, 1.0 and 0.5).
  const pl::client::VehicleLocalizerConfig v;
  const pl::client::LocalizerConfig& c = v.localizer;
  const std::string help = help_of("pl-localize");
  EXPECT_DOUBLE_EQ(number_default(help, "--voxel"), c.scan.voxel_m);
  EXPECT_DOUBLE_EQ(number_default(help, "--fov"), c.scan.fov_deg);
  EXPECT_DOUBLE_EQ(number_default(help, "--max-range"), c.scan.max_range_m);
  EXPECT_DOUBLE_EQ(number_default(help, "--roi-radius"), c.roi_radius_m);
  EXPECT_DOUBLE_EQ(number_default(help, "--delta"), c.icp.max_pair_m);
  EXPECT_DOUBLE_EQ(number_default(help, "--cell"), c.map.cell_m);
  EXPECT_DOUBLE_EQ(number_default(help, "--max-iterations"), c.icp.max_iterations);
  EXPECT_DOUBLE_EQ(number_default(help, "--kernel"), c.icp.kernel_m);
  EXPECT_DOUBLE_EQ(number_default(help, "--momentum-window"), c.fusion.momentum_window);
  EXPECT_DOUBLE_EQ(number_default(help, "--momentum-plane-s"), c.fusion.momentum_plane_s);
  EXPECT_DOUBLE_EQ(number_default(help, "--cache-mb"), v.tiles.memory_mb);
  EXPECT_EQ(default_of(help, "--beams"), "");  // the sensor's: known once the drive is read
}

TEST(ToolsCli, EveryToolPrintsTheProjectVersion) {
  for (const std::string tool : {"pl-map", "pl-dataset", "pl-sim", "pl-eval", "pl-server", "pl-localize"}) {
    const auto r = pl::test::run(pl::test::tool(tool) + " --version");
    EXPECT_EQ(r.exit_code, 0) << tool;
    EXPECT_EQ(r.output, tool + " PointLocalization " PL_VERSION "\n");
  }
}

// Values out of range (once accepted silently) and words where numbers belong: exit code 2 before
// any work, "TOOL: error: FLAG takes ..." and the help to read.
TEST(ToolsCli, NumbersOutOfRangeAreRefusedNamingTheFlag) {
  pl::test::TempDir dir;
  pl::test::write_file(dir / "m.sqlite", "");  // --db of an existing store is checked first
  struct Case {
    std::string tool, args, expected, help;
  };
  const std::string out = " --out " + (dir / "x");
  const std::vector<Case> cases = {
      {"pl-map", "build --dataset " + dir.path() + out + " --voxel -1", "--voxel takes a number > 0, got \"-1\"", "pl-map build"},
      {"pl-map", "build --dataset " + dir.path() + out + " --max-range -5", "--max-range takes a number > 0", "pl-map build"},
      {"pl-map", "build --dataset " + dir.path() + out + " --every 0", "--every takes a whole number >= 1", "pl-map build"},
      {"pl-map", "tile --cloud c.pcd --map m --db " + (dir / "m.sqlite") + " --max-error 0.5", "--max-error takes a number in (0, 0.1]",
       "pl-map tile"},
      {"pl-map", "diff --db " + (dir / "m.sqlite") + " --map m --from 0 --to 1", "--from takes a whole number >= 1", "pl-map diff"},
      {"pl-dataset", "scans " + dir.path() + " --voxel -1", "--voxel takes a number >= 0", "pl-dataset scans"},
      {"pl-dataset", "scans " + dir.path() + " --max-range -5", "--max-range takes a number > 0", "pl-dataset scans"},
      {"pl-dataset", "scans " + dir.path() + " --beams many", "--beams takes a whole number >= 0, got \"many\"", "pl-dataset scans"},
      {"pl-dataset", "info " + dir.path() + " --sample 0", "--sample takes a whole number >= 1", "pl-dataset info"},
      {"pl-dataset", "degrade-gps " + dir.path() + out + " --seed -3", "--seed takes a whole number >= 0", "pl-dataset degrade-gps"},
      {"pl-sim", "--route loop" + out + " --frames -3", "--frames takes a whole number >= 0", "pl-sim"},
      {"pl-sim", "--route loop" + out + " --traffic 5000", "--traffic takes a whole number in [0, 1000]", "pl-sim"},
      {"pl-sim", "--route loop" + out + " --truck-share 1.5", "--truck-share takes a number in [0, 1]", "pl-sim"},
      {"pl-server", "--db " + (dir / "m.sqlite") + " --cache-mb -5", "--cache-mb takes a whole number in [0, 1048576]", "pl-server"},
      {"pl-server", "--db " + (dir / "m.sqlite") + " --threads 0", "--threads takes a whole number in [1, 256]", "pl-server"},
      {"pl-eval", "topview --cloud c.pcd" + out + " --cell -1", "--cell takes a number > 0", "pl-eval topview"},
      {"pl-eval", "map --map a.pcd --ref b.pcd --within 5cm", "--within takes a number > 0, got \"5cm\"", "pl-eval map"},
      {"pl-localize", "--dataset " + dir.path() + " --db x --map m" + out + " --count -3", "--count takes a whole number >= 1", "pl-localize"},
      {"pl-localize", "--dataset " + dir.path() + " --db x --map m" + out + " --voxel -1", "--voxel takes a number > 0", "pl-localize"},
      {"pl-localize", "--dataset " + dir.path() + " --db x --map m" + out + " --max-range -5", "--max-range takes a number > 0", "pl-localize"},
      {"pl-localize", "--dataset " + dir.path() + " --db x --map m" + out + " --cache-mb -5", "--cache-mb takes a number > 0", "pl-localize"},
      {"pl-localize", "--dataset " + dir.path() + " --db x --map m" + out + " --fov 400", "--fov takes a number in (0, 360]", "pl-localize"},
      {"pl-localize", "--dataset " + dir.path() + " --db x --map m" + out + " --every 3 --phase 3", "--phase 3 must be below --every 3",
       "pl-localize"},
      {"pl-localize", "--dataset " + dir.path() + " --db x --map m --out /etc/hostname/poses.tum", "--out: cannot write /etc/hostname/poses.tum",
       "pl-localize"},
  };
  for (const auto& c : cases) {
    const auto r = pl::test::run(pl::test::tool(c.tool) + " " + c.args);
    EXPECT_EQ(r.exit_code, 2) << c.tool << " " << c.args << "\n" << r.output;
    EXPECT_EQ(r.output.rfind(c.tool + ": error: " + c.expected, 0), 0u) << c.tool << " " << c.args << "\n" << r.output;
    EXPECT_NE(r.output.find("(run " + c.help + " --help)"), std::string::npos) << r.output;
  }
}
