// The localizer's settings by name (pl/client/config_fields.hpp): every name reaches its own member
// and only it, the table covers every member of the config structs (counted by the compiler), values
// round-trip through text, and bad names and values are refused naming the fix; and pl-localize's
// --set and --list-settings over them.
#include <gtest/gtest.h>

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "member_count.hpp"
#include "pl/client/config_fields.hpp"
#include "pl/client/localizer.hpp"
#include "pl/common/error.hpp"
#include "test_util.hpp"

namespace {

using pl::client::ConfigField;
using pl::client::VehicleLocalizerConfig;
using pl::client::detail::member_count;

// The total, stated so that a change to it is a visible decision. What it is made of is checked
// struct by struct below (Coverage).
constexpr std::size_t kFields = 160;

std::vector<std::string> texts(VehicleLocalizerConfig& cfg) {
  std::vector<std::string> out;
  for (const auto& f : pl::client::config_fields(cfg)) out.push_back(pl::client::config_field_text(f));
  return out;
}

// A value for field i that is not its default and differs from every other field's new value.
std::string distinct_value(const ConfigField& f, std::size_t i) {
  const std::string old = pl::client::config_field_text(f);
  switch (f.value.index()) {
    case 0: {  // double: i + 0.5 (or + 0.75 where that is the default); not a round number, so a
               // text that only round-tripped roughly would show
      const std::string v = std::to_string(i) + ".5";
      return v == old ? std::to_string(i) + ".75" : v;
    }
    case 1:
      return std::to_string(1000 + i);
    case 2:
      return old == "true" ? "false" : "true";
    case 3:
      return std::to_string(100000 + i);
    default:
      return "text-" + std::to_string(i);
  }
}

std::string error_of(const std::string& name, const std::string& text) {
  VehicleLocalizerConfig cfg;
  try {
    pl::client::set_config_field(cfg, name, text);
  } catch (const pl::Error& e) {
    return e.what();
  }
  return "(no error)";
}

}  // namespace

TEST(ConfigFields, NamesAreUniqueAndPointIntoTheConfig) {
  VehicleLocalizerConfig cfg;
  const auto fields = pl::client::config_fields(cfg);
  EXPECT_EQ(fields.size(), kFields);
  std::set<std::string> names;
  const auto* lo = reinterpret_cast<const unsigned char*>(&cfg);
  for (const auto& f : fields) {
    EXPECT_TRUE(names.insert(f.name).second) << "twice: " << f.name;
    EXPECT_FALSE(f.help.empty()) << f.name;
    const auto* p = std::visit([](auto* q) { return reinterpret_cast<const unsigned char*>(q); }, f.value);
    EXPECT_TRUE(p >= lo && p < lo + sizeof cfg) << f.name << " does not point into the config given";
  }
}

// (a) Each name set to a value of its own changes that setting and no other: two names on one member
// would change each other's text. And its member lies in the sub-struct its path names (a table
// for localizer/odometry/icp pointing at localizer/icp would fail here); the last part of every name
// is the member's identifier by construction (config_fields.cpp's FIELD macro).
TEST(ConfigFields, EachNameSetsItsOwnMemberAndNoOther) {
  VehicleLocalizerConfig defaults;
  const std::vector<std::string> before = texts(defaults);
  const auto names = pl::client::config_fields(defaults);
  for (std::size_t i = 0; i < names.size(); ++i) {
    VehicleLocalizerConfig cfg;
    const auto fields = pl::client::config_fields(cfg);
    const std::string value = distinct_value(fields[i], i);
    pl::client::set_config_field(cfg, fields[i].name, value);
    const std::vector<std::string> after = texts(cfg);
    for (std::size_t j = 0; j < after.size(); ++j) {
      if (j == i)
        EXPECT_EQ(after[j], value) << fields[j].name << " did not take (or round-trip) the value set";
      else
        EXPECT_EQ(after[j], before[j]) << "setting " << fields[i].name << " changed " << fields[j].name;
    }
  }
}

TEST(ConfigFields, EachMemberLiesInTheStructItsPathNames) {
  VehicleLocalizerConfig c;
  struct Part {
    std::string prefix;
    const void* begin;
    std::size_t size;
  };
  auto part = [](std::string prefix, const auto& member) { return Part{std::move(prefix), &member, sizeof member}; };
  const std::vector<Part> parts = {
      part("localizer/scan/", c.localizer.scan),
      part("localizer/map/", c.localizer.map),
      part("localizer/coarse_map/", c.localizer.coarse_map),
      part("localizer/icp/", c.localizer.icp),
      part("localizer/fusion/odometry_sigma/", c.localizer.fusion.odometry_sigma),
      part("localizer/fusion/lidar_sigma/", c.localizer.fusion.lidar_sigma),
      part("localizer/fusion/", c.localizer.fusion),
      part("localizer/motion/", c.localizer.motion),
      part("localizer/integrity/", c.localizer.integrity),
      part("localizer/places/", c.localizer.places),
      part("localizer/odometry/icp/", c.localizer.odometry.icp),
      part("localizer/odometry/", c.localizer.odometry),
      part("localizer/", c.localizer),
      part("tiles/", c.tiles),
      part("search/", c.search),
      part("gps_search/", c.gps_search),
      part("changes/", c.changes),
      part("", c),
  };
  for (const auto& f : pl::client::config_fields(c)) {
    const auto* p = std::visit([](auto* q) { return reinterpret_cast<const unsigned char*>(q); }, f.value);
    // The longest prefix the name begins with (listed longest first within each folder).
    const Part* in = nullptr;
    for (const auto& pt : parts)
      if (f.name.rfind(pt.prefix, 0) == 0 && (!in || pt.prefix.size() > in->prefix.size())) in = &pt;
    ASSERT_NE(in, nullptr) << f.name;
    const auto* b = static_cast<const unsigned char*>(in->begin);
    EXPECT_TRUE(p >= b && p < b + in->size) << f.name << " points outside " << (in->prefix.empty() ? "the config" : in->prefix);
    // Nothing deeper: a name directly under a folder is a member of that struct, not of one nested in it.
    EXPECT_EQ(f.name.find('/', in->prefix.size()), std::string::npos) << f.name << " is in no listed struct";
  }
}

// (b) Every member of every config struct is in the table, or is a nested struct (its own folder),
// or is one of the few left out on purpose (config_fields.hpp). The member counts are the
// compiler's (member_count.hpp), not figures kept by hand: adding a member to any of these structs
// fails this test until the table has it (config_fields.cpp's static_asserts fail the build first).
// sizeof would miss a bool or int added into padding.
TEST(ConfigFields, CoverEveryMemberOfEveryConfigStruct) {
  VehicleLocalizerConfig cfg;
  std::map<std::string, std::size_t> direct;  // folder -> names directly in it
  for (const auto& f : pl::client::config_fields(cfg)) {
    const auto slash = f.name.rfind('/');
    ++direct[slash == std::string::npos ? "" : f.name.substr(0, slash + 1)];
  }
  using namespace pl::client;
  using pl::registration::IcpConfig;
  using pl::registration::PoseSearch;
  struct Folder {
    std::string prefix;
    std::size_t members, elsewhere;  // the struct's members; those not directly in it (folders, left out)
  };
  const std::vector<Folder> folders = {
      {"localizer/scan/", member_count<pl::ScanPrepConfig>(), 0},
      {"localizer/map/", member_count<RoiMapConfig>(), 0},
      {"localizer/coarse_map/", member_count<RoiMapConfig>(), 0},
      {"localizer/icp/", member_count<IcpConfig>(), 0},
      {"localizer/fusion/", member_count<FusionConfig>(), 2},  // odometry_sigma/ and lidar_sigma/: a folder per array
      {"localizer/fusion/odometry_sigma/", std::tuple_size_v<decltype(FusionConfig::odometry_sigma)>, 0},
      {"localizer/fusion/lidar_sigma/", std::tuple_size_v<decltype(FusionConfig::lidar_sigma)>, 0},
      {"localizer/motion/", member_count<MotionConfig>(), 0},
      {"localizer/integrity/", member_count<IntegrityConfig>(), 0},
      {"localizer/places/", member_count<PlaceConfig>(), 0},
      {"localizer/odometry/", member_count<LidarOdometryConfig>(), 1},  // icp/
      {"localizer/odometry/icp/", member_count<IcpConfig>(), 0},
      // scan, map, coarse_map, icp, fusion, motion, integrity, places, odometry
      {"localizer/", member_count<LocalizerConfig>(), 9},
      {"tiles/", member_count<TileClientConfig>(), 1},  // version: left out (std::optional)
      {"search/", member_count<PoseSearch>(), 0},
      {"gps_search/", member_count<PoseSearch>(), 0},
      {"changes/", member_count<ChangeEvidenceConfig>(), 0},
      // localizer, tiles, search, gps_search, changes; base_from_lidar and base_from_antenna left out
      // (Eigen), and on_wait (a callback)
      {"", member_count<VehicleLocalizerConfig>(), 8},
  };
  std::size_t total = 0;
  for (const auto& f : folders) {
    EXPECT_EQ(direct[f.prefix], f.members - f.elsewhere)
        << "\"" << f.prefix << "\": the struct has " << f.members << " members, " << f.elsewhere
        << " held elsewhere; add the new member to config_fields.cpp";
    total += direct[f.prefix];
  }
  EXPECT_EQ(direct.size(), folders.size()) << "a folder not listed here";
  EXPECT_EQ(total, kFields);
}

TEST(ConfigFields, ValuesRoundTripThroughText) {
  VehicleLocalizerConfig cfg;
  auto fields = pl::client::config_fields(cfg);
  const std::vector<std::string> before = texts(cfg);
  for (const auto& f : fields) pl::client::set_config_field(f, pl::client::config_field_text(f));
  EXPECT_EQ(texts(cfg), before);
  // The defaults include 1.5e-4 and 3e-4; these are the awkward ones of binary floating point.
  for (const double v : {0.1 + 0.2, 1.0 / 3.0, 1e-300, 123456789.125, -0.0625}) {
    cfg.localizer.icp.kernel_m = v;
    const ConfigField& kernel =
        *std::find_if(fields.begin(), fields.end(), [](const auto& f) { return f.name == "localizer/icp/kernel_m"; });
    const std::string text = pl::client::config_field_text(kernel);
    cfg.localizer.icp.kernel_m = 0;
    pl::client::set_config_field(kernel, text);
    EXPECT_EQ(cfg.localizer.icp.kernel_m, v) << text;
  }
  EXPECT_EQ(pl::client::config_field_text(*std::find_if(fields.begin(), fields.end(),
                                                        [](const auto& f) { return f.name == "localizer/icp/converged_rad"; })),
            "0.00015");
}

TEST(ConfigFields, ParsesEachType) {
  VehicleLocalizerConfig cfg;
  pl::client::set_config_field(cfg, "localizer/scan/voxel_m", "0.25");
  pl::client::set_config_field(cfg, "localizer/icp/converged_m", "2e-3");
  pl::client::set_config_field(cfg, "localizer/icp/max_iterations", "-7");  // range-free: the localizer checks
  pl::client::set_config_field(cfg, "max_odometry_samples", "18446744073709551615");
  pl::client::set_config_field(cfg, "tiles/server", "http://maps:8080");
  pl::client::set_config_field(cfg, "tiles/token", "");
  pl::client::set_config_field(cfg, "localizer/fusion/odometry_sigma/yaw", "0.01");
  EXPECT_EQ(cfg.localizer.scan.voxel_m, 0.25);
  EXPECT_EQ(cfg.localizer.icp.converged_m, 2e-3);
  EXPECT_EQ(cfg.localizer.icp.max_iterations, -7);
  EXPECT_EQ(cfg.max_odometry_samples, SIZE_MAX);
  EXPECT_EQ(cfg.tiles.server, "http://maps:8080");
  EXPECT_EQ(cfg.tiles.token, "");
  EXPECT_EQ(cfg.localizer.fusion.odometry_sigma[5], 0.01);
  for (const auto& [text, value] : std::vector<std::pair<std::string, bool>>{{"true", true},
                                                                             {"false", false},
                                                                             {"1", true},
                                                                             {"0", false},
                                                                             {"on", true},
                                                                             {"off", false},
                                                                             {"yes", true},
                                                                             {"no", false},
                                                                             {"True", true},
                                                                             {"OFF", false}}) {
    cfg.start_from_gps = !value;
    pl::client::set_config_field(cfg, "start_from_gps", text);
    EXPECT_EQ(cfg.start_from_gps, value) << text;
  }
}

// (c) The errors name the problem and the fix.
TEST(ConfigFields, RefusesUnknownNamesSuggestingTheClosest) {
  EXPECT_EQ(error_of("localizer/scan/voxl_m", "1"),
            "no localizer setting is named \"localizer/scan/voxl_m\" (did you mean localizer/scan/voxel_m?)");
  // The member without its folder, or in the wrong one: every member of that name.
  EXPECT_EQ(
      error_of("kernel_m", "1"),
      "no localizer setting is named \"kernel_m\" (did you mean localizer/icp/kernel_m or localizer/odometry/icp/kernel_m?)");
  EXPECT_EQ(error_of("localizer/max_speed_mps", "1"),
            "no localizer setting is named \"localizer/max_speed_mps\" (did you mean localizer/motion/max_speed_mps?)");
  EXPECT_EQ(error_of("localizer/motion/max_speed", "1"),
            "no localizer setting is named \"localizer/motion/max_speed\" (did you mean localizer/motion/max_speed_mps?)");
  // The members left out on purpose say where they are set instead.
  EXPECT_EQ(error_of("tiles/version", "3").rfind("tiles/version is not a setting: ", 0), 0u);
  EXPECT_NE(error_of("tiles/version", "3").find("--map-version"), std::string::npos);
  EXPECT_EQ(error_of("base_from_lidar", "0").rfind("base_from_lidar is not a setting: extrinsics", 0), 0u);
  // Nothing close: what names look like.
  const std::string far = error_of("frobnicate", "1");
  EXPECT_EQ(far.rfind("no localizer setting is named \"frobnicate\": names are paths", 0), 0u) << far;
  EXPECT_NE(far.find("localizer/icp/kernel_m"), std::string::npos) << far;
}

TEST(ConfigFields, RefusesValuesThatDoNotParseNamingTheType) {
  EXPECT_EQ(error_of("localizer/scan/voxel_m", "abc"),
            "localizer/scan/voxel_m takes a number (such as 0.5 or 1e-3), got \"abc\"");
  EXPECT_EQ(error_of("localizer/scan/voxel_m", ""), "localizer/scan/voxel_m takes a number (such as 0.5 or 1e-3), got \"\"");
  EXPECT_EQ(error_of("localizer/scan/voxel_m", "0.5m"),
            "localizer/scan/voxel_m takes a number (such as 0.5 or 1e-3), got \"0.5m\"");
  EXPECT_EQ(error_of("localizer/scan/voxel_m", "nan"),
            "localizer/scan/voxel_m takes a number (such as 0.5 or 1e-3), got \"nan\"");
  EXPECT_EQ(error_of("localizer/scan/voxel_m", "1e999"),
            "localizer/scan/voxel_m takes a number (such as 0.5 or 1e-3), got \"1e999\"");
  // Whole numbers: no fraction, no exponent, within the member's type.
  EXPECT_EQ(error_of("localizer/icp/max_iterations", "2.5"), "localizer/icp/max_iterations takes a whole number, got \"2.5\"");
  EXPECT_EQ(error_of("localizer/icp/max_iterations", "1e3"), "localizer/icp/max_iterations takes a whole number, got \"1e3\"");
  EXPECT_EQ(error_of("localizer/icp/max_iterations", " 5"), "localizer/icp/max_iterations takes a whole number, got \" 5\"");
  EXPECT_EQ(error_of("localizer/icp/max_iterations", "3000000000"),
            "localizer/icp/max_iterations takes a whole number from -2147483648 to 2147483647, got \"3000000000\"");
  EXPECT_EQ(error_of("localizer/icp/max_iterations", "-99999999999999999999"),
            "localizer/icp/max_iterations takes a whole number from -2147483648 to 2147483647, got \"-99999999999999999999\"");
  EXPECT_EQ(error_of("max_odometry_samples", "-1"), "max_odometry_samples takes a whole number >= 0, got \"-1\"");
  EXPECT_EQ(error_of("max_odometry_samples", "18446744073709551616"),
            "max_odometry_samples takes a whole number from 0 to 18446744073709551615, got \"18446744073709551616\"");
  EXPECT_EQ(error_of("start_from_gps", "maybe"), "start_from_gps takes true or false (or 1/0, on/off, yes/no), got \"maybe\"");
  EXPECT_EQ(error_of("start_from_gps", "2"), "start_from_gps takes true or false (or 1/0, on/off, yes/no), got \"2\"");
  // A refused value leaves the setting as it was.
  VehicleLocalizerConfig cfg;
  EXPECT_THROW(pl::client::set_config_field(cfg, "localizer/icp/max_iterations", "2.5"), pl::Error);
  EXPECT_EQ(cfg.localizer.icp.max_iterations, VehicleLocalizerConfig().localizer.icp.max_iterations);
}

// The localizer's settings are range-checked by name: the defaults pass; every number of
// LocalizerConfig set to -1 (and every real one to NaN) is refused naming that setting; the
// stricter rules name theirs; a Localizer is not made from a config out of range.
TEST(ConfigFields, LocalizerSettingsOutOfRangeAreRefusedByName) {
  EXPECT_NO_THROW(pl::client::check_localizer_config(pl::client::LocalizerConfig{}));
  std::size_t numbers = 0;
  const std::size_t count = [] {
    pl::client::LocalizerConfig c;
    return pl::client::config_fields(c).size();
  }();
  for (std::size_t k = 0; k < count; ++k) {
    for (const char* bad : {"-1", "nan"}) {
      pl::client::LocalizerConfig c;
      const ConfigField f = pl::client::config_fields(c)[k];
      if (f.value.index() == 2 || f.value.index() == 4) continue;  // bools and text have no range
      if (std::string(bad) == "nan") {
        if (auto* d = std::get_if<double*>(&f.value))
          **d = std::nan("");
        else
          continue;
      } else if (f.value.index() == 3) {
        continue;  // std::size_t cannot hold -1
      } else {
        pl::client::set_config_field(f, bad);
      }
      ++numbers;
      try {
        pl::client::check_localizer_config(c);
        ADD_FAILURE() << f.name << " = " << bad << " passed the check";
      } catch (const pl::Error& e) {
        EXPECT_EQ(std::string(e.what()).rfind("localizer setting " + f.name + " must be", 0), 0u) << e.what();
      }
    }
  }
  EXPECT_GT(numbers, 150u);  // every number of the localizer's 100+ settings, -1 and NaN

  struct Case {
    std::string name, value, expected;
  };
  const std::vector<Case> cases = {
      {"localizer/integrity/alert_limit_m", "0", "must be > 0, got 0"},
      {"localizer/icp/kernel_m", "0", "must be > 0, got 0"},
      {"localizer/fusion/lidar_sigma/yaw", "0", "must be > 0, got 0"},
      {"localizer/integrity/min_share", "1.5", "is a share: from 0 to 1, got 1.5"},
      {"localizer/integrity/ambiguity_ratio", "0", "is a share: > 0 and at most 1, got 0"},
      {"localizer/icp/max_boost", "0.5", "is a factor: at least 1, got 0.5"},
      {"localizer/scan/fov_deg", "400", "is at most 360, got 400"},
      {"localizer/odometry/icp/max_iterations", "0", "must be > 0, got 0"},
  };
  for (const auto& c : cases) {
    VehicleLocalizerConfig cfg;
    pl::client::set_config_field(cfg, c.name, c.value);
    try {
      pl::client::check_localizer_config(cfg.localizer);
      ADD_FAILURE() << c.name << " = " << c.value << " passed the check";
    } catch (const pl::Error& e) {
      EXPECT_EQ(std::string(e.what()).rfind("localizer setting " + c.name + " " + c.expected + " (", 0), 0u) << e.what();
    }
    // The same words for the one setting alone (pl-localize --set says them before any work).
    for (const auto& f : pl::client::config_fields(cfg))
      if (f.name == c.name) {
        EXPECT_EQ(pl::client::config_field_range_problem(f).rfind(c.name + " " + c.expected, 0), 0u);
      }
  }
  // A setting against another.
  pl::client::LocalizerConfig ranges;
  ranges.scan.min_range_m = 90.0;
  EXPECT_THROW(pl::client::check_localizer_config(ranges), pl::Error);
  // Zero where zero means "off" stays allowed.
  pl::client::LocalizerConfig off;
  off.scan.voxel_m = 0.0;
  off.map.thin_m = 0.0;
  off.integrity.seeds = 0;
  off.motion.sweep_points = 0;
  EXPECT_NO_THROW(pl::client::check_localizer_config(off));
  // The localizer checks its config when made.
  pl::client::LocalizerConfig bad;
  bad.integrity.alert_limit_m = -1.0;
  EXPECT_THROW(pl::client::Localizer(bad, 50.0, [](const Eigen::Vector2d&, double) { return std::vector<pl::client::MapTile>{}; }),
               pl::Error);
  // And the vehicle localizer before it opens the map: the setting is named, not a missing map.
  VehicleLocalizerConfig vehicle;
  vehicle.tiles.server = "http://127.0.0.1:1";
  vehicle.tiles.map = "m";
  vehicle.ready_timeout_s = 0.0;
  vehicle.localizer.icp.kernel_m = 0.0;
  try {
    pl::client::VehicleLocalizer l(vehicle);
    ADD_FAILURE() << "a kernel of 0 m was taken";
  } catch (const pl::Error& e) {
    EXPECT_EQ(std::string(e.what()).rfind("localizer setting localizer/icp/kernel_m must be > 0, got 0", 0), 0u) << e.what();
  }
}

// pl-localize --set: checked while parsing, before any work, with the library's message.
TEST(ConfigFieldsCli, PlLocalizeSetRefusesBadSettingsBeforeAnyWork) {
  pl::test::TempDir dir;
  const std::string base =
      pl::test::tool("pl-localize") + " --dataset " + dir.path() + " --db x --map m --out " + (dir / "o.tum");
  struct Case {
    std::string set, expected;
  };
  const std::vector<Case> cases = {
      {"localizer/scan/voxel_m=abc", "--set localizer/scan/voxel_m takes a number (such as 0.5 or 1e-3), got \"abc\""},
      {"localizer/icp/max_iterations=2.5", "--set localizer/icp/max_iterations takes a whole number, got \"2.5\""},
      {"localizer/scan/voxl_m=1",
       "--set: no localizer setting is named \"localizer/scan/voxl_m\" (did you mean localizer/scan/voxel_m?); "
       "pl-localize --list-settings lists them all"},
      {"localizer/scan/voxel_m", "--set takes NAME=VALUE, got \"localizer/scan/voxel_m\""},
      // What pl-localize sets itself is refused, naming the option to use.
      {"localizer/scan/beams=16", "--set localizer/scan/beams: pl-localize sets it from --beams; use that instead"},
      {"tiles/server=http://x:1", "--set tiles/server: pl-localize sets it from --server; use that instead"},
      // Out of its range.
      {"localizer/integrity/alert_limit_m=-1",
       "--set localizer/integrity/alert_limit_m must be >= 0, got -1 (a scan whose protection level exceeds this is not ok"},
  };
  for (const auto& c : cases) {
    const auto r = pl::test::run(base + " --set " + c.set);
    EXPECT_EQ(r.exit_code, 2) << c.set << "\n" << r.output;
    EXPECT_EQ(r.output.rfind("pl-localize: error: " + c.expected, 0), 0u) << c.set << "\n" << r.output;
  }
}

TEST(ConfigFieldsCli, PlLocalizeListSettingsShowsEveryNameWithItsValue) {
  // Needs none of the required options, as --help.
  const auto r =
      pl::test::run(pl::test::tool("pl-localize") + " --list-settings --set localizer/icp/kernel_m=0.7 --set tiles/token=abc");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  VehicleLocalizerConfig cfg;
  const auto fields = pl::client::config_fields(cfg);
  std::vector<std::string> lines;
  std::istringstream in(r.output);
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  ASSERT_EQ(lines.size(), fields.size()) << r.output;
  for (std::size_t i = 0; i < fields.size(); ++i) {
    std::string value = pl::client::config_field_text(fields[i]);
    if (fields[i].name == "localizer/icp/kernel_m") value = "0.7";  // the --set values are shown
    if (fields[i].name == "tiles/token") value = "abc";
    EXPECT_EQ(lines[i].rfind(fields[i].name + "=" + value + " ", 0), 0u) << lines[i];
    EXPECT_NE(lines[i].find(fields[i].help), std::string::npos) << lines[i];
  }
}

// The values reach the run: the constructor's wait for an unreachable server is ready_timeout_s
// (30 s by default), here 0.3 s, and the error says how long it waited.
TEST(ConfigFieldsCli, PlLocalizeAppliesTheSettings) {
  pl::test::TempDir dir;
  const float point[4] = {10.0f, 0.0f, 0.0f, 0.5f};
  std::filesystem::create_directories(dir / "velodyne");
  std::ofstream(dir / "velodyne/000000.bin", std::ios::binary).write(reinterpret_cast<const char*>(point), sizeof point);
  pl::test::write_file(dir / "times.txt", "0.0\n");
  const auto r = pl::test::run(pl::test::tool("pl-localize") + " --dataset " + dir.path() +
                               " --server http://127.0.0.1:9 --map m --init 0,0,0,0 --out " + (dir / "o.tum") +
                               " --set ready_timeout_s=0.3");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_EQ(r.output.rfind("pl-localize: error: no map 'm' from http://127.0.0.1:9 within 0.3 s", 0), 0u) << r.output;
}
