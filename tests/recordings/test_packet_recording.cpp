// A recording of a LiDAR's packets used as any other: a simulated VLP-16 drive written as the Velodyne
// driver records it (velodyne_msgs/VelodyneScan messages of data packets, in MCAP, with the ground
// truth as nav_msgs/Odometry), then pl-dataset info, pl-map build and pl-localize on it.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>

#include "cdr_writer.hpp"
#include "pl/recordings/dataset.hpp"
#include "pl/recordings/mcap_writer.hpp"
#include "test_util.hpp"
#include "velodyne_packets.hpp"

namespace {

namespace vt = pl::lidar::velodyne_test;

constexpr int kLasers = 16;

// One firing of the 16 lasers at one azimuth: the distance (2 mm counts) and reflectivity of each.
struct Column {
  double time_s = 0;
  std::uint16_t azimuth = 0;  // 0.01 degree
  std::uint16_t distance[kLasers] = {};
  std::uint8_t intensity[kLasers] = {};
};

// The scan's points as the VLP-16 fired them: each point to the firing at its azimuth (0.2 degree
// columns) and the laser at its elevation (-15 to 15 degrees by 2), columns in the order of their times.
std::vector<Column> columns_of(const pl::Frame& f, double scan_time_s) {
  std::vector<Column> cols(1800);  // every firing, with or without returns
  for (int col = 0; col < 1800; ++col) {
    cols[col].azimuth = static_cast<std::uint16_t>(col * 20);
    cols[col].time_s = scan_time_s + 0.1 * col / 1800.0;
  }
  for (std::size_t i = 0; i < f.scan.size(); ++i) {
    const auto& p = f.scan[i];
    const double d = std::sqrt(p.x * p.x + p.y * p.y + p.z * p.z);
    if (d < 0.5 || d > 130) continue;
    const double el = std::atan2(p.z, std::hypot(p.x, p.y)) * 180 / M_PI;
    const int laser = static_cast<int>(std::lround((el + 15) / 2));
    if (laser < 0 || laser >= kLasers) continue;
    double az = std::atan2(-p.y, p.x) * 180 / M_PI;  // clockwise from straight ahead, as the sensor turns
    if (az < 0) az += 360;
    const int col = static_cast<int>(std::lround(az / 0.2)) % 1800;
    Column& c = cols[static_cast<std::size_t>(col)];
    c.distance[laser] = static_cast<std::uint16_t>(std::lround(d / 0.002));
    c.intensity[laser] = static_cast<std::uint8_t>(std::clamp(std::lround(p.intensity * 255.0), 0L, 255L));
  }
  return cols;
}

// The simulator's clock starts at 0; the recording's at 2023-11-14.
constexpr std::int64_t kEpochNs = 1700000000LL * 1000000000LL;
std::int64_t to_ns(double s) { return kEpochNs + static_cast<std::int64_t>(std::llround(s * 1e9)); }

// A VelodyneScan message: two firings a block (the second in the block's upper 16 slots), 12 blocks a
// packet, each packet stamped with its first firing (its time past the hour, and as received).
std::string velodyne_scan(const std::vector<Column>& cols) {
  std::vector<std::pair<std::int64_t, std::string>> packets;
  for (std::size_t at = 0; at < cols.size(); at += 24) {
    vt::PacketWriter w;
    for (int b = 0; b < 12; ++b) {
      const std::size_t first = at + 2 * static_cast<std::size_t>(b);
      if (first >= cols.size()) {
        w.block(b, 0xEEFF, cols.back().azimuth);  // an empty block at the last azimuth
        continue;
      }
      w.block(b, 0xEEFF, cols[first].azimuth);
      for (int half = 0; half < 2 && first + half < cols.size(); ++half)
        for (int l = 0; l < kLasers; ++l) w.ret(b, 16 * half + l, cols[first + half].distance[l], cols[first + half].intensity[l]);
    }
    const std::int64_t ns = to_ns(cols[at].time_s);
    w.tail(static_cast<std::uint32_t>((ns / 1000) % 3600000000LL), vt::kStrongest, vt::kVlp16);
    packets.emplace_back(ns, w.str());
  }
  pl::test::CdrWriter m;
  const std::int64_t first = packets.front().first;
  m.header(static_cast<std::int32_t>(first / 1000000000), static_cast<std::uint32_t>(first % 1000000000), "velodyne");
  m.put<std::uint32_t>(static_cast<std::uint32_t>(packets.size()));
  for (const auto& [ns, bytes] : packets) m.put<std::int32_t>(static_cast<std::int32_t>(ns / 1000000000)).put<std::uint32_t>(ns % 1000000000).raw(bytes);
  return m.bytes();
}

// nav_msgs/Odometry: the LiDAR's pose in "map".
std::string odometry(double t, const pl::Pose& pose) {
  pl::test::CdrWriter m;
  const std::int64_t ns = to_ns(t);
  m.header(static_cast<std::int32_t>(ns / 1000000000), static_cast<std::uint32_t>(ns % 1000000000), "map").str("velodyne");
  const Eigen::Quaterniond q(pose.linear());
  for (double v : {pose.translation().x(), pose.translation().y(), pose.translation().z(), q.x(), q.y(), q.z(), q.w()}) m.put(v);
  for (int i = 0; i < 36 + 6 + 36; ++i) m.put(0.0);
  return m.bytes();
}

struct PacketDrive {
  std::string mcap, calibration, sim;
};

// A 40-scan VLP-16 drive round the town loop, simulated, then written as packets (made once per build tree).
PacketDrive packet_drive() {
  const std::string dir = pl::test::made_once("packet-drive-v4", [](const std::string& t) {
    const auto sim = pl::test::run(pl::test::tool("pl-sim") + " --route loop --frames 40 --seed 11 --lidar vlp16 --calibration-error 0 --sweep off --out " + t + "/sim");
    if (sim.exit_code != 0) throw std::runtime_error(sim.output);
    const pl::Dataset ds = pl::open_dataset(t + "/sim");
    {
      pl::McapWriter mcap(t + "/drive.mcap");
      const auto scans = mcap.add_channel(mcap.add_schema("velodyne_msgs/msg/VelodyneScan", "ros2msg", ""), "/velodyne_packets", "cdr");
      const auto truth = mcap.add_channel(mcap.add_schema("nav_msgs/msg/Odometry", "ros2msg", ""), "/ground_truth", "cdr");
      for (std::size_t i = 0; i < ds.size(); ++i) {
        const std::vector<Column> cols = columns_of(ds.load_frame(i, false), ds.times[i]);
        const std::uint64_t ns = static_cast<std::uint64_t>(to_ns(cols.back().time_s));
        mcap.write(scans, static_cast<std::uint32_t>(i), ns, ns, velodyne_scan(cols));
        const std::uint64_t gt_ns = static_cast<std::uint64_t>(to_ns(ds.times[i]));
        mcap.write(truth, static_cast<std::uint32_t>(i), gt_ns, gt_ns, odometry(ds.times[i], ds.ground_truth.poses[i]));
      }
      // The last sweep begins just after the last scan's time: one more pose, the last step again.
      const std::size_t n = ds.size();
      const pl::Pose step = ds.ground_truth.poses[n - 2].inverse() * ds.ground_truth.poses[n - 1];
      const double after = 2 * ds.times[n - 1] - ds.times[n - 2];
      const std::uint64_t ns = static_cast<std::uint64_t>(to_ns(after));
      mcap.write(truth, static_cast<std::uint32_t>(n), ns, ns, odometry(after, pl::Pose(ds.ground_truth.poses[n - 1] * step)));
      mcap.close();
    }
    pl::test::write_file(t + "/VLP16.yaml", vt::calibration_yaml(kLasers, [](int i) {
                           vt::LaserCal c;
                           c.elevation_deg = -15 + 2 * i;
                           return c;
                         }));
  });
  return {dir + "/drive.mcap", dir + "/VLP16.yaml", dir + "/sim"};
}

TEST(PacketRecording, InfoNamesTheSensorAndItsSweeps) {
  const PacketDrive d = packet_drive();
  const auto r = pl::test::run(pl::test::tool("pl-dataset") + " info " + d.mcap + " --lidar-calibration " + d.calibration +
                               " --truth-topic /ground_truth");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("lidar packets  Velodyne VLP-16, 16 channels, 10.0 Hz: 40 sweeps from 3000 packets (0 skipped)"), std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find("/velodyne_packets"), std::string::npos) << r.output;
  // Without the calibration it needs, the recording is refused with the flag that gives it.
  const auto no_cal = pl::test::run(pl::test::tool("pl-dataset") + " info " + d.mcap);
  EXPECT_NE(no_cal.exit_code, 0);
  EXPECT_NE(no_cal.output.find("--lidar-calibration"), std::string::npos) << no_cal.output;
}

TEST(PacketRecording, MapBuiltFromPacketsAndTheDriveLocalizedOnIt) {
  const PacketDrive d = packet_drive();
  const pl::test::TempDir dir;
  const std::string data = " --dataset " + d.mcap + " --lidar-calibration " + d.calibration + " --truth-topic /ground_truth --deskew off";
  auto sh = [](const std::string& cmd) {
    const auto r = pl::test::run(cmd);
    EXPECT_EQ(r.exit_code, 0) << cmd << "\n" << r.output;
    return r.output;
  };
  sh(pl::test::tool("pl-map") + " build" + data + " --poses gt --out " + (dir / "map.pcd"));
  sh(pl::test::tool("pl-map") + " tile --cloud " + (dir / "map.pcd") + " --db " + (dir / "maps.sqlite") + " --map town --origin 49.0,8.4,110");
  sh(pl::test::tool("pl-map") + " publish --db " + (dir / "maps.sqlite") + " --map town --version 1");
  const std::string out = sh(pl::test::tool("pl-localize") + data + " --db " + (dir / "maps.sqlite") +
                             " --map town --init gt --out " + (dir / "poses.tum") + " --kitti-out " + (dir / "poses.txt"));
  EXPECT_NE(out.find(" 0 lost"), std::string::npos) << out;
  sh(pl::test::tool("pl-dataset") + " poses " + d.mcap + " --lidar-calibration " + d.calibration + " --truth-topic /ground_truth --out " +
     (dir / "gt.txt"));
  const auto e = pl::test::run(pl::test::tool("pl-eval") + " ape --json --est " + (dir / "poses.txt") + " --gt " + (dir / "gt.txt"));
  ASSERT_EQ(e.exit_code, 0) << e.output;
  const auto j = nlohmann::json::parse(e.output.substr(e.output.find('{')));
  EXPECT_GE(j["matched"].get<int>(), 38);
  EXPECT_LT(j["mean"].get<double>(), 0.02) << j.dump();
}

}  // namespace
