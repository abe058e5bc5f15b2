// Cloud files read and written: PCD (ascii, binary, doubles) and PLY round trips, clear errors, and
// the in-memory parsers against the file readers.
#include <gtest/gtest.h>

#include <string>

#include "pl/common/cloud_io.hpp"
#include "pl/common/error.hpp"
#include "pl/common/scan.hpp"
#include "cloud_files.hpp"
#include "test_util.hpp"

namespace {

using pl::test::TempDir;
using pl::test::write_file;
using pl::test::cloud_files::contains;
using pl::test::cloud_files::error_of;
using pl::test::cloud_files::parse_error;

TEST(CloudIo, PcdBinaryRoundTrip) {
  TempDir dir;
  pl::Points3d pts = {Eigen::Vector3d(1.25, -2.5, 0.125), Eigen::Vector3d(1500.5, 2200.25, -3.0)};
  pl::write_pcd(dir / "a.pcd", pts, {0.5f, 0.25f});
  pl::Cloud c = pl::read_cloud(dir / "a.pcd");
  ASSERT_EQ(c.size(), 2u);
  EXPECT_TRUE(c.points[1].isApprox(pts[1]));
  EXPECT_FLOAT_EQ(c.intensity[0], 0.5f);
  EXPECT_THROW(pl::write_pcd(dir / "far.pcd", {Eigen::Vector3d(4.0e5, 5.0e6, 0)}, {}), pl::Error);
}

TEST(CloudIo, PcdAsciiWithExtraFieldsAndDoubles) {
  TempDir dir;
  write_file(dir / "a.pcd",
             "# .PCD v0.7\nVERSION 0.7\nFIELDS rgb x y z intensity\nSIZE 4 8 8 8 4\nTYPE U F F F F\nCOUNT 1 1 1 1 1\n"
             "WIDTH 2\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 2\nDATA ascii\n7 1.5 2.5 3.5 0.9\n8 -1 -2 -3 0.1\n");
  pl::Cloud c = pl::read_cloud(dir / "a.pcd");
  ASSERT_EQ(c.size(), 2u);
  EXPECT_EQ(c.points[0], Eigen::Vector3d(1.5, 2.5, 3.5));
  EXPECT_FLOAT_EQ(c.intensity[1], 0.1f);
}

TEST(CloudIo, PcdBinaryWithDoubles) {
  TempDir dir;
  std::string body = "VERSION 0.7\nFIELDS x y z\nSIZE 8 8 8\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 1\nHEIGHT 1\nPOINTS 1\nDATA binary\n";
  double v[3] = {412345.125, 5412345.5, 101.25};  // far from the origin: doubles keep it exact
  body.append(reinterpret_cast<const char*>(v), sizeof(v));
  write_file(dir / "d.pcd", body);
  pl::Cloud c = pl::read_cloud(dir / "d.pcd");
  EXPECT_EQ(c.points[0], Eigen::Vector3d(412345.125, 5412345.5, 101.25));
  EXPECT_TRUE(c.intensity.empty());
}

TEST(CloudIo, PlyAsciiAndBinary) {
  TempDir dir;
  write_file(dir / "a.ply",
             "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\n"
             "property uchar intensity\nelement face 0\nproperty list uchar int vertex_indices\nend_header\n1 2 3 200\n4 5 6 100\n");
  pl::Cloud a = pl::read_cloud(dir / "a.ply");
  ASSERT_EQ(a.size(), 2u);
  EXPECT_EQ(a.points[1], Eigen::Vector3d(4, 5, 6));
  EXPECT_FLOAT_EQ(a.intensity[0], 200.f);
  std::string body = "ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty double x\nproperty double y\nproperty double z\nend_header\n";
  double v[3] = {-7.5, 8.25, 9.0};
  body.append(reinterpret_cast<const char*>(v), sizeof(v));
  write_file(dir / "b.ply", body);
  EXPECT_EQ(pl::read_cloud(dir / "b.ply").points[0], Eigen::Vector3d(-7.5, 8.25, 9.0));
}

TEST(CloudIo, ClearErrors) {
  TempDir dir;
  write_file(dir / "noz.pcd", "FIELDS x y\nSIZE 4 4\nTYPE F F\nCOUNT 1 1\nWIDTH 1\nPOINTS 1\nDATA ascii\n1 2\n");
  EXPECT_NE(error_of(dir / "noz.pcd").find("needs x, y and z"), std::string::npos);
  write_file(dir / "zstd.pcd", "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 1\nPOINTS 1\nDATA binary_zstd\n");
  EXPECT_TRUE(contains(error_of(dir / "zstd.pcd"),
                       "zstd.pcd: PCD DATA binary_zstd is not supported (ascii, binary or binary_compressed)"));
  write_file(dir / "short.pcd", "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 5\nPOINTS 5\nDATA binary\nabc");
  EXPECT_NE(error_of(dir / "short.pcd").find("truncated"), std::string::npos);
  write_file(dir / "x.xyz", "1 2 3\n");
  EXPECT_NE(error_of(dir / "x.xyz").find("unknown cloud format"), std::string::npos);
  write_file(dir / "bad.ply", "ply\nformat binary_big_endian 1.0\nelement vertex 1\nend_header\n");
  EXPECT_NE(error_of(dir / "bad.ply").find("binary_big_endian is not supported"), std::string::npos);
  EXPECT_NE(error_of(dir / "missing.pcd").find("cannot open"), std::string::npos);
}

TEST(CloudIo, InMemoryParsersMatchTheFileReaders) {
  TempDir dir;
  pl::Points3d pts = {Eigen::Vector3d(1.25, -2.5, 0.125), Eigen::Vector3d(15.5, 22.25, -3.0)};
  pl::write_pcd(dir / "a.pcd", pts, {0.5f, 0.25f}, pl::GeoPoint{49.0, 8.4, 100.0});
  const std::string bytes = pl::test::read_file(dir / "a.pcd");
  const pl::Cloud from_file = pl::read_pcd(dir / "a.pcd"), from_bytes = pl::parse_pcd(bytes, "a.pcd");
  EXPECT_EQ(from_bytes.points, from_file.points);
  EXPECT_EQ(from_bytes.intensity, from_file.intensity);
  ASSERT_TRUE(from_bytes.origin.has_value());
  EXPECT_EQ(pl::parse_cloud(bytes, "x/A.PCD").points, from_file.points);
  const std::string ply = "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\n1 2 3\n";
  EXPECT_EQ(pl::parse_ply(ply, "a.ply").points[0], Eigen::Vector3d(1, 2, 3));
  pl::Scan scan = {{1.5f, -2.25f, 0.125f, 0.5f}};
  pl::write_kitti_bin(dir / "0.bin", scan);
  const pl::Scan back = pl::parse_kitti_bin(pl::test::read_file(dir / "0.bin"), "0.bin");
  ASSERT_EQ(back.size(), 1u);
  EXPECT_EQ(back[0].y, -2.25f);
  EXPECT_FLOAT_EQ(pl::parse_cloud(pl::test::read_file(dir / "0.bin"), "0.bin").intensity[0], 0.5f);
  EXPECT_TRUE(contains(parse_error("1 2 3", "a.xyz"), "a.xyz: unknown cloud format"));
}

}  // namespace
