// The Hesai decoder on packets written from the manuals' layouts (hesai_packets.hpp): points, firing
// times, return types, sweeps cut per channel, the model told by the packets, and what it refuses.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>

#include <unistd.h>

#include "error_of.hpp"
#include "hesai_packets.hpp"
#include "pl/common/error.hpp"
#include "pl/lidar/decoder.hpp"

namespace pl::lidar {
namespace {

using test::HesaiBlock;
using test::HesaiFormat;
using test::HesaiTail;

constexpr double kPi = 3.14159265358979323846;

// Blocks of `f` from `az0` in steps of `step` (hundredths of a degree), each firing round's blocks at
// one azimuth; unit(block, channel) gives distance and reflectivity.
std::vector<HesaiBlock> blocks_of(const HesaiFormat& f, int az0, int step, int returns,
                                  const std::function<std::pair<int, int>(int, int)>& unit) {
  std::vector<HesaiBlock> blocks(static_cast<std::size_t>(f.blocks));
  for (int b = 0; b < f.blocks; ++b) {
    HesaiBlock& k = blocks[static_cast<std::size_t>(b)];
    k.azimuth_cdeg = static_cast<std::uint16_t>((az0 + step * (b / returns)) % 36000);
    for (int c = 0; c < f.channels; ++c) {
      const auto [d, r] = unit(b, c);
      k.distance.push_back(static_cast<std::uint16_t>(d));
      k.reflectivity.push_back(static_cast<std::uint8_t>(r));
    }
  }
  return blocks;
}

DecoderOptions options_for(int channels, double cut_deg = 0) {
  DecoderOptions o;
  o.calibration_text = test::hesai_angle_file(channels);
  o.cut_azimuth_deg = cut_deg;
  return o;
}

std::vector<Sweep> decode(PacketDecoder& d, const std::vector<std::string>& packets) {
  std::vector<Sweep> out;
  for (const auto& p : packets) d.add(p, 0, out);
  d.finish(out);
  return out;
}

using pl::test::error_of;

TEST(HesaiDecoder, EveryModelsPointsComeBackFromWrittenPackets) {
  for (const HesaiFormat& f : test::hesai_formats()) {
    SCOPED_TRACE(f.model);
    std::vector<double> elevation, offset;
    DecoderOptions o;
    o.calibration_text = test::hesai_angle_file(f.channels, &elevation, &offset);
    o.cut_azimuth_deg = 180;
    auto d = make_decoder(Vendor::Hesai, o);
    auto unit = [](int b, int c) { return std::pair<int, int>(1000 + 37 * c + 5 * b, (3 * c + b) & 0xFF); };
    HesaiTail tail;
    tail.rpm = 1200;
    const auto sweeps = decode(*d, {test::write_hesai_packet(f, blocks_of(f, 1000, 20, 1, unit), tail)});
    ASSERT_EQ(sweeps.size(), 1u);
    const Sweep& s = sweeps[0];
    ASSERT_EQ(s.points.size(), static_cast<std::size_t>(f.blocks * f.channels));
    const std::int64_t packet_ns = test::hesai_tail_seconds(tail) * 1'000'000'000 + tail.micros * 1000LL;
    EXPECT_LT(std::abs(s.stamp_ns - packet_ns), 1'000'000) << "the sensor's clock, within a millisecond of the packet's";
    for (int b = 0; b < f.blocks; ++b) {
      for (int c = 0; c < f.channels; ++c) {
        const Point& p = s.points[static_cast<std::size_t>(b * f.channels + c)];
        const double r = unit(b, c).first * 0.004, az = (1000 + 20 * b) / 100.0 + offset[c], el = elevation[c];
        const double a = az * kPi / 180, e = el * kPi / 180;
        EXPECT_NEAR(p.x, r * std::cos(e) * std::sin(a), 1e-4);
        EXPECT_NEAR(p.y, r * std::cos(e) * std::cos(a), 1e-4);
        EXPECT_NEAR(p.z, r * std::sin(e), 1e-4);
        EXPECT_EQ(p.channel, c);
        EXPECT_EQ(p.intensity, unit(b, c).second);
        EXPECT_EQ(p.return_type, ReturnType::Strongest);
        EXPECT_NEAR(p.azimuth_deg, az, 1e-4);
        EXPECT_NEAR(p.elevation_deg, el, 1e-5);
        EXPECT_NEAR(p.distance_m, r, 1e-6);
        EXPECT_GE(p.time_s, 0.0);
        EXPECT_LT(p.time_s, 1e-3);
      }
    }
    const SensorInfo info = d->info();
    EXPECT_EQ(info.model, f.model);
    EXPECT_EQ(info.channels, f.channels);
    EXPECT_DOUBLE_EQ(info.rotation_hz, 20.0);
    ASSERT_EQ(info.ring_of_channel.size(), static_cast<std::size_t>(f.channels));
    for (int c = 0; c < f.channels; ++c) EXPECT_EQ(info.ring_of_channel[c], (7 * c) % f.channels) << "rank of elevation";
    EXPECT_EQ(d->counts().packets, 1u);
    EXPECT_EQ(d->counts().skipped, 0u);
    EXPECT_EQ(d->counts().sweeps, 1u);
    EXPECT_EQ(d->counts().points, s.points.size());
  }
}

// Seconds between two points of one written packet (block, channel), all channels at 10 m.
double firing_gap_s(const std::string& model, std::uint8_t mode, std::uint8_t loop, int b1, int c1, int b2, int c2) {
  const HesaiFormat& f = test::hesai_format(model);
  auto d = make_decoder(Vendor::Hesai, options_for(f.channels, 180));
  HesaiTail tail;
  tail.return_mode = mode;
  tail.loop_flag = loop;
  const int returns = mode == 0x37 ? 1 : 2;
  // Distinct distances per block, so that no return of a dual pair is dropped as the same target.
  auto unit = [](int b, int) { return std::pair<int, int>(2500 + 100 * b, 10 + b); };
  const auto sweeps = decode(*d, {test::write_hesai_packet(f, blocks_of(f, 1000, 20, returns, unit), tail)});
  const auto& pts = sweeps.at(0).points;
  auto at = [&](int b, int c) {
    // Points come round by round, channel by channel, return by return.
    const int round = b / returns, r = b % returns;
    return pts.at(static_cast<std::size_t>((round * f.channels + c) * returns + r)).time_s;
  };
  return at(b2, c2) - at(b1, c1);
}

TEST(HesaiDecoder, FiringTimesFollowTheManuals) {
  // XT32: rounds 50 us apart, channels 1.512 us; dual return: two blocks a round.
  EXPECT_NEAR(firing_gap_s("PandarXT32", 0x37, 0, 0, 0, 3, 5), 157.56e-6, 1e-9);
  EXPECT_NEAR(firing_gap_s("PandarXT32", 0x39, 0, 0, 0, 5, 5), 107.56e-6, 1e-9);
  EXPECT_NEAR(firing_gap_s("PandarXT16", 0x37, 0, 0, 0, 0, 15), 45.36e-6, 1e-9);
  EXPECT_NEAR(firing_gap_s("PandarXT32M", 0x37, 0, 0, 0, 5, 17), 250e-6 + 2.888e-6, 1e-9);
  // Pandar64: laser 8 at -46.796 us, laser 1 at -23.18 us; rounds 55.56 us apart.
  EXPECT_NEAR(firing_gap_s("Pandar64", 0x37, 0, 0, 0, 0, 7), -23.616e-6, 1e-9);
  EXPECT_NEAR(firing_gap_s("Pandar64", 0x37, 0, 0, 0, 1, 0), 55.56e-6, 1e-9);
  // Pandar40P: laser 4 at -3.62 us, laser 8 at -54.67 us.
  EXPECT_NEAR(firing_gap_s("Pandar40P", 0x37, 0, 0, 3, 0, 7), -51.05e-6, 1e-9);
  // QT64: blocks 500/3 us apart; laser 56 at 129.6 us, laser 55 at 127.54 us.
  EXPECT_NEAR(firing_gap_s("PandarQT64", 0x37, 0, 0, 54, 0, 55), 2.06e-6, 1e-9);
  EXPECT_NEAR(firing_gap_s("PandarQT64", 0x37, 0, 0, 0, 1, 0), 166.666e-6, 1e-9);
  // QT128 dual return: the mode flag names the firing sequence (lasers 33, 34 in sequence 1;
  // lasers 1, 2 in sequence 2).
  EXPECT_NEAR(firing_gap_s("PandarQT128", 0x39, 1, 0, 32, 0, 33), 25.344e-6, 1e-9);
  EXPECT_NEAR(firing_gap_s("PandarQT128", 0x39, 0, 0, 0, 0, 1), 76.032e-6, 1e-9);
}

TEST(HesaiDecoder, DualReturnsKeepEachTargetOnce) {
  const HesaiFormat& f = test::hesai_format("PandarXT32");
  // Per channel: {distance, reflectivity} of the first and second block of the firing.
  const int units[6][4] = {{2500, 50, 2500, 50},    // identical: reported once
                           {2500, 50, 2510, 60},    // 4 cm apart: one target, the second block's
                           {2500, 50, 5000, 80},    // last (weaker), strongest
                           {2500, 90, 5000, 40},    // last is the strongest, then second strongest
                           {0, 0, 5000, 40},        // no first-block return
                           {2500, 50, 0, 0}};       // no second-block return
  auto unit = [&](int b, int c) {
    const int* u = units[c % 6];
    return c < 6 ? std::pair<int, int>(u[(b % 2) * 2], u[(b % 2) * 2 + 1]) : std::pair<int, int>(0, 0);
  };
  auto run = [&](const HesaiFormat& fmt, std::uint8_t mode) {
    auto d = make_decoder(Vendor::Hesai, options_for(fmt.channels, 180));
    HesaiTail tail;
    tail.return_mode = mode;
    // Rounds 20 deg apart: the first round's points are those below 15 deg.
    const auto sweeps = decode(*d, {test::write_hesai_packet(fmt, blocks_of(fmt, 1000, 2000, 2, unit), tail)});
    std::vector<std::pair<int, ReturnType>> first_round;  // channel, type
    for (const Point& p : sweeps.at(0).points)
      if (p.azimuth_deg < 15) first_round.emplace_back(p.channel, p.return_type);
    return first_round;
  };
  using R = ReturnType;
  const std::vector<std::pair<int, R>> last_strongest = {{0, R::Identical}, {1, R::Strongest}, {2, R::Last}, {2, R::Strongest},
                                                         {3, R::LastStrong}, {3, R::SecondStrongest}, {4, R::Strongest}, {5, R::LastStrong}};
  EXPECT_EQ(run(f, 0x39), last_strongest);
  // First and last: the XT32 sends the last return in the first block, the QT64 the first.
  const auto xt = run(f, 0x3b), qt = run(test::hesai_format("PandarQT64"), 0x3b);
  ASSERT_GE(xt.size(), 4u);
  EXPECT_EQ(xt[2], std::make_pair(2, R::Last));
  EXPECT_EQ(xt[3], std::make_pair(2, R::First));
  ASSERT_GE(qt.size(), 4u);
  EXPECT_EQ(qt[2], std::make_pair(2, R::First));
  EXPECT_EQ(qt[3], std::make_pair(2, R::Last));
}

TEST(HesaiDecoder, SweepsAreCutWhereEachChannelPassesTheCut) {
  const HesaiFormat& f = test::hesai_format("PandarXT32");
  const double cut = 90;
  auto d = make_decoder(Vendor::Hesai, options_for(f.channels, cut));
  std::vector<std::string> packets;
  HesaiTail tail;
  tail.micros = 0;
  // Rounds 0.9 deg and the XT's 50 us apart: 400 rounds (50 packets) a turn, 130 packets from 300 deg.
  for (int k = 0; k < 130; ++k) {
    packets.push_back(test::write_hesai_packet(
        f, blocks_of(f, 30000 + k * 8 * 90, 90, 1, [](int, int) { return std::pair<int, int>(2500, 20); }), tail));
    tail.micros += 400;
  }
  const auto sweeps = decode(*d, packets);
  ASSERT_EQ(sweeps.size(), 4u);  // from 300 deg to the cut, two turns, the rest
  EXPECT_EQ(d->counts().sweeps, 4u);
  for (std::size_t i = 1; i <= 2; ++i) {
    SCOPED_TRACE(i);
    const Sweep& s = sweeps[i];
    EXPECT_EQ(s.points.size(), 400u * 32);
    // The first channel past the cut (offset +1.5 deg) opens the sweep: at round 165 of the first it
    // is on the cut (300 + 148.5 + 1.5 deg), which belongs to the sweep before; at 166 past it.
    EXPECT_NEAR((s.stamp_ns - sweeps[i - 1].stamp_ns) * 1e-9, i == 1 ? 166 * 50e-6 : 400 * 50e-6, 1e-9);
    std::vector<double> last(32, -1);
    std::vector<int> count(32, 0);
    for (const Point& p : s.points) {
      double from_cut = std::fmod(p.azimuth_deg - cut + 720, 360.0);
      if (from_cut <= 0) from_cut += 360;  // on the cut: the end of a turn
      // Each channel's turn starts past the cut and climbs to it, whatever its azimuth offset.
      if (count[p.channel]++ == 0) {
        EXPECT_LT(from_cut, 0.9 + 1e-3) << int(p.channel);
      }
      EXPECT_GT(from_cut, last[p.channel]);
      last[p.channel] = from_cut;
      EXPECT_GE(p.time_s, 0.0);
      EXPECT_LT(p.time_s, 0.02 + 4 * 50e-6) << "a turn and the 3 deg the offsets spread the cut";
    }
    for (int c = 0; c < 32; ++c) EXPECT_GT(last[c], 359.0);
  }
}

TEST(HesaiDecoder, TheModelIsToldByThePackets) {
  for (const HesaiFormat& f : test::hesai_formats()) {
    auto d = make_decoder(Vendor::Hesai, options_for(f.channels));
    EXPECT_EQ(d->info().model, "");
    std::vector<Sweep> out;
    d->add(test::write_hesai_packet(f, blocks_of(f, 0, 20, 1, [](int, int) { return std::pair<int, int>(500, 1); }), {}), 0, out);
    EXPECT_EQ(d->info().model, f.model);
    EXPECT_EQ(d->counts().skipped, 0u) << f.model;
  }
  DecoderOptions o = options_for(32);
  o.model = "xt32";
  auto d = make_decoder(Vendor::Hesai, o);
  EXPECT_EQ(d->info().model, "PandarXT32");
  std::vector<Sweep> out;
  const HesaiFormat& xt16 = test::hesai_format("PandarXT16");
  d->add(test::write_hesai_packet(xt16, blocks_of(xt16, 0, 20, 1, [](int, int) { return std::pair<int, int>(500, 1); }), {}), 0, out);
  EXPECT_EQ(d->counts().skipped, 1u);
  EXPECT_NE(d->counts().last_problem.find("PandarXT32"), std::string::npos) << d->counts().last_problem;
  o.model = "PandarXT64";
  EXPECT_NE(error_of([&] { make_decoder(Vendor::Hesai, o); }).find("PandarXT32M"), std::string::npos);
}

TEST(HesaiDecoder, AMissingCalibrationNamesTheFileAndTheFlag) {
  const HesaiFormat& f = test::hesai_format("PandarXT32");
  const std::string packet = test::write_hesai_packet(f, blocks_of(f, 0, 20, 1, [](int, int) { return std::pair<int, int>(500, 1); }), {});
  auto d = make_decoder(Vendor::Hesai, DecoderOptions{});
  std::vector<Sweep> out;
  const std::string missing = error_of([&] { d->add(packet, 0, out); });
  EXPECT_NE(missing.find("--lidar-calibration PandarXT32.csv"), std::string::npos) << missing;
  DecoderOptions o;
  o.model = "Pandar64";
  EXPECT_NE(error_of([&] { make_decoder(Vendor::Hesai, o); }).find("--lidar-calibration Pandar64.csv"), std::string::npos);
  // Another model's file: its laser count does not fit.
  auto wrong = make_decoder(Vendor::Hesai, options_for(16));
  const std::string mismatch = error_of([&] { wrong->add(packet, 0, out); });
  EXPECT_NE(mismatch.find("32 channels"), std::string::npos) << mismatch;
  EXPECT_NE(mismatch.find("16 lasers"), std::string::npos) << mismatch;
}

TEST(HesaiDecoder, DamagedAndForeignPacketsAreSkippedAndCounted) {
  const HesaiFormat& f = test::hesai_format("PandarXT32");
  auto unit = [](int, int) { return std::pair<int, int>(2500, 7); };
  const std::string good = test::write_hesai_packet(f, blocks_of(f, 1000, 20, 1, unit), {});
  auto with = [&](std::size_t at, char v) { std::string p = good; p[at] = v; return p; };
  const int tail = f.tail_start();
  const std::vector<std::string> bad = {
      "", good.substr(0, 10), good.substr(0, 1075), good.substr(0, 1079), good + std::string(3, '\0'),
      with(0, 0x00),                                 // no 0xEEFF
      with(6, 31),                                   // 31 lasers
      with(static_cast<std::size_t>(tail + f.mode_at), 0x00),  // no return mode
      with(12 + 1, static_cast<char>(0x8C)),         // block 0 at azimuth 360.72 deg
      with(static_cast<std::size_t>(tail + f.date_at + 1), 13),  // month 13
      std::string(1206, '\xFF'),                     // a Velodyne-sized packet
  };
  auto d = make_decoder(Vendor::Hesai, options_for(f.channels, 180));
  std::vector<Sweep> out;
  for (const auto& p : bad) d->add(p, 0, out);  // before the model is known
  EXPECT_EQ(d->info().model, "");
  d->add(good, 0, out);
  for (const auto& p : bad) d->add(p, 0, out);  // and after
  d->finish(out);
  EXPECT_EQ(d->counts().packets, 2 * bad.size() + 1);
  EXPECT_EQ(d->counts().skipped, 2 * bad.size());
  EXPECT_FALSE(d->counts().last_problem.empty());
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].points.size(), static_cast<std::size_t>(f.blocks * f.channels)) << "the good packet's points only";
  // A Hesai header this decoder does not read (protocol 1.4: AT128, Pandar128) is an error.
  std::string at128 = good;
  at128[2] = 1, at128[3] = 4, at128[6] = static_cast<char>(128), at128[7] = 2;
  auto fresh = make_decoder(Vendor::Hesai, options_for(f.channels));
  EXPECT_NE(error_of([&] { fresh->add(at128, 0, out); }).find("AT128"), std::string::npos);
}

TEST(HesaiDecoder, RangeLimitsAreTheOptionsWithinTheModels) {
  const HesaiFormat& f = test::hesai_format("PandarXT32");
  // 0.8 m, 1 m, 50 m, 60 m and 124 m (past the XT32's 120 m) on channels 0-4.
  const int raw[5] = {200, 250, 12500, 15000, 31000};
  auto unit = [&](int b, int c) { return std::pair<int, int>(b == 0 && c < 5 ? raw[c] : 0, 9); };
  DecoderOptions o = options_for(f.channels, 180);
  o.min_range_m = 1.0;
  o.max_range_m = 50.0;
  auto count = [&](const DecoderOptions& opt) {
    auto d = make_decoder(Vendor::Hesai, opt);
    return decode(*d, {test::write_hesai_packet(f, blocks_of(f, 1000, 20, 1, unit), {})}).at(0).points.size();
  };
  EXPECT_EQ(count(o), 2u);
  o.min_range_m = 0.3;
  o.max_range_m = 300;
  EXPECT_EQ(count(o), 4u);
}

TEST(HesaiCalibration, ErrorsNameTheFileLineAndField) {
  const auto dir = std::filesystem::temp_directory_path() / ("pl_hesai_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  auto error_for = [&](const std::string& text) {
    const std::string path = (dir / "angles.csv").string();
    std::ofstream(path, std::ios::binary) << text;
    DecoderOptions o;
    o.calibration_path = path;
    return error_of([&] { make_decoder(Vendor::Hesai, o); });
  };
  const std::string path = (dir / "angles.csv").string();
  EXPECT_NE(error_for("Laser id,Elevation,Azimuth\n1,2\n").find(path + ":2: expected 3 fields"), std::string::npos);
  EXPECT_NE(error_for("1,abc,0\n").find(path + ":1: expected an elevation"), std::string::npos);
  EXPECT_NE(error_for("1,95,0\n").find("an elevation from -90 to 90"), std::string::npos);
  EXPECT_NE(error_for("1,5,nan\n").find(":1: expected an azimuth offset"), std::string::npos);
  EXPECT_NE(error_for("0,5,1\n").find(":1: expected a laser id"), std::string::npos);
  EXPECT_NE(error_for("1,0,0\n\n1,0,0\n").find(":3: expected laser id 1 once (line 1 has it too)"), std::string::npos);
  EXPECT_NE(error_for("1,0,0\n3,0,0\n").find("2 is missing"), std::string::npos);
  EXPECT_NE(error_for("Laser id,Elevation,Azimuth\n").find("rows of laser id"), std::string::npos);
  EXPECT_NE(error_for("1,0,0\nChannel,Elevation,Azimuth\n").find(":2: expected a laser id"), std::string::npos);
  DecoderOptions o;
  o.calibration_path = (dir / "absent.csv").string();
  EXPECT_NE(error_of([&] { make_decoder(Vendor::Hesai, o); }).find("cannot open"), std::string::npos);
  // The makers' spellings: either header, CRLF line ends, a byte-order mark.
  o.calibration_path = path;
  std::ofstream(path, std::ios::binary) << "\xEF\xBB\xBF" "Channel,Elevation,Azimuth\r\n2,-1.5,0.25\r\n1,3.5,-0.125\r\n";
  auto d = make_decoder(Vendor::Hesai, o);
  const SensorInfo info = d->info();
  ASSERT_EQ(info.elevation_deg.size(), 2u);
  EXPECT_DOUBLE_EQ(info.elevation_deg[0], 3.5);
  EXPECT_DOUBLE_EQ(info.elevation_deg[1], -1.5);
  EXPECT_EQ(info.ring_of_channel, (std::vector<std::uint16_t>{1, 0}));
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace pl::lidar
