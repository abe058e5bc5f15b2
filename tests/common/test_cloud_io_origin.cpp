// The geodetic origin of a PCD: the "# origin" comment, the origin file beside the cloud, and the two
// checked against each other.
#include <gtest/gtest.h>

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <utility>
#include <vector>

#include "pl/common/cloud_io.hpp"
#include "pl/common/error.hpp"
#include "cloud_files.hpp"
#include "test_util.hpp"

namespace {

using pl::test::TempDir;
using pl::test::write_file;
using pl::test::cloud_files::contains;
using pl::test::cloud_files::error_of;
using pl::test::cloud_files::kPclXyziCompressed;

TEST(CloudIo, PcdRecordsTheOrigin) {
  TempDir dir;
  pl::write_pcd(dir / "o.pcd", {Eigen::Vector3d(1, 2, 3)}, {}, pl::GeoPoint{49.0112128044, 8.4228850418, 112.83});
  pl::Cloud c = pl::read_cloud(dir / "o.pcd");
  ASSERT_TRUE(c.origin.has_value());
  EXPECT_DOUBLE_EQ(c.origin->lat_deg, 49.0112128044);
  EXPECT_DOUBLE_EQ(c.origin->alt_m, 112.83);
  pl::write_pcd(dir / "n.pcd", {Eigen::Vector3d(1, 2, 3)}, {});
  EXPECT_FALSE(pl::read_cloud(dir / "n.pcd").origin.has_value());
}

TEST(CloudIo, PcdOriginFileBesideTheCloud) {
  TempDir dir;
  const pl::Points3d pts = {Eigen::Vector3d(1, 2, 3)};
  // More decimals than the comment keeps: the origin file has them all.
  const pl::GeoPoint origin{49.01121280441234, 8.42288504187654, 112.83456};
  pl::write_pcd(dir / "map.pcd", pts, {}, origin);
  const auto json = nlohmann::json::parse(pl::test::read_file(dir / "map.pcd.origin.json"));
  EXPECT_EQ(json.at("lat").get<double>(), origin.lat_deg);
  EXPECT_EQ(json.at("lon").get<double>(), origin.lon_deg);
  EXPECT_EQ(json.at("alt").get<double>(), origin.alt_m);
  EXPECT_EQ(json.at("frame"), "ENU");
  auto expect_origin = [&](const std::string& path) {
    const pl::Cloud c = pl::read_cloud(path);
    ASSERT_TRUE(c.origin.has_value()) << path;
    EXPECT_EQ(c.origin->lat_deg, origin.lat_deg);
    EXPECT_EQ(c.origin->lon_deg, origin.lon_deg);
    EXPECT_EQ(c.origin->alt_m, origin.alt_m);
  };
  expect_origin(dir / "map.pcd");
  // Saved again by PCL or Open3D: the comment is gone, the origin file still gives the origin.
  std::string bytes = pl::test::read_file(dir / "map.pcd");
  const std::size_t comment = bytes.find("# origin ");
  ASSERT_NE(comment, std::string::npos);
  bytes.erase(comment, bytes.find('\n', comment) + 1 - comment);
  write_file(dir / "map.pcd", bytes);
  expect_origin(dir / "map.pcd");
  EXPECT_FALSE(pl::parse_pcd(bytes, dir / "map.pcd").origin.has_value());  // bytes have no file beside them
  // A PCL file with an origin file beside it.
  write_file(dir / "pcl.pcd", kPclXyziCompressed);
  write_file(dir / "pcl.pcd.origin.json", pl::test::read_file(dir / "map.pcd.origin.json"));
  expect_origin(dir / "pcl.pcd");
  // The comment and the origin file agree within 1e-9 degrees and 1 mm: the file's full precision wins.
  write_file(dir / "near.pcd", "# origin 49.0112128044 8.4228850419 112.8350\n" + kPclXyziCompressed);
  write_file(dir / "near.pcd.origin.json", pl::test::read_file(dir / "map.pcd.origin.json"));
  expect_origin(dir / "near.pcd");
  // Written again without an origin: the old origin file goes with the old cloud.
  pl::write_pcd(dir / "map.pcd", pts, {});
  EXPECT_FALSE(std::filesystem::exists(dir / "map.pcd.origin.json"));
  EXPECT_FALSE(pl::read_pcd(dir / "map.pcd").origin.has_value());
}

TEST(CloudIo, PcdOriginFileAndCommentMustAgree) {
  TempDir dir;
  const pl::Points3d pts = {Eigen::Vector3d(1, 2, 3)};
  pl::write_pcd(dir / "a.pcd", pts, {}, pl::GeoPoint{49.0, 8.4, 100.0});
  pl::write_pcd(dir / "b.pcd", pts, {}, pl::GeoPoint{48.0, 11.5, 520.0});
  // a.pcd next to b.pcd's origin file: the mistake to catch, naming both files.
  std::filesystem::copy_file(dir / "b.pcd.origin.json", dir / "a.pcd.origin.json",
                             std::filesystem::copy_options::overwrite_existing);
  const std::string message = error_of(dir / "a.pcd");
  EXPECT_TRUE(
      contains(message, dir / "a.pcd.origin.json records the origin lat 48.0000000000 lon 11.5000000000 alt 520.0000 but the "
                              "\"# origin\" comment of " +
                            (dir / "a.pcd") + " says lat 49.0000000000 lon 8.4000000000 alt 100.0000"));
  EXPECT_TRUE(contains(message, "one of the two belongs to another map; delete the wrong one"));
  // 2 mm up, or 2e-9 degrees north, is another origin.
  write_file(dir / "a.pcd.origin.json", R"({"lat": 49.0, "lon": 8.4, "alt": 100.002, "frame": "ENU"})");
  EXPECT_TRUE(
      contains(error_of(dir / "a.pcd"), "a.pcd.origin.json records the origin lat 49.0000000000 lon 8.4000000000 alt 100.0020"));
  write_file(dir / "a.pcd.origin.json", R"({"lat": 49.000000002, "lon": 8.4, "alt": 100.0, "frame": "ENU"})");
  EXPECT_TRUE(contains(error_of(dir / "a.pcd"), "but the \"# origin\" comment of"));
  write_file(dir / "a.pcd.origin.json",
             R"({"lat": 49.0000000005, "lon": 8.4, "alt": 100.0009})");  // within: "frame" may be left out
  EXPECT_EQ(pl::read_pcd(dir / "a.pcd").origin->alt_m, 100.0009);
  // A malformed origin file is an error naming it, never a silent fallback to the comment.
  const std::vector<std::pair<std::string, std::string>> bad = {
      {R"({"lat": 49.0, "lon": 8.4})", "a.pcd.origin.json: missing \"alt\""},
      {R"({"lat": "49", "lon": 8.4, "alt": 1})", "a.pcd.origin.json: \"lat\" must be a number, not a JSON string"},
      {R"({"lat": 49.0, "lon": 8.4, "alt": 1, "frame": "NED"})",
       "a.pcd.origin.json: \"frame\" must be \"ENU\" (the cloud's x east, y north, z up about the origin), found \"NED\""},
      {R"({"lat": 91.0, "lon": 8.4, "alt": 1})",
       "a.pcd.origin.json: the origin must have lat in [-90, 90] and lon in [-180, 180] degrees"},
      {R"({"lat": 1e400, "lon": 8.4, "alt": 1})", "a.pcd.origin.json: not valid JSON"},
      {"[49, 8.4, 100]",
       "a.pcd.origin.json: not an origin (expected {\"lat\": DEGREES, \"lon\": DEGREES, \"alt\": METRES, \"frame\": \"ENU\"})"},
      {"49 8.4 100", "a.pcd.origin.json: not valid JSON"}};
  for (const auto& [text, expected] : bad) {
    write_file(dir / "a.pcd.origin.json", text);
    EXPECT_TRUE(contains(error_of(dir / "a.pcd"), expected)) << text;
  }
  std::filesystem::remove(dir / "a.pcd.origin.json");
  std::filesystem::create_directories(dir / "a.pcd.origin.json");
  EXPECT_TRUE(contains(error_of(dir / "a.pcd"), "a.pcd.origin.json: cannot read (Is a directory)"));
  // write_pcd refuses an origin it could not read back.
  EXPECT_THROW(pl::write_pcd(dir / "c.pcd", pts, {}, pl::GeoPoint{95.0, 8.4, 0.0}), pl::Error);
}

}  // namespace
