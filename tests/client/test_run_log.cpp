// The run log (pl/client/run_log.hpp) on hand-made inputs, read back with this project's MCAP reader:
// channels and schema names, the JSON of each, points placed in the map frame, /map written only when
// the tiles change. tests/client/run_log/ reads a whole pl-localize --log run with @mcap/core.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstring>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "error_of.hpp"
#include "pl/client/run_log.hpp"
#include "pl/common/pose.hpp"
#include "pl/recordings/bag.hpp"
#include "test_util.hpp"

namespace {

using nlohmann::json;

std::string unbase64(const std::string& s) {
  static const std::string abc = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  std::uint32_t v = 0;
  int bits = 0;
  for (char c : s) {
    if (c == '=') break;
    const auto k = abc.find(c);
    if (k == std::string::npos) throw std::runtime_error("not base64");
    v = (v << 6) | static_cast<std::uint32_t>(k);
    bits += 6;
    if (bits >= 8) {
      bits -= 8;
      out.push_back(static_cast<char>((v >> bits) & 0xff));
    }
  }
  return out;
}

std::vector<Eigen::Vector3f> points_of(const json& cloud) {
  const std::string raw = unbase64(cloud.at("data").get<std::string>());
  const std::size_t stride = cloud.at("point_stride").get<std::size_t>();
  EXPECT_EQ(raw.size() % stride, 0u);
  std::vector<Eigen::Vector3f> out;
  for (std::size_t at = 0; at + stride <= raw.size(); at += stride) {
    float v[3];
    std::memcpy(v, raw.data() + at, sizeof v);
    out.emplace_back(v[0], v[1], v[2]);
  }
  return out;
}

pl::client::MapTile tile(int tx, int ty, const std::string& hash, std::size_t points) {
  auto cloud = std::make_shared<pl::TileCloud>();
  for (std::size_t i = 0; i < points; ++i) cloud->points.emplace_back(tx * 20.0 + 0.7 * static_cast<double>(i), ty * 20.0, 1.0);
  pl::client::MapTile t;
  t.key = pl::TileKey{tx, ty};
  t.hash = hash;
  t.cloud = cloud;
  return t;
}

// Every message of the log, by topic, parsed.
std::map<std::string, std::vector<std::pair<std::int64_t, json>>> read_log(const std::string& path,
                                                                           std::map<std::string, std::string>* types = nullptr) {
  auto r = pl::bag::open_mcap(pl::bag::map_file(path));
  std::map<std::string, std::vector<std::pair<std::int64_t, json>>> out;
  for (const auto& t : r->topics()) {
    out[t.name];
    if (types) (*types)[t.name] = t.type;
  }
  for (const auto& m : r->messages()) out[r->topics()[m.topic].name].emplace_back(m.time_ns, json::parse(r->read(m)));
  return out;
}

TEST(RunLog, ChannelsOnFoxglovesSchemasWithTheirJson) {
  const pl::test::TempDir dir;
  const std::string path = dir / "run.mcap";
  const Eigen::Isometry3d lidar = pl::make_pose(100.0, -20.0, 2.0, 0.0, 0.0, M_PI / 2);
  {
    pl::client::RunLogOptions o;
    o.scan_voxel_m = 0.01;  // keeps the three points apart
    pl::client::RunLog log(path, o);
    log.pose(1.5, lidar);
    log.pose(1.51, lidar);
    pl::client::ScanReport r;
    r.t = 1.5;
    r.fused = lidar;
    r.health = pl::client::Health::Degraded;
    r.note = "ambiguous";
    r.protection_m = 0.7;
    r.icp.iterations = 12;
    r.icp.inlier_share = 0.8;
    r.map_tiles = 2;
    r.map_points = 20;
    r.register_ms = 4.5;
    const pl::Scan scan{{10, 0, 0, 0.5f}, {0, 10, 0, 0.5f}, {5, 5, 1, 0.5f}};
    log.scan(r, scan, {}, 20.0);
    log.map(1.5, {tile(0, 0, "a", 10), tile(1, 0, "b", 5)});
    log.map(1.6, {tile(1, 0, "b", 5), tile(0, 0, "a", 10)});  // the same tiles: nothing written
    log.map(1.7, {tile(0, 0, "a", 10), tile(1, 0, "c", 4)});  // a tile's content changed
    pl::GpsFix none;
    none.t = 1.4;
    log.gps(none);  // no position: left out
    pl::GpsFix fix;
    fix.t = 1.45;
    fix.position = pl::GeoPoint{49.01, 8.42, 115.0};
    fix.std_m = 0.5;
    fix.status = pl::kGpsFixed;
    log.gps(fix);
    EXPECT_EQ(log.counts().at("/map"), 2u);
    log.close();
  }
  std::map<std::string, std::string> types;
  const auto m = read_log(path, &types);
  EXPECT_EQ(types["/pose"], "json:foxglove.PoseInFrame");
  EXPECT_EQ(types["/tf"], "json:foxglove.FrameTransform");
  EXPECT_EQ(types["/scan"], "json:foxglove.PointCloud");
  EXPECT_EQ(types["/map"], "json:foxglove.PointCloud");
  EXPECT_EQ(types["/gps"], "json:foxglove.LocationFix");
  EXPECT_EQ(types["/health"], "json:pl.ScanReport");
  ASSERT_EQ(m.at("/pose").size(), 2u);
  ASSERT_EQ(m.at("/tf").size(), 2u);
  ASSERT_EQ(m.at("/scan").size(), 1u);
  ASSERT_EQ(m.at("/map").size(), 2u);
  ASSERT_EQ(m.at("/gps").size(), 1u);
  ASSERT_EQ(m.at("/health").size(), 1u);

  const auto& [pose_t, pose] = m.at("/pose")[0];
  EXPECT_EQ(pose_t, 1'500'000'000);
  EXPECT_EQ(pose["timestamp"], json({{"sec", 1}, {"nsec", 500000000}}));
  EXPECT_EQ(pose["frame_id"], "map");
  EXPECT_DOUBLE_EQ(pose["pose"]["position"]["x"].get<double>(), 100.0);
  EXPECT_NEAR(pose["pose"]["orientation"]["z"].get<double>(), std::sqrt(0.5), 1e-12);
  EXPECT_NEAR(pose["pose"]["orientation"]["w"].get<double>(), std::sqrt(0.5), 1e-12);
  const json& tf = m.at("/tf")[1].second;
  EXPECT_EQ(tf["parent_frame_id"], "map");
  EXPECT_EQ(tf["child_frame_id"], "base");
  EXPECT_DOUBLE_EQ(tf["translation"]["y"].get<double>(), -20.0);

  // The scan in the map frame: placed by the LiDAR's pose (turned 90 degrees, at 100, -20, 2).
  const json& cloud = m.at("/scan")[0].second;
  EXPECT_EQ(cloud["frame_id"], "map");
  EXPECT_EQ(cloud["point_stride"], 12);
  EXPECT_EQ(cloud["fields"].size(), 3u);
  EXPECT_EQ(cloud["fields"][2], json({{"name", "z"}, {"offset", 8}, {"type", 7}}));
  const auto pts = points_of(cloud);
  ASSERT_EQ(pts.size(), 3u);
  std::vector<Eigen::Vector3f> want{{100, -10, 2}, {90, -20, 2}, {95, -15, 3}};
  for (const auto& w : want) {
    bool found = false;
    for (const auto& p : pts) found = found || (p - w).norm() < 1e-4;
    EXPECT_TRUE(found) << w.transpose();
  }
  // The map: every tile's points (0.7 m apart, beyond the 0.5 m voxels), then the changed set.
  EXPECT_EQ(points_of(m.at("/map")[0].second).size(), 15u);
  EXPECT_EQ(points_of(m.at("/map")[1].second).size(), 14u);
  EXPECT_EQ(m.at("/map")[1].first, 1'700'000'000);

  const json& gps = m.at("/gps")[0].second;
  EXPECT_DOUBLE_EQ(gps["latitude"].get<double>(), 49.01);
  EXPECT_DOUBLE_EQ(gps["longitude"].get<double>(), 8.42);
  EXPECT_DOUBLE_EQ(gps["altitude"].get<double>(), 115.0);
  EXPECT_DOUBLE_EQ(gps["position_covariance"][0].get<double>(), 0.25);
  EXPECT_EQ(gps["position_covariance_type"], 1);

  const json& h = m.at("/health")[0].second;
  EXPECT_EQ(h["health"], "degraded");
  EXPECT_EQ(h["note"], "ambiguous");
  EXPECT_DOUBLE_EQ(h["protection_m"].get<double>(), 0.7);
  EXPECT_EQ(h["icp"]["iterations"], 12);
  EXPECT_DOUBLE_EQ(h["icp"]["fitness"].get<double>(), 0.8);
  EXPECT_EQ(h["map_tiles"], 2);
  EXPECT_DOUBLE_EQ(h["timing_ms"]["register"].get<double>(), 4.5);
  EXPECT_DOUBLE_EQ(h["timing_ms"]["total"].get<double>(), 20.0);
}

TEST(RunLog, ATimeBefore1970IsRefusedNamingTheFile) {
  const pl::test::TempDir dir;
  pl::client::RunLog log(dir / "run.mcap");
  const std::string e = pl::test::error_of([&] { log.pose(-1.0, Eigen::Isometry3d::Identity()); });
  EXPECT_NE(e.find(dir / "run.mcap"), std::string::npos) << e;
  EXPECT_NE(e.find("cannot be logged"), std::string::npos) << e;
}

}  // namespace
