// The Ouster decoder's metadata: found in a file or as text, in either layout, with the SDK's
// defaults for what is left out; refused with the file, line and field when it is wrong.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>

#include "ouster_packets.hpp"
#include "pl/common/error.hpp"
#include "pl/lidar/decoder.hpp"

namespace pl::lidar {
namespace {

namespace ot = pl::test::ouster;

class OusterMetadata : public ::testing::Test {
 protected:
  void SetUp() override {
    std::string tmpl = (std::filesystem::temp_directory_path() / "pl-ouster-XXXXXX").string();
    ASSERT_NE(mkdtemp(tmpl.data()), nullptr);
    dir_ = tmpl;
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }

  std::string write(const std::string& name, const std::string& text) {
    const std::string path = dir_ + "/" + name;
    std::ofstream(path) << text;
    return path;
  }

  // The error a decoder made from the metadata file `text` throws ("" when none).
  std::string error_of(const std::string& text, const std::string& model = {}) {
    DecoderOptions o;
    o.calibration_path = write("meta.json", text);
    o.model = model;
    try {
      make_decoder(Vendor::Ouster, o);
    } catch (const Error& e) {
      return e.what();
    }
    return "";
  }

  std::string dir_;
};

std::string replaced(std::string text, const std::string& from, const std::string& to) {
  const std::size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  return at == std::string::npos ? text : text.replace(at, from.size(), to);
}

// The 1-based line of the first `needle` in `text`.
std::string line_of(const std::string& text, const std::string& needle) {
  const std::size_t at = text.find(needle);
  return std::to_string(1 + std::count(text.begin(), text.begin() + static_cast<std::ptrdiff_t>(at), '\n'));
}

TEST_F(OusterMetadata, MissingMetadataNamesTheFlag) {
  try {
    make_decoder(Vendor::Ouster, DecoderOptions{});
    FAIL() << "a decoder without metadata";
  } catch (const Error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("--lidar-calibration"), std::string::npos) << what;
    EXPECT_NE(what.find("metadata"), std::string::npos) << what;
  }
  DecoderOptions o;
  o.calibration_path = dir_ + "/nowhere.json";
  try {
    make_decoder(Vendor::Ouster, o);
    FAIL() << "a metadata file that is not there";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(o.calibration_path), std::string::npos) << e.what();
  }
}

TEST_F(OusterMetadata, FileOrTextDecodeAlike) {
  const ot::Spec s;
  const std::string text = ot::metadata_json(s, true);
  DecoderOptions by_path;
  by_path.calibration_path = write("m.json", text);
  DecoderOptions by_text;
  by_text.calibration_text = text;
  by_text.calibration_path = dir_ + "/ignored.json";  // the text wins
  EXPECT_EQ(make_decoder(Vendor::Ouster, by_path)->info().elevation_deg, s.altitude);
  EXPECT_EQ(make_decoder(Vendor::Ouster, by_text)->info().elevation_deg, s.altitude);
}

TEST_F(OusterMetadata, ErrorsNameTheFileLineAndField) {
  const ot::Spec s;
  const std::string good = ot::metadata_json(s, false);
  const std::string nested = ot::metadata_json(s, true);
  const std::string path = dir_ + "/meta.json";
  struct Case {
    std::string text, field, line;
  };
  const std::string broken = replaced(good, "\"lidar_mode\":", "\"lidar_mode\" ");
  const std::string short_alt = replaced(good, "[16.5, ", "[");
  const std::vector<Case> cases = {
      {broken, "JSON", line_of(broken, "\"lidar_mode\" ")},
      {short_alt, "beam_altitude_angles", line_of(good, "\"beam_altitude_angles\"")},
      {replaced(good, "[4.2000000000000002, ", "[\"4.2\", "), "beam_azimuth_angles", line_of(good, "\"beam_azimuth_angles\"")},
      {replaced(nested, "\"LEGACY\"", "\"FIVE_WORD_PIXEL\""), "udp_profile_lidar", line_of(nested, "\"udp_profile_lidar\"")},
      {replaced(good, "\"512x10\"", "\"fast\""), "lidar_mode", line_of(good, "\"lidar_mode\"")},
      {replaced(good, "\"column_window\": [0, 511]", "\"column_window\": [0, 512]"), "column_window", line_of(good, "\"column_window\"")},
      {replaced(good, "\"columns_per_packet\": 16", "\"columns_per_packet\": 0"), "columns_per_packet", line_of(good, "\"columns_per_packet\"")},
      {replaced(nested, "\"lidar_to_sensor_transform\": [-1, 0, 0, 0,", "\"lidar_to_sensor_transform\": [0, 0, 0,"),
       "lidar_to_sensor_transform", line_of(nested, "\"lidar_to_sensor_transform\"")},
      {"[1, 2, 3]", "a JSON object", "1"},
  };
  for (const Case& c : cases) {
    const std::string what = error_of(c.text);
    SCOPED_TRACE(what);
    EXPECT_EQ(what.rfind(path + ":" + c.line + ":", 0), 0u) << "the file and line first";
    EXPECT_NE(what.find(c.field), std::string::npos);
  }
  const std::string no_azimuth = replaced(nested, "\"beam_azimuth_angles\"", "\"beam_azimuths\"");
  EXPECT_NE(error_of(no_azimuth).find("beam_azimuth_angles"), std::string::npos);
  const std::string per_pixel = replaced(good, "[4.2000000000000002, ", "[[4.2, 1.0], ");
  EXPECT_NE(error_of(per_pixel).find("per-pixel"), std::string::npos) << error_of(per_pixel);
}

TEST_F(OusterMetadata, ModelFromTheProductLineOrTheOptions) {
  const ot::Spec s;
  const std::string text = ot::metadata_json(s, false);
  EXPECT_EQ(error_of(text, "OS-1-32"), "") << "OS-1-32-G is an OS-1-32";
  const std::string other = error_of(text, "OS-0-128");
  EXPECT_NE(other.find("OS-1-32-G"), std::string::npos) << other;
  EXPECT_NE(other.find("OS-0-128"), std::string::npos) << other;

  const std::string unnamed = replaced(text, "\"prod_line\": \"OS-1-32-G\"", "\"prod_sn\": \"1\"");
  DecoderOptions o;
  o.calibration_text = unnamed;
  EXPECT_EQ(make_decoder(Vendor::Ouster, o)->info().model, "OS-?-32");
  o.model = "OS-2-32";
  EXPECT_EQ(make_decoder(Vendor::Ouster, o)->info().model, "OS-2-32");
  o.model = "OS-1-64";
  EXPECT_THROW(make_decoder(Vendor::Ouster, o), Error) << "64 beams named, 32 described";
}

TEST_F(OusterMetadata, ReducedMetadataTakesTheSdkDefaults) {
  // What an old OS-1-64 gave: the beam angles and the mode, nothing else. LEGACY packets of 16
  // columns, 64 beams (the angles), the first generation's beam origin (12.163 mm), the default
  // lidar_to_sensor.
  ot::Spec s;
  s.pixels = 64;
  s.altitude.clear();
  s.azimuth.clear();
  for (int i = 0; i < 64; ++i) {
    s.altitude.push_back(16.6 - i * 0.52);
    s.azimuth.push_back(i % 2 ? -1.1 : 3.1);
  }
  s.origin_mm = 12.163;
  const std::string text = "{\"beam_altitude_angles\": " + ot::json_list(s.altitude) +
                           ",\n \"beam_azimuth_angles\": " + ot::json_list(s.azimuth) + ",\n \"lidar_mode\": \"512x10\"}";
  DecoderOptions o;
  o.calibration_text = text;
  auto d = make_decoder(Vendor::Ouster, o);
  EXPECT_EQ(d->info().channels, 64);
  std::vector<Sweep> out;
  const auto packets = ot::frame(s, 1, 1000, 195'312, [](int m, int row) {
    std::array<ot::Return, 2> r{};
    if (m == 64 && row == 4) r[0] = {20000, 9};
    return r;
  });
  for (const auto& p : packets) d->add(p, 0, out);
  ASSERT_EQ(out.size(), 1u);
  ASSERT_EQ(out[0].points.size(), 1u);
  // Column 64 of 512: encoder 45 degrees; beam 4 3.1 further on, 16.6 - 4 * 0.52 up.
  const double alt = (16.6 - 4 * 0.52) * M_PI / 180, az = -(45 + 3.1) * M_PI / 180, enc = -45 * M_PI / 180;
  const double along = 20000 - 12.163;
  const Point& p = out[0].points[0];
  EXPECT_NEAR(p.x, -(12.163 * std::cos(enc) + along * std::cos(alt) * std::cos(az)) * 1e-3, 1e-6);
  EXPECT_NEAR(p.y, -(12.163 * std::sin(enc) + along * std::cos(alt) * std::sin(az)) * 1e-3, 1e-6);
  EXPECT_NEAR(p.z, (along * std::sin(alt) + 36.18) * 1e-3, 1e-6);
  EXPECT_EQ(d->counts().skipped, 0u);
}

}  // namespace
}  // namespace pl::lidar
