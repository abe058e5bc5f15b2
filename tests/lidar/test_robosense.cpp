// The RoboSense decoder on packets written from the published layouts (robosense_packets.hpp): returns
// back to their points, sweeps cut at the cut azimuth, the model told by the packets, angles from the
// angle file or the DIFOP packet (and the error without either), damaged packets skipped.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "error_of.hpp"
#include "../common/test_util.hpp"
#include "pl/common/error.hpp"
#include "pl/lidar/decoder.hpp"
#include "robosense_packets.hpp"

namespace pl::lidar {
namespace {

using rs_test::Block;
using rs_test::Kind;

constexpr double kDeg = M_PI / 180.0;
constexpr std::int64_t kHeliosUs = 1700000000250000;  // a Helios packet's time: s and µs since 1970

std::vector<double> descending16() {  // 15°, 13°, ... -15°: laser l is channel 15 - l
  std::vector<double> e;
  for (int l = 0; l < 16; ++l) e.push_back(15 - 2 * l);
  return e;
}
std::vector<double> alternating16() {  // the Helios-16P's offsets alternate about ±4°
  std::vector<double> h;
  for (int l = 0; l < 16; ++l) h.push_back(l % 2 ? 3.5 : -4.0);
  return h;
}

std::unique_ptr<PacketDecoder> decoder_with_file(const test::TempDir& dir, const std::string& text, DecoderOptions o = {}) {
  test::write_file(dir / "angle.csv", text);
  o.calibration_path = dir / "angle.csv";
  return make_decoder(Vendor::RoboSense, o);
}

std::vector<Sweep> feed(PacketDecoder& d, const std::vector<std::string>& packets, bool finish = true) {
  std::vector<Sweep> out;
  for (const auto& p : packets) d.add(p, 1, out);
  if (finish) d.finish(out);
  return out;
}

const Point* find(const Sweep& s, std::uint16_t channel, ReturnType type = ReturnType::Strongest, float distance = -1) {
  for (const Point& p : s.points)
    if (p.channel == channel && p.return_type == type && (distance < 0 || std::abs(p.distance_m - distance) < 1e-3f)) return &p;
  return nullptr;
}

// Where the sensor's frame puts a return: the lens sits `lens` from the axis, azimuth runs clockwise.
void expect_at(const Point& p, double d, double elevation, int azimuth_cdeg, int firing_cdeg, double lens) {
  const double h = azimuth_cdeg * 0.01 * kDeg, f = firing_cdeg * 0.01 * kDeg, e = elevation * kDeg;
  EXPECT_NEAR(p.x, d * std::cos(e) * std::cos(h) + lens * std::cos(f), 1e-3);
  EXPECT_NEAR(p.y, -d * std::cos(e) * std::sin(h) - lens * std::sin(f), 1e-3);
  EXPECT_NEAR(p.z, d * std::sin(e), 1e-3);
  EXPECT_NEAR(p.azimuth_deg, azimuth_cdeg * 0.01, 1e-4);
  EXPECT_NEAR(p.elevation_deg, elevation, 1e-4);
  EXPECT_NEAR(p.distance_m, d, 1e-4);
}

TEST(RoboSenseHelios16P, WrittenReturnsDecodeToTheirPoints) {
  test::TempDir dir;
  auto d = decoder_with_file(dir, rs_test::angle_file(descending16(), alternating16()));
  auto blocks = rs_test::turning(1000, 20);
  blocks[0].returns = {{0, 4000, 50}, {16, 4000, 60}, {5, 2000, 70}};
  blocks[11].returns = {{31, 8000, 255}};
  const auto sweeps = feed(*d, {rs_test::difop(Kind::Helios, 600, 0x04, {}), rs_test::msop(Kind::Helios, blocks, kHeliosUs)});
  ASSERT_EQ(sweeps.size(), 1u);
  const Sweep& s = sweeps[0];
  ASSERT_EQ(s.points.size(), 4u);
  EXPECT_EQ(s.stamp_ns, kHeliosUs * 1000);
  const auto info = d->info();
  EXPECT_EQ(info.model, "Helios-16P");
  EXPECT_EQ(info.channels, 16);
  EXPECT_DOUBLE_EQ(info.rotation_hz, 10.0);
  ASSERT_EQ(info.elevation_deg.size(), 16u);
  EXPECT_NEAR(info.elevation_deg[0], -15, 1e-6);
  EXPECT_NEAR(info.elevation_deg[15], 15, 1e-6);

  // Laser 0 (15°, -4.00°): its first firing at the block's azimuth, its second half a step later.
  const Point* a = find(s, 15, ReturnType::Strongest, 10.0f);
  ASSERT_TRUE(a);
  expect_at(*a, 10.0, 15, 1000 - 400, 1000, 0.03498);
  EXPECT_EQ(a->intensity, 50);
  EXPECT_DOUBLE_EQ(a->time_s, 0.0);
  const Point* b = nullptr;
  for (const Point& p : s.points) b = p.intensity == 60 ? &p : b;
  ASSERT_TRUE(b);
  expect_at(*b, 10.0, 15, 1010 - 400, 1010, 0.03498);
  EXPECT_NEAR(b->time_s, 27.78e-6, 1e-9);
  // Laser 5 (5°, +3.50°) fires 17.08 µs into the 111.12 µs firing table: 3/20 of the step.
  const Point* c = find(s, 10);
  ASSERT_TRUE(c);
  expect_at(*c, 5.0, 5, 1003 + 350, 1003, 0.03498);
  EXPECT_EQ(c->intensity, 70);
  // The last block has no next one: the nominal 0.20° step at 600 rpm.
  const Point* e = find(s, 0);
  ASSERT_TRUE(e);
  expect_at(*e, 20.0, -15, 1237 + 350, 1237, 0.03498);
  EXPECT_NEAR(e->time_s, (11 * 55.56 + 99.46 / 2) * 1e-6, 2e-9);
}

TEST(RoboSenseHelios16P, TheDifopSaysTheReturnType) {
  for (const auto& [code, type] : {std::pair{0x04, ReturnType::Strongest}, {0x05, ReturnType::Last}, {0x06, ReturnType::First}}) {
    test::TempDir dir;
    auto d = decoder_with_file(dir, rs_test::angle_file(descending16(), alternating16()));
    auto blocks = rs_test::turning(1000, 20);
    blocks[3].returns = {{2, 4000, 1}};
    const auto sweeps = feed(*d, {rs_test::difop(Kind::Helios, 600, code, {}), rs_test::msop(Kind::Helios, blocks, kHeliosUs)});
    ASSERT_EQ(sweeps.size(), 1u);
    ASSERT_EQ(sweeps[0].points.size(), 1u);
    EXPECT_EQ(sweeps[0].points[0].return_type, type) << code;
  }
}

TEST(RoboSenseHelios16P, DualReturnsFillTheBlocksHalves) {
  test::TempDir dir;
  auto d = decoder_with_file(dir, rs_test::angle_file(descending16(), alternating16()));
  auto blocks = rs_test::turning(2000, 20);
  blocks[1].returns = {{4, 4000, 10}, {20, 6000, 20}};  // laser 4's strongest and second strongest
  const auto sweeps = feed(*d, {rs_test::difop(Kind::Helios, 600, 0x00, {}), rs_test::msop(Kind::Helios, blocks, kHeliosUs)});
  ASSERT_EQ(sweeps.size(), 1u);
  const Point* a = find(sweeps[0], 11, ReturnType::Strongest);
  const Point* b = find(sweeps[0], 11, ReturnType::SecondStrongest);
  ASSERT_TRUE(a && b);
  EXPECT_FLOAT_EQ(a->azimuth_deg, b->azimuth_deg);  // one firing: one azimuth, one time
  EXPECT_DOUBLE_EQ(a->time_s, b->time_s);
  EXPECT_NEAR(a->time_s, (55.56 + 13.26) * 1e-6, 1e-9);
  EXPECT_NEAR(b->distance_m, 15.0, 1e-4);
}

TEST(RoboSenseRs16, WrittenReturnsDecodeWithTheDifopsAngles) {
  std::vector<double> elevation;  // 1-8 point down, 9-16 up (the manual's order here: 15° first)
  for (int l = 0; l < 8; ++l) elevation.push_back(-15 + 2 * l);
  for (int l = 0; l < 8; ++l) elevation.push_back(15 - 2 * l);
  DecoderOptions o;
  auto d = make_decoder(Vendor::RoboSense, o);  // no model, no file: the packets tell
  auto blocks = rs_test::turning(30000, 40);    // two firings a block: 0.40° at 600 rpm
  blocks[0].returns = {{0, 2000, 9}, {17, 3000, 8}};
  blocks[2].returns = {{8, 1000, 7}};
  const auto sweeps = feed(*d, {rs_test::msop(Kind::Rs16, blocks, 0, 1234567), rs_test::difop(Kind::Rs16, 600, 0x01, elevation)});
  ASSERT_EQ(sweeps.size(), 1u);
  const Sweep& s = sweeps[0];
  ASSERT_EQ(s.points.size(), 3u);
  EXPECT_EQ(s.stamp_ns, (1709294400LL + 1) * 1000000000 + 234567000);  // 2024-03-01 12:00:01.234567 UTC
  EXPECT_EQ(d->info().model, "RS-LiDAR-16");
  const Point* a = find(s, 0);
  ASSERT_TRUE(a);
  expect_at(*a, 10.0, -15, 30000, 30000, 0.03825);
  // Laser 1's second firing: 58.30 µs of the block's 111 µs, 21/100 of its 0.40°.
  const Point* b = find(s, 1);
  ASSERT_TRUE(b);
  expect_at(*b, 15.0, -13, 30021, 30021, 0.03825);
  EXPECT_NEAR(b->time_s, 58.30e-6, 1e-9);
  // Laser 9 points 15° up: the top channel. Its block starts 2 x 111 µs in, it fires 22.4 µs later.
  const Point* c = find(s, 15);
  ASSERT_TRUE(c);
  expect_at(*c, 5.0, 15, 30088, 30088, 0.03825);
  EXPECT_NEAR(c->time_s, 244.4e-6, 1e-9);
}

TEST(RoboSense, SweepsEndWhereTheAzimuthPassesTheCut) {
  for (const double cut : {0.0, 1.0}) {
    test::TempDir dir;
    DecoderOptions o;
    o.cut_azimuth_deg = cut;
    auto d = decoder_with_file(dir, rs_test::angle_file(descending16(), {}), o);
    std::vector<std::string> packets;  // no DIFOP: with an angle file, packets decode as they come
    for (int n = 0; n < 3; ++n) {
      auto blocks = rs_test::turning(35760 + 240 * n, 20);
      for (auto& b : blocks) b.returns = {{0, 4000, static_cast<std::uint8_t>(b.azimuth / 200)}};
      packets.push_back(rs_test::msop(Kind::Helios, blocks, kHeliosUs + 667 * n));
    }
    auto sweeps = feed(*d, packets, false);
    EXPECT_EQ(sweeps.size(), 1u) << cut;  // closed by the add() that passed the cut
    d->finish(sweeps);
    ASSERT_EQ(sweeps.size(), 2u) << cut;
    // Blocks at 357.60° + 0.20° k: the first at or past the cut opens the second sweep.
    const int first = static_cast<int>((36000 + cut * 100 - 35760) / 20);
    EXPECT_EQ(sweeps[0].points.size(), static_cast<std::size_t>(first)) << cut;
    EXPECT_EQ(sweeps[1].points.size(), static_cast<std::size_t>(36 - first)) << cut;
    const std::int64_t packet = first / 12, block = first % 12;
    EXPECT_EQ(sweeps[1].stamp_ns, (kHeliosUs + 667 * packet) * 1000 + std::llround(block * 55.56 * 1000)) << cut;
    EXPECT_NEAR(sweeps[1].points.front().azimuth_deg, cut, 1e-4);
  }
}

TEST(RoboSense, TheModelIsToldByThePacketsOrTheAngleFile) {
  test::TempDir dir;
  std::vector<double> e32(32);
  for (int l = 0; l < 32; ++l) e32[static_cast<std::size_t>(l)] = 15.5 - l;
  auto d = decoder_with_file(dir, rs_test::angle_file(e32, {}));
  auto blocks = rs_test::turning(500, 20);
  blocks[0].returns = {{0, 4000, 1}, {1, 4000, 1}};  // one firing: two lasers
  blocks[1].returns = {{0, 4400, 1}};
  auto sweeps = feed(*d, {rs_test::msop(Kind::Helios, blocks, kHeliosUs), rs_test::difop(Kind::Helios, 1200, 0x04, {})});
  EXPECT_EQ(d->info().model, "Helios-32");
  EXPECT_EQ(d->info().channels, 32);
  EXPECT_DOUBLE_EQ(d->info().rotation_hz, 20.0);
  ASSERT_EQ(sweeps.size(), 1u);
  ASSERT_EQ(sweeps[0].points.size(), 3u);
  EXPECT_EQ(sweeps[0].points[1].channel, 30);
  EXPECT_NEAR(sweeps[0].points[1].time_s, 1.57e-6, 1e-9);

  // A Helios without a model or an angle file: the packets do not say which.
  auto bare = make_decoder(Vendor::RoboSense, {});
  std::vector<Sweep> out;
  try {
    bare->add(rs_test::msop(Kind::Helios, rs_test::turning(0, 20), kHeliosUs), 1, out);
    FAIL() << "a Helios of unknown laser count was decoded";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("--lidar-model Helios-16P"), std::string::npos) << e.what();
  }
}

TEST(RoboSense, HeliosDualReturnsComeInBlockPairs) {
  test::TempDir dir;
  std::vector<double> e32(32);
  for (int l = 0; l < 32; ++l) e32[static_cast<std::size_t>(l)] = 15.5 - l;
  DecoderOptions o;
  o.model = "RS-Helios";
  auto d = decoder_with_file(dir, rs_test::angle_file(e32, {}), o);
  std::vector<Block> blocks(12);
  for (int k = 0; k < 12; ++k) blocks[static_cast<std::size_t>(k)].azimuth = 500 + 20 * (k / 2);
  blocks[2].returns = {{3, 4000, 1}};
  blocks[3].returns = {{3, 4400, 2}};
  const auto sweeps = feed(*d, {rs_test::difop(Kind::Helios, 600, 0x00, {}), rs_test::msop(Kind::Helios, blocks, kHeliosUs)});
  ASSERT_EQ(sweeps.size(), 1u);
  ASSERT_EQ(sweeps[0].points.size(), 2u);
  const Point &a = sweeps[0].points[0], &b = sweeps[0].points[1];
  EXPECT_EQ(a.return_type, ReturnType::Strongest);
  EXPECT_EQ(b.return_type, ReturnType::SecondStrongest);
  EXPECT_NEAR(a.azimuth_deg, 5.21, 1e-4);  // 4.72 µs of 55.56: 1/20 of the pair's 0.20° (truncated)
  EXPECT_FLOAT_EQ(a.azimuth_deg, b.azimuth_deg);
  EXPECT_NEAR(b.time_s, (55.56 + 4.72) * 1e-6, 1e-9);
}

TEST(RoboSense, PacketsBeforeTheFirstDifopDecodeWithItsAngles) {
  const std::vector<double> e = descending16(), h = alternating16();
  DecoderOptions o;
  o.model = "Helios-16P";
  auto blocks = rs_test::turning(100, 20);
  blocks[4].returns = {{7, 5000, 3}};
  const std::string msop = rs_test::msop(Kind::Helios, blocks, kHeliosUs), difop = rs_test::difop(Kind::Helios, 600, 0x04, e, h);
  auto late = make_decoder(Vendor::RoboSense, o), early = make_decoder(Vendor::RoboSense, o);
  std::vector<Sweep> out;
  late->add(msop, 1, out);
  EXPECT_TRUE(late->info().elevation_deg.empty());  // no angles yet
  const auto a = feed(*late, {difop}), b = feed(*early, {difop, msop});
  ASSERT_EQ(a.size(), 1u);
  ASSERT_EQ(b.size(), 1u);
  ASSERT_EQ(a[0].points.size(), 1u);
  ASSERT_EQ(b[0].points.size(), 1u);
  EXPECT_EQ(a[0].points[0].x, b[0].points[0].x);
  EXPECT_EQ(a[0].points[0].channel, 8);  // laser 7: 1°
  expect_at(a[0].points[0], 12.5, 1, 180 + 4 + 350, 184, 0.03498);
}

TEST(RoboSense, WithoutDifopOrAngleFileTheErrorNamesTheFix) {
  DecoderOptions o;
  const std::string msop = rs_test::msop(Kind::Rs16, rs_test::turning(0, 40), 0);
  auto d = make_decoder(Vendor::RoboSense, o);
  std::vector<Sweep> out;
  d->add(rs_test::difop(Kind::Rs16, 600, 0x01, {}), 1, out);  // a DIFOP with an empty angle table
  for (int i = 0; i < 3999; ++i) d->add(msop, 1, out);
  try {
    d->add(msop, 1, out);
    FAIL() << "4000 packets were held without angles";
  } catch (const Error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("RS-LiDAR-16"), std::string::npos) << what;
    EXPECT_NE(what.find("--lidar-calibration"), std::string::npos) << what;
  }
  auto short_one = make_decoder(Vendor::RoboSense, o);
  short_one->add(msop, 1, out);
  EXPECT_THROW(short_one->finish(out), Error);
  EXPECT_TRUE(out.empty());
}

TEST(RoboSense, DamagedAndForeignPacketsAreSkippedAndCounted) {
  test::TempDir dir;
  DecoderOptions o;
  o.model = "Helios-16P";
  auto d = decoder_with_file(dir, rs_test::angle_file(descending16(), {}), o);
  auto blocks = rs_test::turning(1000, 20);
  blocks[0].returns = {{0, 4000, 1}};
  const std::string good = rs_test::msop(Kind::Helios, blocks, kHeliosUs);
  std::string no_flag = good, far_azimuth = good, unit = good;
  no_flag[42 + 500 + 1] = 0x00;
  far_azimuth[42 + 300 + 2] = static_cast<char>(0x8C), far_azimuth[42 + 300 + 3] = static_cast<char>(0xA0);  // 360.00°
  unit[17] = 7;
  const std::vector<std::pair<std::string, std::string>> bad = {
      {good.substr(0, 1206), "1248 bytes"},
      {good.substr(0, 1000), "1248 bytes"},
      {std::string(1248, '\0'), "neither header"},
      {no_flag, "FF EE"},
      {far_azimuth, "359.99"},
      {unit, "distance unit"},
      {rs_test::msop(Kind::Rs16, blocks, 0), "RS-LiDAR-16 MSOP packet among Helios"},
      {rs_test::difop(Kind::Helios, 600, 4, {}).substr(0, 1247), "1248 bytes"}};
  std::vector<Sweep> out;
  d->add(rs_test::difop(Kind::Helios, 600, 0x04, {}), 1, out);
  for (const auto& [packet, why] : bad) {
    d->add(packet, 1, out);
    EXPECT_NE(d->counts().last_problem.find(why), std::string::npos) << d->counts().last_problem;
  }
  d->add(good, 1, out);
  d->finish(out);
  EXPECT_EQ(d->counts().packets, bad.size() + 2);
  EXPECT_EQ(d->counts().skipped, bad.size());
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].points.size(), 1u);
}

TEST(RoboSense, ReturnsOutsideTheRangeLimitsAreLeftOut) {
  test::TempDir dir;
  DecoderOptions o;
  o.min_range_m = 1.0;
  o.max_range_m = 15.0;
  auto d = decoder_with_file(dir, rs_test::angle_file(descending16(), {}), o);
  auto blocks = rs_test::turning(1000, 20);
  blocks[0].returns = {{0, 200, 1}, {1, 4000, 2}, {2, 8000, 3}};  // 0.5 m, 10 m, 20 m
  const auto sweeps = feed(*d, {rs_test::difop(Kind::Helios, 600, 0x04, {}), rs_test::msop(Kind::Helios, blocks, kHeliosUs)});
  ASSERT_EQ(sweeps.size(), 1u);
  ASSERT_EQ(sweeps[0].points.size(), 1u);
  EXPECT_EQ(sweeps[0].points[0].intensity, 2);
}

TEST(RoboSense, AngleFileErrorsNameTheFileLineAndField) {
  test::TempDir dir;
  const std::string good = rs_test::angle_file(descending16(), alternating16());
  auto error = [&](const std::string& text, const std::string& model = "") {
    test::write_file(dir / "angle.csv", text);
    DecoderOptions o;
    o.calibration_path = dir / "angle.csv";
    o.model = model;
    return pl::test::error_of([&] { make_decoder(Vendor::RoboSense, o); });
  };
  const std::string second_line_bad = "15,-4\nabc,3.5\n" + good.substr(good.find('\n', good.find('\n') + 1) + 1);
  EXPECT_NE(error(second_line_bad).find(dir / "angle.csv:2: expected the elevation"), std::string::npos)
      << error(second_line_bad);
  EXPECT_NE(error("15,-4,1\n").find(":1: expected \"elevation,azimuth offset\""), std::string::npos);
  EXPECT_NE(error("15,95\n").find("the azimuth offset in degrees"), std::string::npos);
  EXPECT_NE(error(good + "1,1\n").find("16 (RS-LiDAR-16, Helios-16P) or 32"), std::string::npos);
  EXPECT_NE(error("\n\n").find("no angles"), std::string::npos);
  EXPECT_NE(error(good, "Helios-32").find("32 lines"), std::string::npos);
  EXPECT_EQ(error(good), "");
  DecoderOptions missing;
  missing.calibration_path = dir / "none.csv";
  EXPECT_THROW(make_decoder(Vendor::RoboSense, missing), Error);
  DecoderOptions unknown;
  unknown.model = "Helios-64";
  EXPECT_THROW(make_decoder(Vendor::RoboSense, unknown), Error);
}

TEST(RoboSense, AngleFileValuesAreReadAsTheMakersDriverReadsThem) {
  // Single precision, then truncated to 0.01°: 8.90 is 8.8999996 and becomes 8.89°.
  std::vector<double> e = descending16();
  e[3] = 8.90;
  DecoderOptions o;
  o.model = "Helios-16P";
  o.calibration_text = rs_test::angle_file(e, {});
  const auto info = make_decoder(Vendor::RoboSense, o)->info();
  ASSERT_EQ(info.elevation_deg.size(), 16u);
  EXPECT_NEAR(info.elevation_deg[12], 8.89, 1e-6);
}

}  // namespace
}  // namespace pl::lidar
