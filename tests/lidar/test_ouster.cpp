// The Ouster decoder on packets written from the published layouts (ouster_packets.hpp): points
// where the SDK's XYZ table puts them, one sweep per frame, late, damaged and foreign packets
// skipped and counted.
#include <gtest/gtest.h>

#include <cmath>
#include <map>

#include "ouster_packets.hpp"
#include "pl/common/error.hpp"
#include "pl/lidar/decoder.hpp"

namespace pl::lidar {
namespace {

namespace ot = pl::test::ouster;

constexpr std::uint64_t kDt = 195'312;  // ns between columns at 512 x 10
constexpr std::int64_t kReceived = 1'700'000'000'000'000'000;

double rad(double deg) { return deg * M_PI / 180.0; }

// Where a range of beam `row` in column `m` lies in the sensor frame, metres: the beam leaves from
// the lidar origin's offset along the column's encoder direction (clockwise from the lidar frame's
// +x), and lidar_to_sensor takes the point to the sensor frame.
std::array<double, 3> expected(const ot::Spec& s, int m, int row, double range_mm) {
  const double encoder = 360.0 * m / s.columns;
  const double beam = encoder + s.azimuth[static_cast<std::size_t>(row)];
  const double alt = rad(s.altitude[static_cast<std::size_t>(row)]);
  const double along = range_mm - s.origin_mm;
  const double l[3] = {s.origin_mm * std::cos(rad(-encoder)) + along * std::cos(alt) * std::cos(rad(-beam)),
                       s.origin_mm * std::sin(rad(-encoder)) + along * std::cos(alt) * std::sin(rad(-beam)),
                       along * std::sin(alt)};
  const auto& t = s.lidar_to_sensor;
  std::array<double, 3> out{};
  for (int r = 0; r < 3; ++r) out[r] = (t[r * 4] * l[0] + t[r * 4 + 1] * l[1] + t[r * 4 + 2] * l[2] + t[r * 4 + 3]) * 1e-3;
  return out;
}

// The test pattern: a return on every seventh pixel, its range and reflectivity from its place.
std::array<ot::Return, 2> pattern(int m, int row) {
  std::array<ot::Return, 2> r{};
  if ((m + row) % 7 != 0) return r;
  r[0] = {static_cast<std::uint32_t>(1000 + 40 * m + 8 * row), static_cast<std::uint8_t>((3 * m + row) % 256)};
  if ((m + row) % 5 == 0) r[1] = {r[0].range_mm + 4000, static_cast<std::uint8_t>(255 - r[0].reflectivity)};
  return r;
}

std::unique_ptr<PacketDecoder> decoder(const ot::Spec& s, bool nested = false, DecoderOptions o = {}) {
  o.calibration_text = ot::metadata_json(s, nested);
  return make_decoder(Vendor::Ouster, o);
}

std::vector<Sweep> feed(PacketDecoder& d, const std::vector<std::string>& packets, std::int64_t received = kReceived) {
  std::vector<Sweep> out;
  for (std::size_t i = 0; i < packets.size(); ++i) d.add(packets[i], received + static_cast<std::int64_t>(i) * 1'000'000, out);
  return out;
}

// Every point of `sweep` is the pattern's pixel of its channel and time, where the formula puts it.
void expect_pattern(const ot::Spec& s, const Sweep& sweep, bool second_returns) {
  std::size_t wanted = 0;
  for (int m = 0; m < s.columns; ++m)
    for (int row = 0; row < s.pixels; ++row) {
      const auto r = pattern(m, row);
      wanted += (r[0].range_mm > 0) + (second_returns && r[1].range_mm > 0);
    }
  ASSERT_EQ(sweep.points.size(), wanted);
  for (const Point& p : sweep.points) {
    const int m = static_cast<int>(std::lround(p.time_s * 1e9 / kDt));
    ASSERT_NEAR(p.time_s, m * kDt * 1e-9, 1e-12);
    const auto r = pattern(m, p.channel);
    const bool second = p.return_type == ReturnType::SecondStrongest;
    ASSERT_EQ(p.return_type, second ? ReturnType::SecondStrongest : ReturnType::Strongest);
    const ot::Return& ret = r[second ? 1 : 0];
    ASSERT_GT(ret.range_mm, 0u) << "a point where none was written: column " << m << " row " << p.channel;
    const auto want = expected(s, m, p.channel, ret.range_mm);
    EXPECT_NEAR(p.x, want[0], 1e-5);
    EXPECT_NEAR(p.y, want[1], 1e-5);
    EXPECT_NEAR(p.z, want[2], 1e-5);
    EXPECT_EQ(p.intensity, ret.reflectivity);
    EXPECT_NEAR(p.distance_m, ret.range_mm * 1e-3, 1e-6);
    EXPECT_NEAR(p.elevation_deg, s.altitude[p.channel], 1e-5);
    EXPECT_NEAR(std::remainder(p.azimuth_deg - (360.0 * m / s.columns + s.azimuth[p.channel]), 360.0), 0, 1e-4);
  }
}

TEST(OusterDecoder, LegacyFrameDecodesToItsPoints) {
  const ot::Spec s;
  auto d = decoder(s);
  const auto sweeps = feed(*d, ot::frame(s, 9, 5'000'000'000, kDt, pattern));
  ASSERT_EQ(sweeps.size(), 1u) << "a complete frame is a sweep at its last packet";
  expect_pattern(s, sweeps[0], false);
  EXPECT_EQ(sweeps[0].stamp_ns, kReceived) << "a clock since power-up: the receive time of the first column's packet";
  EXPECT_EQ(d->counts().skipped, 0u);
  EXPECT_EQ(d->counts().sweeps, 1u);
  EXPECT_EQ(d->counts().points, sweeps[0].points.size());
}

TEST(OusterDecoder, EachProfileDecodesToItsPoints) {
  for (ot::Profile profile : {ot::Profile::Single, ot::Profile::Dual, ot::Profile::LowData}) {
    SCOPED_TRACE(ot::profile_text(profile));
    ot::Spec s;
    s.profile = profile;
    s.prod_line = "OS-0-32-U1";
    s.origin_mm = 27.67;
    auto d = decoder(s, true);
    const auto sweeps = feed(*d, ot::frame(s, 300, 5'000'000'000, kDt, pattern));
    ASSERT_EQ(sweeps.size(), 1u);
    expect_pattern(s, sweeps[0], profile == ot::Profile::Dual);
  }
}

TEST(OusterDecoder, FlatAndNestedMetadataAgree) {
  ot::Spec s;
  s.lidar_to_sensor = {0, -1, 0, 10, 1, 0, 0, -5, 0, 0, 1, 40, 0, 0, 0, 1};  // turned a quarter, moved
  const auto packets = ot::frame(s, 1, 5'000'000'000, kDt, pattern);
  auto flat = feed(*decoder(s, false), packets);
  auto nested = feed(*decoder(s, true), packets);
  ASSERT_EQ(flat.size(), 1u);
  ASSERT_EQ(nested.size(), 1u);
  expect_pattern(s, flat[0], false);
  expect_pattern(s, nested[0], false);
}

TEST(OusterDecoder, SensorFrameFacesForwardLeftUp) {
  // Beam 0 level and without azimuth offset: at encoder 0 it faces the connector (the sensor
  // frame's -x), a quarter turn later (clockwise seen from above) the sensor frame's +y.
  ot::Spec s;
  s.altitude[0] = 0;
  s.azimuth[0] = 0;
  auto d = decoder(s);
  const auto sweeps = feed(*d, ot::frame(s, 1, 5'000'000'000, kDt, [](int m, int row) {
    std::array<ot::Return, 2> r{};
    if (row == 0 && (m == 0 || m == 128)) r[0] = {10000, 50};
    return r;
  }));
  ASSERT_EQ(sweeps.size(), 1u);
  ASSERT_EQ(sweeps[0].points.size(), 2u);
  const Point& back = sweeps[0].points[0];
  const Point& left = sweeps[0].points[1];
  EXPECT_NEAR(back.x, -10.0, 1e-6);
  EXPECT_NEAR(back.y, 0.0, 1e-6);
  EXPECT_NEAR(back.z, 0.03618, 1e-6);
  EXPECT_NEAR(back.azimuth_deg, 0.0, 1e-6);
  EXPECT_NEAR(left.x, 0.0, 1e-6);
  EXPECT_NEAR(left.y, 10.0, 1e-6);
  EXPECT_NEAR(left.azimuth_deg, 90.0, 1e-6);
  EXPECT_NEAR(left.time_s, 128 * kDt * 1e-9, 1e-12);
}

TEST(OusterDecoder, SensorInfoComesFromTheMetadata) {
  const ot::Spec s;
  const SensorInfo info = decoder(s)->info();
  EXPECT_EQ(info.vendor, "Ouster");
  EXPECT_EQ(info.model, "OS-1-32-G");
  EXPECT_EQ(info.channels, 32);
  EXPECT_EQ(info.rotation_hz, 10.0);
  ASSERT_EQ(info.elevation_deg.size(), 32u);
  EXPECT_EQ(info.elevation_deg[3], s.altitude[3]);
  ASSERT_EQ(info.ring_of_channel.size(), 32u);
  for (std::size_t c = 0; c < 32; ++c) EXPECT_EQ(info.ring_of_channel[c], 31 - c) << "row 0 is the top beam";
}

TEST(OusterDecoder, OneSweepPerFrame) {
  const ot::Spec s;
  auto d = decoder(s);
  auto f10 = ot::frame(s, 10, 5'000'000'000, kDt, pattern);
  auto f11 = ot::frame(s, 11, 5'100'000'000, kDt, pattern);
  auto f12 = ot::frame(s, 12, 5'200'000'000, kDt, pattern);
  std::vector<Sweep> out;
  for (std::size_t i = 0; i + 1 < f10.size(); ++i) d->add(f10[i], kReceived, out);  // its last packet lost
  EXPECT_TRUE(out.empty()) << "a frame is open until its last packet or the next frame";
  d->add(f11[0], kReceived, out);
  ASSERT_EQ(out.size(), 1u) << "the next frame's first packet ends it";
  EXPECT_LT(out[0].points.size(), 512u * 32 / 7);
  d->add(f10.back(), kReceived, out);  // late
  EXPECT_EQ(d->counts().skipped, 1u);
  EXPECT_NE(d->counts().last_problem.find("late packet of frame 10"), std::string::npos) << d->counts().last_problem;
  d->add(f11[0], kReceived, out);  // twice
  EXPECT_EQ(d->counts().skipped, 2u);
  for (std::size_t i = 1; i < f11.size(); ++i) d->add(f11[i], kReceived, out);
  ASSERT_EQ(out.size(), 2u);
  expect_pattern(s, out[1], false);
  d->add(f11[5], kReceived, out);  // after its frame ended
  EXPECT_EQ(d->counts().skipped, 3u);
  for (std::size_t i = 0; i < 3; ++i) d->add(f12[i], kReceived, out);
  d->finish(out);
  ASSERT_EQ(out.size(), 3u) << "finish() gives the open frame";
  EXPECT_EQ(d->counts().sweeps, 3u);
}

TEST(OusterDecoder, FrameIdsWrapAndRestart) {
  const ot::Spec s;
  auto d = decoder(s);
  std::vector<Sweep> out;
  for (std::uint16_t id : {65535, 0, 40000}) {  // wraps; then a jump back (a restarted sensor)
    const auto f = ot::frame(s, id, 5'000'000'000, kDt, pattern);
    for (std::size_t i = 0; i < 4; ++i) d->add(f[i], kReceived, out);
  }
  d->finish(out);
  EXPECT_EQ(out.size(), 3u);
  EXPECT_EQ(d->counts().skipped, 0u);
}

TEST(OusterDecoder, ColumnWindowEndsTheFrame) {
  ot::Spec s;
  s.window_first = 480;  // wraps: 480-511 and 0-63
  s.window_last = 63;
  auto d = decoder(s, true);
  const auto all = ot::frame(s, 3, 5'000'000'000, kDt, pattern);
  const std::vector<std::string> sent = {all[30], all[31], all[0], all[1], all[2], all[3]};  // as the sensor sends them
  const auto out = feed(*d, sent);
  ASSERT_EQ(out.size(), 1u) << "every packet of the window came";
  for (const Point& p : out[0].points) {
    const int m = static_cast<int>(std::lround(p.time_s * 1e9 / kDt));
    EXPECT_TRUE(m >= 480 || m <= 63) << m;
  }
}

TEST(OusterDecoder, StampIsTheSensorsClockWhenSynchronised) {
  const ot::Spec s;
  const std::uint64_t ptp = 1'650'000'000'123'456'789;
  const auto out = feed(*decoder(s), ot::frame(s, 1, ptp, kDt, pattern));
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].stamp_ns, static_cast<std::int64_t>(ptp));
  EXPECT_NEAR(out[0].points.back().time_s, 511 * kDt * 1e-9, 1e-12);
}

TEST(OusterDecoder, RangeLimitsLeaveReturnsOut) {
  const ot::Spec s;
  DecoderOptions o;
  o.min_range_m = 5;
  o.max_range_m = 10;
  const auto out = feed(*decoder(s, false, o), ot::frame(s, 1, 5'000'000'000, kDt, pattern));
  ASSERT_EQ(out.size(), 1u);
  ASSERT_FALSE(out[0].points.empty());
  for (const Point& p : out[0].points) {
    EXPECT_GE(p.distance_m, 5.0f);
    EXPECT_LE(p.distance_m, 10.0f);
  }
}

TEST(OusterDecoder, DamagedAndForeignPacketsAreSkippedAndCounted) {
  ot::Spec s;
  s.profile = ot::Profile::Single;
  auto d = decoder(s, true);
  const auto f = ot::frame(s, 4, 5'000'000'000, kDt, pattern);
  std::string wrong_type = f[0];
  wrong_type[0] = 2;
  std::string beyond = f[1];
  beyond[32 + 8] = static_cast<char>(0xFF);  // measurement id 0x??FF of a 512-column frame
  beyond[32 + 9] = static_cast<char>(0x7F);
  const std::vector<std::pair<std::string, std::string>> bad = {
      {f[0].substr(0, f[0].size() - 1), "bytes, not a"},
      {f[0] + "xy", "bytes, not a"},
      {std::string(48, '\1'), "IMU packet"},
      {std::string(1206, '\xff'), "bytes, not a"},
      {std::string(), "0 bytes"},
      {wrong_type, "packet type 2"},
      {beyond, "measurement id 32767"},
  };
  std::vector<Sweep> out;
  for (std::size_t i = 0; i < bad.size(); ++i) {
    d->add(bad[i].first, kReceived, out);
    EXPECT_EQ(d->counts().skipped, i + 1);
    EXPECT_NE(d->counts().last_problem.find(bad[i].second), std::string::npos) << d->counts().last_problem;
  }
  EXPECT_TRUE(out.empty());
  for (const auto& p : f) d->add(p, kReceived, out);
  ASSERT_EQ(out.size(), 1u);
  expect_pattern(s, out[0], false);
  EXPECT_EQ(d->counts().packets, bad.size() + f.size());
}

TEST(OusterDecoder, PacketsOfAnotherProfileAreNamed) {
  ot::Spec s;
  s.profile = ot::Profile::Single;
  const auto packets = ot::frame(s, 2, 5'000'000'000, kDt, pattern);
  s.profile = ot::Profile::Legacy;  // what the metadata says
  auto d = decoder(s);
  const auto out = feed(*d, packets);
  EXPECT_TRUE(out.empty());
  EXPECT_EQ(d->counts().skipped, packets.size());
  EXPECT_NE(d->counts().last_problem.find("the size of RNG19_RFL8_SIG16_NIR16 packets"), std::string::npos)
      << d->counts().last_problem;
}

TEST(OusterDecoder, OusterRosTrailingByteIsAccepted) {
  const ot::Spec s;
  auto packets = ot::frame(s, 2, 5'000'000'000, kDt, pattern);
  for (auto& p : packets) p.push_back('\0');  // as older ouster_ros drivers recorded them
  const auto out = feed(*decoder(s), packets);
  ASSERT_EQ(out.size(), 1u);
  expect_pattern(s, out[0], false);
}

}  // namespace
}  // namespace pl::lidar
