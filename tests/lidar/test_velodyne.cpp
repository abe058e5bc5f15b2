// The Velodyne decoder on packets written from the published layout (velodyne_packets.hpp): every
// point where the makers' formula puts it, at its firing's time, in the sweep of its firing's
// azimuth; dual returns; the model told by the packets; damaged packets skipped; calibration errors.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <functional>
#include <string>
#include <vector>

#include <unistd.h>

#include "error_of.hpp"
#include "pl/common/error.hpp"
#include "pl/lidar/decoder.hpp"
#include "velodyne_packets.hpp"

namespace pl::lidar {
namespace {

using namespace velodyne_test;

constexpr std::int64_t kHourNs = 472222LL * 3600 * 1'000'000'000;  // a top of the hour (2023-11-14 22:00 UTC)

using pl::test::error_of;

bool has(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

DecoderOptions options(const std::string& calibration, double cut_deg = 0) {
  DecoderOptions o;
  o.calibration_text = calibration;
  o.cut_azimuth_deg = cut_deg;
  o.min_range_m = 0.3;
  return o;
}

// One VLP-16 firing as written, and where the published timing and azimuth interpolation put it.
struct Firing {
  int laser;
  std::uint16_t distance;
  std::uint8_t intensity;
  double azimuth;      // the firing's in 0.01 degree, unwrapped over turns, before the laser's rot_correction
  double time_us;      // past the hour
};

// VLP-16 strongest-return packets of a sensor turning `step` (0.01 degree) per block from `a0`:
// a block every 110.592 us holding two sequences 55.296 us apart, a laser every 2.304 us.
std::vector<std::string> vlp16_stream(int packets, int a0, int step, double toh0_us, std::vector<Firing>& firings) {
  std::vector<std::string> out;
  for (int k = 0; k < packets; ++k) {
    PacketWriter w;
    const double toh_us = toh0_us + k * 12 * 110.592;
    w.tail(static_cast<std::uint32_t>(std::lround(toh_us)), kStrongest, kVlp16);
    for (int b = 0; b < 12; ++b) {
      const int n = k * 12 + b;
      w.block(b, kBank[0], static_cast<std::uint16_t>((a0 + step * n) % 36000));
      for (int s = 0; s < 2; ++s)
        for (int l = 0; l < 16; ++l) {
          const double in_block_us = s * 55.296 + l * 2.304;
          Firing f{l, static_cast<std::uint16_t>(n % 7 == 3 && l == 5 ? 0 : 600 + 37 * l + n % 50),
                   static_cast<std::uint8_t>((n + 3 * l) % 256), a0 + step * (n + in_block_us / 110.592),
                   std::round(toh_us) + b * 110.592 + in_block_us};
          w.ret(b, 16 * s + l, f.distance, f.intensity);
          firings.push_back(f);
        }
    }
    out.push_back(w.str());
  }
  return out;
}

double rot_deg(int laser) { return 0.5 * (laser % 4 - 1.5); }

TEST(VelodyneDecoder, EveryVlp16FiringWhereTheFormulaPutsIt) {
  const double cut = 90.13;  // within a block: its firings part between two sweeps
  auto d = make_decoder(Vendor::Velodyne, options(plain_calibration(16, 0.5), cut));
  std::vector<Firing> firings;
  const double toh0 = 1'234'567'000;  // us past the hour
  const auto packets = vlp16_stream(160, 35000, 40, toh0, firings);  // 2.1 turns from 350 degrees
  std::vector<Sweep> sweeps;
  for (std::size_t k = 0; k < packets.size(); ++k)
    d->add(packets[k], kHourNs + std::llround((toh0 + k * 1327.104) * 1000) + 400'000, sweeps);
  d->finish(sweeps);
  EXPECT_EQ(d->info().model, "VLP-16");
  EXPECT_EQ(d->counts().skipped, 0u);

  // The sweep of each firing: the turns its azimuth made past the cut since the first firing's.
  const double first_turn = std::floor((firings[0].azimuth - cut * 100) / 36000);
  std::vector<std::vector<const Firing*>> expected;
  std::vector<double> first_time_us;
  for (const Firing& f : firings) {
    const auto s = static_cast<std::size_t>(std::floor((f.azimuth - cut * 100) / 36000) - first_turn);
    if (s >= expected.size()) expected.resize(s + 1), first_time_us.push_back(f.time_us);
    if (f.distance) expected[s].push_back(&f);
  }
  ASSERT_EQ(sweeps.size(), expected.size());
  ASSERT_EQ(sweeps.size(), 3u);
  for (std::size_t s = 0; s < sweeps.size(); ++s) {
    ASSERT_EQ(sweeps[s].points.size(), expected[s].size()) << "sweep " << s;
    EXPECT_NEAR(static_cast<double>(sweeps[s].stamp_ns - kHourNs), first_time_us[s] * 1000, 2) << "sweep " << s;
    for (std::size_t i = 0; i < expected[s].size(); ++i) {
      const Firing& f = *expected[s][i];
      const Point& p = sweeps[s].points[i];
      const double elevation = -15 + 2.0 * f.laser, azimuth = f.azimuth * 0.01 - rot_deg(f.laser);
      const Xyz e = place(f.distance * 0.002, elevation, azimuth);
      ASSERT_NEAR(p.x, e.x, 1e-3) << "sweep " << s << " point " << i;
      ASSERT_NEAR(p.y, e.y, 1e-3);
      ASSERT_NEAR(p.z, e.z, 1e-3);
      ASSERT_NEAR(std::remainder(p.azimuth_deg - azimuth, 360.0), 0, 0.0051);
      ASSERT_GE(p.azimuth_deg, 0);
      ASSERT_LT(p.azimuth_deg, 360);
      ASSERT_EQ(p.channel, f.laser);
      ASSERT_EQ(p.intensity, f.intensity);
      ASSERT_EQ(p.return_type, ReturnType::Strongest);
      ASSERT_NEAR(p.distance_m, f.distance * 0.002, 1e-6);
      ASSERT_NEAR(p.elevation_deg, elevation, 1e-4);
      ASSERT_NEAR(p.time_s, (f.time_us - first_time_us[s]) * 1e-6, 2e-9);
    }
  }
  // Sweeps 1 and 2 are whole turns from the cut: their firings' azimuths span [90, 450).
  EXPECT_GE(expected[1].front()->azimuth * 0.01 - 360, cut);
  EXPECT_LT(expected[1].back()->azimuth * 0.01 - 360, cut + 360);
  const SensorInfo info = d->info();
  EXPECT_NEAR(info.rotation_hz, 0.4 / 110.592e-6 / 360, 0.01);
  ASSERT_EQ(info.ring_of_channel.size(), 16u);
  EXPECT_EQ(info.ring_of_channel[0], 0);
  EXPECT_EQ(info.ring_of_channel[15], 15);
  EXPECT_NEAR(info.elevation_deg[15], 15, 1e-4);
}

TEST(VelodyneDecoder, DualReturnsPairedAndNamedAsTheReferenceNamesThem) {
  auto d = make_decoder(Vendor::Velodyne, options(plain_calibration(16)));
  PacketWriter w;
  w.tail(1000, kDual, kVlp16);
  for (int b = 0; b < 12; ++b) w.block(b, kBank[0], static_cast<std::uint16_t>(1000 + 80 * (b / 2)));
  w.ret(0, 0, 1000, 50).ret(1, 0, 1000, 50);  // one return: reported once
  w.ret(0, 1, 2000, 30).ret(1, 1, 1500, 80);  // the last return farther and weaker
  w.ret(0, 2, 3000, 60).ret(1, 2, 2500, 60);  // equal intensities: the last is the strong one
  w.ret(0, 3, 1200, 10).ret(1, 3, 0, 0);      // no second return
  w.ret(2, 4, 900, 5).ret(3, 4, 900, 5);      // the next column
  std::vector<Sweep> sweeps;
  d->add(w.str(), kHourNs + 1'000'000, sweeps);
  d->finish(sweeps);
  ASSERT_EQ(sweeps.size(), 1u);
  const auto& p = sweeps[0].points;
  ASSERT_EQ(p.size(), 7u);
  const std::vector<std::pair<int, ReturnType>> want = {
      {0, ReturnType::Identical}, {1, ReturnType::LastWeak}, {2, ReturnType::LastStrong}, {3, ReturnType::Identical},
      {1, ReturnType::FirstStrong}, {2, ReturnType::FirstWeak}, {4, ReturnType::Identical}};
  for (std::size_t i = 0; i < want.size(); ++i) {
    EXPECT_EQ(p[i].channel, want[i].first) << i;
    EXPECT_EQ(p[i].return_type, want[i].second) << i;
  }
  // A pair's returns are one firing: one azimuth and one time; the next column 110.592 us later.
  EXPECT_FLOAT_EQ(p[4].azimuth_deg, p[1].azimuth_deg);
  EXPECT_DOUBLE_EQ(p[4].time_s, p[1].time_s);
  EXPECT_NEAR(p[6].time_s - p[0].time_s, (110.592 + 4 * 2.304) * 1e-6, 2e-9);
  EXPECT_NEAR(p[1].distance_m, 4.0, 1e-6);
  EXPECT_NEAR(p[4].distance_m, 3.0, 1e-6);
}

// One packet of `product` with the same azimuth in every block of a column, one return per slot.
std::string packet_of(std::uint8_t product, std::uint8_t mode, int blocks_per_column, const std::uint16_t (&flags)[12],
                      std::uint32_t toh_us) {
  PacketWriter w;
  w.tail(toh_us, mode, product);
  for (int b = 0; b < 12; ++b) {
    w.block(b, flags[b], static_cast<std::uint16_t>(20000 + 20 * (b / blocks_per_column)));
    for (int j = 0; j < 32; ++j) w.ret(b, j, static_cast<std::uint16_t>(1000 + b * 32 + j), static_cast<std::uint8_t>(j));
  }
  return w.str();
}

const Point* find(const Sweep& s, int channel, double distance_m) {
  for (const Point& p : s.points)
    if (p.channel == channel && std::abs(p.distance_m - distance_m) < 1e-4) return &p;
  return nullptr;
}

TEST(VelodyneDecoder, TheModelIsToldByThePacketsWithItsLasersAndFiringTimes) {
  struct Case {
    const char* model;
    std::uint8_t product;
    int lasers, blocks_per_column;
    float unit;
    std::uint16_t flags[12];
    // block, slot -> laser and firing time after the time stamp (us)
    std::function<std::pair<int, double>(int, int)> where;
  };
  const std::vector<Case> cases = {
      {"VLP-32C", kVlp32C, 32, 1, 0.004f, {0xEEFF, 0xEEFF, 0xEEFF, 0xEEFF, 0xEEFF, 0xEEFF, 0xEEFF, 0xEEFF, 0xEEFF, 0xEEFF, 0xEEFF, 0xEEFF},
       [](int b, int j) { return std::pair{j, b * 55.296 + (j / 2) * 2.304}; }},
      {"HDL-32E", kHdl32E, 32, 1, 0.002f, {0xEEFF, 0xEEFF, 0xEEFF, 0xEEFF, 0xEEFF, 0xEEFF, 0xEEFF, 0xEEFF, 0xEEFF, 0xEEFF, 0xEEFF, 0xEEFF},
       [](int b, int j) { return std::pair{j, b * 46.08 + j * 1.152}; }},
      {"VLS-128", kVls128, 128, 4, 0.004f, {0xEEFF, 0xDDFF, 0xCCFF, 0xBBFF, 0xEEFF, 0xDDFF, 0xCCFF, 0xBBFF, 0xEEFF, 0xDDFF, 0xCCFF, 0xBBFF},
       [](int b, int j) {
         const int laser = 32 * (b % 4) + j, group = laser / 8;
         return std::pair{laser, (b / 4) * 53.3 + (group + group / 8) * 2.665 - 8.7};
       }},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.model);
    auto d = make_decoder(Vendor::Velodyne, options(plain_calibration(c.lasers)));
    std::vector<Sweep> sweeps;
    d->add(packet_of(c.product, kLast, c.blocks_per_column, c.flags, 5'000'000), kHourNs + 5'000'000'000, sweeps);
    d->finish(sweeps);
    EXPECT_EQ(d->info().model, c.model);
    EXPECT_EQ(d->info().channels, c.lasers);
    ASSERT_EQ(sweeps.size(), 1u);
    ASSERT_EQ(sweeps[0].points.size(), 384u);
    const std::int64_t first_ns = kHourNs + 5'000'000'000 + std::llround(c.where(0, 0).second * 1000);
    EXPECT_NEAR(static_cast<double>(sweeps[0].stamp_ns - first_ns), 0, 2);
    for (int b = 0; b < 12; b += 5)
      for (int j = 0; j < 32; j += 7) {
        const auto [laser, us] = c.where(b, j);
        const Point* p = find(sweeps[0], laser, (1000 + b * 32 + j) * c.unit);
        ASSERT_NE(p, nullptr) << b << " " << j;
        EXPECT_NEAR(p->time_s, (us - c.where(0, 0).second) * 1e-6, 2e-9) << b << " " << j;
        EXPECT_EQ(p->return_type, ReturnType::Last);
        EXPECT_EQ(p->intensity, j);
      }
  }
}

TEST(VelodyneDecoder, Vls128DualReturnIsOneColumnAndPaddingBlocksAreNotRead) {
  auto d = make_decoder(Vendor::Velodyne, options(plain_calibration(128)));
  PacketWriter w;
  w.tail(7'000'000, kDual, kVls128);
  for (int b = 0; b < 8; ++b) w.block(b, kBank[b / 2], 9000);
  for (int b = 8; b < 12; ++b) w.block(b, 0, 9000).ret(b, 0, 999, 9);  // padding
  w.ret(0, 3, 2000, 40).ret(1, 3, 2500, 20);                            // bank 1, laser 3: two returns
  w.ret(6, 31, 1500, 7).ret(7, 31, 1500, 7);                            // bank 4, laser 127: one
  std::vector<Sweep> sweeps;
  d->add(w.str(), kHourNs + 7'000'000'000, sweeps);
  d->finish(sweeps);
  EXPECT_EQ(d->counts().skipped, 0u);
  ASSERT_EQ(sweeps.size(), 1u);
  ASSERT_EQ(sweeps[0].points.size(), 3u);
  EXPECT_EQ(sweeps[0].points[0].channel, 3);
  EXPECT_EQ(sweeps[0].points[0].return_type, ReturnType::FirstStrong);
  EXPECT_EQ(sweeps[0].points[1].return_type, ReturnType::LastWeak);
  EXPECT_EQ(sweeps[0].points[2].channel, 127);
  EXPECT_EQ(sweeps[0].points[2].return_type, ReturnType::Identical);
}

TEST(VelodyneDecoder, Hdl64eNeedsItsModelAndHasUpperAndLowerBlocks) {
  // Offsets, a two-point correction and the focal intensity correction on laser 33 (lower block).
  LaserCal special;
  special.elevation_deg = -10, special.rot_deg = -2, special.dist = 1.2, special.dist_x = 1.25, special.dist_y = 1.1;
  special.two_point = true, special.vert_offset = 0.2, special.horiz_offset = 0.03;
  special.focal_distance = 1500, special.focal_slope = 1.4, special.min_intensity = 20, special.max_intensity = 240;
  const std::string yaml = calibration_yaml(64, [&](int i) {
    if (i == 33) return special;
    LaserCal c;
    c.elevation_deg = -24 + 0.4 * i;
    return c;
  });
  std::uint16_t flags[12];
  for (int b = 0; b < 12; ++b) flags[b] = kBank[b % 2];
  const std::string packet = packet_of(0, 0, 2, flags, 9'000'000);

  DecoderOptions o = options(yaml);
  EXPECT_TRUE(has(error_of([&] {
                    std::vector<Sweep> s;
                    make_decoder(Vendor::Velodyne, o)->add(packet, kHourNs + 9'000'000'000, s);
                  }),
                  "set the model"));
  o.model = "hdl64e_s3";
  auto d = make_decoder(Vendor::Velodyne, o);
  std::vector<Sweep> sweeps;
  d->add(packet, kHourNs + 9'000'000'000, sweeps);
  d->finish(sweeps);
  EXPECT_EQ(d->info().model, "HDL-64E S3");
  ASSERT_EQ(sweeps.size(), 1u);
  EXPECT_EQ(sweeps[0].points.size(), 384u);
  // Block 3: lower lasers, column 1 (57.6 us after column 0); slot 1 fires 1.3 us into its group.
  const std::uint16_t raw = 1000 + 3 * 32 + 1;
  const Point* p = find(sweeps[0], 33, raw * 0.002 + 1.2);
  ASSERT_NE(p, nullptr);
  EXPECT_NEAR(p->time_s, (57.6 + 1.3) * 1e-6, 2e-9);
  // The manual's formula, written out again: azimuth 200.20 + its share of the 0.2-degree step, less -2.
  const double d0 = raw * 0.002 + 1.2, v = -10 * kPi / 180, a = (200.20 + 0.20 * 1.3 / 57.6 + 2) * kPi / 180;
  const double xy0 = d0 * std::cos(v) - 0.2 * std::sin(v);
  const double ax = std::abs(xy0 * std::sin(a) - 0.03 * std::cos(a)), ay = std::abs(xy0 * std::cos(a) + 0.03 * std::sin(a));
  const double cx = (1.2 - 1.25) * (ax - 2.4) / (25.04 - 2.4) + 1.25 - 1.2;
  const double cy = (1.2 - 1.1) * (ay - 1.93) / (25.04 - 1.93) + 1.1 - 1.2;
  const double right = ((d0 + cx) * std::cos(v) - 0.2 * std::sin(v)) * std::sin(a) - 0.03 * std::cos(a);
  const double forward = ((d0 + cy) * std::cos(v) - 0.2 * std::sin(v)) * std::cos(a) + 0.03 * std::sin(a);
  EXPECT_NEAR(p->x, forward, 1e-3);
  EXPECT_NEAR(p->y, -right, 1e-3);
  EXPECT_NEAR(p->z, (d0 + cy) * std::sin(v) + 0.2 * std::cos(v), 1e-3);
  const double focal = 256 * std::pow(1 - 1500 / 13100.0, 2), near = 256 * std::pow(1 - raw / 65535.0, 2);
  EXPECT_EQ(p->intensity, std::floor(std::min(240.0, 1 + 1.4 * std::abs(focal - near))));
  EXPECT_EQ(p->return_type, ReturnType::Unknown);
}

TEST(VelodyneDecoder, DamagedAndForeignPacketsAreSkippedAndCounted) {
  auto d = make_decoder(Vendor::Velodyne, options(plain_calibration(16)));
  std::vector<Firing> firings;
  const auto good = vlp16_stream(3, 100, 40, 2'000'000, firings);
  std::vector<Sweep> sweeps;
  auto feed = [&](const std::string& packet) { d->add(packet, kHourNs + 2'000'000'000, sweeps); };
  feed(good[0]);
  struct Damage {
    std::function<void(std::string&)> apply;
    const char* problem;
  };
  const std::vector<Damage> damages = {
      {[](std::string& p) { p.resize(1205); }, "1205 bytes"},
      {[](std::string& p) { p += '\0'; }, "1207 bytes"},
      {[](std::string& p) { p.clear(); }, "0 bytes"},
      {[](std::string& p) { p[500] = 0x12; }, "block 5: flag"},
      {[](std::string& p) { p[702] = char(0xA0), p[703] = char(0x8C); }, "azimuth 36000"},
      {[](std::string& p) { p[1205] = char(kVlp32C); }, "a VLP-32C packet"},
      {[](std::string& p) { p[1205] = 0x77; }, "product id 0x77"},
      {[](std::string& p) { p[1204] = 0x3A; }, "return mode 0x3A"},
      {[](std::string& p) { p[1203] = char(0xF0); }, "past an hour"},
  };
  for (std::size_t i = 0; i < damages.size(); ++i) {
    std::string bad = good[1];
    damages[i].apply(bad);
    feed(bad);
    EXPECT_EQ(d->counts().skipped, i + 1);
    EXPECT_TRUE(has(d->counts().last_problem, damages[i].problem)) << d->counts().last_problem;
  }
  feed(good[1]);
  feed(good[2]);
  d->finish(sweeps);
  EXPECT_EQ(d->counts().packets, damages.size() + 3);
  ASSERT_EQ(sweeps.size(), 1u);
  EXPECT_EQ(sweeps[0].points.size(), 3u * 384 - 10);  // ten empty returns among the written firings
}

TEST(VelodyneDecoder, PacketsOfNoKnownModelStopTheDecoderOrAreSkipped) {
  std::uint16_t flags[12];
  for (auto& f : flags) f = 0xEEFF;
  std::vector<Sweep> sweeps;
  auto d = make_decoder(Vendor::Velodyne, options(plain_calibration(32)));
  std::string garbage(1206, 'x');
  d->add(garbage, 0, sweeps);  // not a Velodyne data packet at all
  EXPECT_EQ(d->counts().skipped, 1u);
  EXPECT_TRUE(has(error_of([&] { d->add(packet_of(0x23, kStrongest, 1, flags, 0), 0, sweeps); }), "VLP-32A/B"));
  const std::string e = error_of([&] { d->add(packet_of(0x00, 0, 1, flags, 0), 0, sweeps); });
  EXPECT_TRUE(has(e, "set the model") && has(e, "HDL-32E")) << e;
  EXPECT_TRUE(has(error_of([&] {
                    DecoderOptions o = options(plain_calibration(32));
                    o.model = "VLP-64";
                    make_decoder(Vendor::Velodyne, o);
                  }),
                  "VLP-64"));
}

TEST(VelodyneDecoder, MissingCalibrationNamesTheModelAndTheFile) {
  std::vector<Firing> firings;
  const auto packets = vlp16_stream(1, 0, 40, 0, firings);
  std::vector<Sweep> sweeps;
  auto d = make_decoder(Vendor::Velodyne, DecoderOptions{});
  const std::string e = error_of([&] { d->add(packets[0], 0, sweeps); });
  EXPECT_TRUE(has(e, "VLP-16 packets need the sensor's calibration") && has(e, "--lidar-calibration VLP16.yaml")) << e;
  DecoderOptions o;
  o.model = "VLS-128";
  EXPECT_TRUE(has(error_of([&] { make_decoder(Vendor::Velodyne, o); }), "--lidar-calibration VLS128.yaml"));
  // The calibration of another sensor.
  auto wrong = make_decoder(Vendor::Velodyne, options(plain_calibration(32)));
  const std::string e2 = error_of([&] { wrong->add(packets[0], 0, sweeps); });
  EXPECT_TRUE(has(e2, "calibration text: 32 lasers, but VLP-16 packets carry 16")) << e2;
}

TEST(VelodyneCalibration, ErrorsNameTheFileLineAndField) {
  const auto dir = std::filesystem::temp_directory_path() / ("pl_velodyne_cal_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  auto error_for = [&](const std::string& text) {
    const std::string path = (dir / "VLP16.yaml").string();
    std::ofstream(path) << text;
    DecoderOptions o;
    o.calibration_path = path;
    return error_of([&] { make_decoder(Vendor::Velodyne, o); });
  };
  const std::string good = plain_calibration(16);
  EXPECT_EQ(error_for(good), "");
  // The value of the n-th `key` (0 first) replaced.
  auto replaced = [&](const std::string& key, int n, const std::string& value) {
    std::string t = good;
    std::size_t at = t.find(key);
    while (n-- > 0) at = t.find(key, at + 1);
    const std::size_t from = at + key.size(), to = t.find_first_of(",\n", from);
    return t.replace(from, to - from, value);
  };
  // "lasers:" is line 1, then 15 lines per laser: lasers[1]'s vert_correction is line 29.
  std::string e = error_for(replaced("vert_correction: ", 1, "abc"));
  EXPECT_TRUE(has(e, "VLP16.yaml:29: lasers[1].vert_correction: expected a number, found \"abc\"")) << e;
  e = error_for(replaced("vert_correction: ", 1, "2"));
  EXPECT_TRUE(has(e, "lasers[1].vert_correction: expected a number in [-1.5708, 1.5708] (radians)")) << e;
  e = error_for(replaced("laser_id: ", 1, "0"));
  EXPECT_TRUE(has(e, "lasers[1].laser_id: expected each laser_id once")) << e;
  e = error_for(replaced("laser_id: ", 1, "1.5"));
  EXPECT_TRUE(has(e, "lasers[1].laser_id: expected a whole number")) << e;
  e = error_for(replaced("num_lasers: ", 0, "15"));
  EXPECT_TRUE(has(e, "num_lasers: expected the number of entries under lasers, 16")) << e;
  e = error_for(replaced("dist_correction: ", 0, "[0"));
  EXPECT_TRUE(has(e, "VLP16.yaml:") && has(e, "YAML: expected valid YAML")) << e;
  e = error_for("lasers: 3\n");
  EXPECT_TRUE(has(e, "lasers: expected a list of one entry per laser")) << e;
  std::string no_vert = good;
  no_vert.erase(no_vert.find("        vert_correction: "), no_vert.find('\n', no_vert.find("        vert_correction: ")) -
                                                              no_vert.find("        vert_correction: ") + 1);
  e = error_for(no_vert);
  EXPECT_TRUE(has(e, "VLP16.yaml:2: lasers[0].vert_correction: expected a field vert_correction")) << e;
  DecoderOptions missing;
  missing.calibration_path = (dir / "none.yaml").string();
  EXPECT_TRUE(has(error_of([&] { make_decoder(Vendor::Velodyne, missing); }), "none.yaml: cannot open"));
  std::filesystem::remove_all(dir);
}

TEST(VelodyneDecoder, RangeLimitsAndTheSensorsClock) {
  // The receive stamps are 20 minutes off the sensor's hour: its clock is not UTC, so the sweep
  // takes the first packet's receive time and the sensor's microseconds after it.
  DecoderOptions o = options(plain_calibration(16));
  o.min_range_m = 1.3, o.max_range_m = 1.5;  // (600 + 37 l + n % 50) counts of 2 mm: lasers 1 to 4
  auto d = make_decoder(Vendor::Velodyne, o);
  std::vector<Firing> firings;
  const auto packets = vlp16_stream(2, 0, 40, 500'000'000, firings);
  std::vector<Sweep> sweeps;
  const std::int64_t receive0 = kHourNs + 1'700'000'000'000;
  d->add(packets[0], receive0, sweeps);
  d->add(packets[1], receive0 + 5'000'000, sweeps);  // late: the sensor's 1327 us stand
  d->finish(sweeps);
  ASSERT_EQ(sweeps.size(), 1u);
  EXPECT_EQ(sweeps[0].stamp_ns, receive0);
  double last = 0;
  for (const Point& p : sweeps[0].points) {
    EXPECT_GE(p.distance_m, 1.3);
    EXPECT_LE(p.distance_m, 1.5);
    last = std::max(last, p.time_s);
  }
  // The second packet's stamp is 1327 us (the sensor's, rounded) after the first's.
  EXPECT_NEAR(last, (1327 + 11 * 110.592 + 55.296 + 3 * 2.304) * 1e-6, 2e-9);
}

TEST(VelodyneDecoder, ADecoderStartedMidStreamStampsSweepsAlike) {
  // A free-running sensor clock and jittery receive stamps: whole sweeps decode the same wherever
  // decoding starts (a recording's scans are decoded again from a few sweeps back).
  std::vector<Firing> firings;
  const auto packets = vlp16_stream(200, 0, 40, 100'000'000, firings);
  auto decode_from = [&](std::size_t first) {
    auto d = make_decoder(Vendor::Velodyne, options(plain_calibration(16)));
    std::vector<Sweep> sweeps;
    for (std::size_t k = first; k < packets.size(); ++k)
      d->add(packets[k], kHourNs + 1'900'000'000'000 + static_cast<std::int64_t>(k) * 1'327'104 + (k * 7919) % 300'000, sweeps);
    return sweeps;
  };
  const auto all = decode_from(0), later = decode_from(40);
  // 2.67 turns from 0 degrees, the last still open; from packet 40 (192 degrees) a part turn first.
  ASSERT_EQ(all.size(), 2u);
  ASSERT_EQ(later.size(), 2u);
  EXPECT_LT(later[0].points.size(), all[0].points.size());
  const Sweep &a = all[1], &b = later[1];
  EXPECT_EQ(a.stamp_ns, b.stamp_ns);
  ASSERT_EQ(a.points.size(), b.points.size());
  for (std::size_t i = 0; i < a.points.size(); ++i) {
    ASSERT_EQ(a.points[i].x, b.points[i].x);
    ASSERT_EQ(a.points[i].time_s, b.points[i].time_s);
  }
}

TEST(VelodyneDecoder, AJumpWithinAPacketIsTimedByTheRotation) {
  // A VLP-32C sending only part of its turn fills a packet's last blocks after the gap.
  auto d = make_decoder(Vendor::Velodyne, options(plain_calibration(32), 180));
  PacketWriter w;
  w.tail(3'000'000, kStrongest, kVlp32C);
  for (int b = 0; b < 12; ++b) {
    w.block(b, kBank[0], static_cast<std::uint16_t>(b < 8 ? 9000 + 20 * b : 27000 + 20 * (b - 8)));
    w.ret(b, 0, 1000, 1);
  }
  std::vector<Sweep> sweeps;
  d->add(w.str(), kHourNs + 3'000'000'000, sweeps);
  d->finish(sweeps);
  ASSERT_EQ(sweeps.size(), 2u);  // the cut at 180 degrees lies in the gap
  ASSERT_EQ(sweeps[0].points.size(), 8u);
  ASSERT_EQ(sweeps[1].points.size(), 4u);
  // Block 8 fired 178.6 degrees after block 7, at 0.2 degree per 55.296 us.
  const double jump_us = (7 + 17860 / 20.0) * 55.296;
  EXPECT_NEAR(static_cast<double>(sweeps[1].stamp_ns - sweeps[0].stamp_ns), jump_us * 1000, 2000);
  EXPECT_NEAR(sweeps[1].points[3].time_s, 3 * 55.296e-6, 2e-9);
}

}  // namespace
}  // namespace pl::lidar
