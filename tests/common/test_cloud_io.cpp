#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>

#include "pl/common/cloud_io.hpp"
#include "pl/common/error.hpp"
#include "pl/common/scan.hpp"
#include "test_util.hpp"

using pl::test::TempDir;
using pl::test::write_file;

namespace {
std::string error_of(const std::string& path) {
  try {
    pl::read_cloud(path);
  } catch (const pl::Error& e) {
    return e.what();
  }
  return "(no error)";
}

// Whether an error message says what it should; on failure the test shows both.
testing::AssertionResult contains(const std::string& message, const std::string& part) {
  if (message.find(part) != std::string::npos) return testing::AssertionSuccess();
  return testing::AssertionFailure() << "the message \"" << message << "\"\ndoes not contain \"" << part << "\"";
}

// The message of parsing these bytes as the file `name` (by its extension), or "(no error)".
std::string parse_error(const std::string& bytes, const std::string& name) {
  try {
    pl::parse_cloud(bytes, name);
  } catch (const pl::Error& e) {
    return e.what();
  }
  return "(no error)";
}

template <typename T>
std::string raw(std::initializer_list<T> values) {
  std::string out;
  for (T v : values) out.append(reinterpret_cast<const char*>(&v), sizeof(T));
  return out;
}

// A PCD header with one line per key (COUNT left out when empty) and DATA last.
std::string pcd_header(const std::string& fields, const std::string& sizes, const std::string& types,
                       const std::string& counts, const std::string& rest) {
  return "FIELDS " + fields + "\nSIZE " + sizes + "\nTYPE " + types + "\n" + (counts.empty() ? "" : "COUNT " + counts + "\n") + rest;
}
}  // namespace

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
  write_file(dir / "lzf.pcd", "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 1\nPOINTS 1\nDATA binary_compressed\n");
  EXPECT_NE(error_of(dir / "lzf.pcd").find("pcl_convert_pcd_ascii_binary"), std::string::npos);
  write_file(dir / "short.pcd", "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 5\nPOINTS 5\nDATA binary\nabc");
  EXPECT_NE(error_of(dir / "short.pcd").find("truncated"), std::string::npos);
  write_file(dir / "x.xyz", "1 2 3\n");
  EXPECT_NE(error_of(dir / "x.xyz").find("unknown cloud format"), std::string::npos);
  write_file(dir / "bad.ply", "ply\nformat binary_big_endian 1.0\nelement vertex 1\nend_header\n");
  EXPECT_NE(error_of(dir / "bad.ply").find("binary_big_endian is not supported"), std::string::npos);
  EXPECT_NE(error_of(dir / "missing.pcd").find("cannot open"), std::string::npos);
}

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

// The regressions below are the classes of the fuzzers' findings (tests/fuzz/regressions/pcd, ply,
// kitti_bin): each input was a crash, undefined behaviour, a multi-gigabyte allocation or a cloud
// with non-finite values before the readers checked it.

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

TEST(CloudIo, PcdHeaderLinesOfWhitespaceAreBlankLines) {
  // A line of spaces and tabs has no key: it was read as one (words[0] of nothing).
  const std::string pcd = "VERSION 0.7\n \t\n" + pcd_header("x y z", "4 4 4", "F F F", "", "  \nPOINTS 1\nDATA ascii\n1 2 3\n");
  EXPECT_EQ(pl::parse_pcd(pcd, "w.pcd").points.at(0), Eigen::Vector3d(1, 2, 3));
  EXPECT_TRUE(contains(parse_error(" \n", "w.pcd"), "w.pcd: header has no DATA line"));
}

TEST(CloudIo, PcdFieldDescriptionsMustBeCompleteAndDecodable) {
  const std::string body = "POINTS 1\nDATA ascii\n1 2 3 4\n";
  // COUNT shorter than FIELDS: the missing counts were read past the end of their array.
  EXPECT_TRUE(contains(parse_error(pcd_header("x y z rgb", "4 4 4 4", "F F F U", "1", body), "c.pcd"),
              "c.pcd: FIELDS names 4 fields but SIZE has 4 values, TYPE 4 and COUNT 1: give one SIZE, TYPE and COUNT per field"));
  // COUNT 0 or negative (atoi): ascii columns past the end of the line, offsets wrapping around.
  EXPECT_TRUE(contains(parse_error(pcd_header("x y z", "4 4 4", "F F F", "1 1 0", body), "c.pcd"),
              "field \"z\" has COUNT \"0\": expected a whole number >= 1"));
  EXPECT_TRUE(contains(parse_error(pcd_header("x y z", "4 4 4", "F F F", "1 -1 1", body), "c.pcd"), "field \"y\" has COUNT \"-1\""));
  // SIZE negative or not decodable for its TYPE: a pointer before the record, or a silent NaN.
  const std::string expected = "which this reader cannot decode (F with SIZE 4 or 8, I or U with SIZE 1, 2, 4 or 8)";
  EXPECT_TRUE(contains(parse_error(pcd_header("x y z", "4 -8 4", "F F F", "", body), "s.pcd"), "field \"y\" is TYPE F SIZE -8, " + expected));
  EXPECT_TRUE(contains(parse_error(pcd_header("x y z i", "4 4 4 2", "F F F F", "", body), "s.pcd"), "field \"i\" is TYPE F SIZE 2"));
  EXPECT_TRUE(contains(parse_error(pcd_header("x y z", "4 4 4", "F F Q", "", body), "s.pcd"), "field \"z\" is TYPE Q SIZE 4"));
  EXPECT_TRUE(contains(parse_error(pcd_header("x y z", "4 4 4", "F F F", "", "WIDTH many\n" + body), "s.pcd"),
              "s.pcd: PCD WIDTH needs one whole number >= 0, found \"many\""));
  EXPECT_TRUE(contains(parse_error("FIELDS x y z\n" + pcd_header("x y z", "4 4 4", "F F F", "", body), "s.pcd"),
              "s.pcd: PCD header has FIELDS twice"));
}

TEST(CloudIo, TruncatedBinaryBodiesNameTheBytesMissing) {
  const std::string header = pcd_header("x y z intensity", "4 4 4 4", "F F F F", "", "POINTS 1000000\nDATA binary\n");
  EXPECT_TRUE(contains(parse_error(header + std::string(48, '\0'), "x.pcd"),
              "x.pcd: POINTS 1000000 needs 16000000 bytes of binary data (16 a point), the file has 48 after the header (truncated?)"));
  const std::string ply = "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty double x\nproperty double y\nproperty double z\nend_header\n";
  EXPECT_TRUE(contains(parse_error(ply + std::string(50, '\0'), "m.ply"),
              "m.ply: element vertex 3 needs 72 bytes of binary data (24 a point), the file has 50 after the header (truncated?)"));
  EXPECT_TRUE(contains(parse_error(std::string(20, '\0'), "0.bin"), "0.bin: size 20 bytes is not a whole number of points"));
}

TEST(CloudIo, OverflowingCountsAreRefused) {
  // POINTS x stride wrapping around 2^64 to a few bytes made the size check pass.
  const std::string xyz = pcd_header("x y z", "4 4 4", "F F F", "", "");
  EXPECT_TRUE(contains(parse_error(xyz + "POINTS 1537228672809129302\nDATA binary\n" + std::string(8, '\0'), "o.pcd"),
              "o.pcd: POINTS 1537228672809129302 needs more than 2^64 bytes of binary data"));
  EXPECT_TRUE(contains(parse_error(xyz + "WIDTH 4294967296\nHEIGHT 4294967297\nDATA binary\n", "o.pcd"),
              "o.pcd: WIDTH 4294967296 x HEIGHT 4294967297 overflows"));
  EXPECT_TRUE(contains(parse_error(xyz + "POINTS 18446744073709551616\nDATA binary\n", "o.pcd"), "PCD POINTS needs one whole number >= 0"));
  // SIZE x COUNT overflowed int.
  EXPECT_TRUE(contains(parse_error(pcd_header("x y z", "4 4 4", "F F F", "1 1 1000000000", "POINTS 1\nDATA binary\n") + std::string(12, '\0'), "o.pcd"),
              "needs 4000000008 bytes of binary data"));
  EXPECT_TRUE(contains(parse_error(pcd_header("x y z", "8 8 8", "F F F", "1 1 4611686018427387904", "POINTS 1\nDATA binary\n"), "o.pcd"),
              "o.pcd: field \"z\" has COUNT 4611686018427387904: the record size overflows"));
  const std::string ply = "ply\nformat binary_little_endian 1.0\nelement vertex 1537228672809129302\nproperty float x\nproperty float y\n"
                          "property float z\nend_header\n";
  EXPECT_TRUE(contains(parse_error(ply + std::string(8, '\0'), "o.ply"), "o.ply: element vertex 1537228672809129302 needs more than 2^64 bytes"));
  EXPECT_TRUE(contains(parse_error("ply\nformat ascii 1.0\nelement vertex -1\nproperty float x\nend_header\n", "o.ply"),
              "o.ply: expected \"element NAME COUNT\" (COUNT a whole number >= 0), found \"element vertex -1\""));
}

TEST(CloudIo, DeclaredCountsBeyondTheBytesAllocateNothing) {
  // A few bytes declaring 10^8 points made the reader allocate gigabytes before it found the body short.
  const std::string xyz = pcd_header("x y z", "4 4 4", "F F F", "", "");
  EXPECT_TRUE(contains(parse_error(xyz + "POINTS 100000000\nDATA binary\n" + std::string(48, '\0'), "b.pcd"),
              "b.pcd: POINTS 100000000 needs 1200000000 bytes of binary data (12 a point), the file has 48"));
  EXPECT_TRUE(contains(parse_error(xyz + "POINTS 200000000\nDATA ascii\n1 2 3\n", "b.pcd"),
              "b.pcd: POINTS 200000000 needs at least 1199999999 bytes of ascii data (a line of 3 values a point), the file has 6"));
  EXPECT_TRUE(contains(parse_error("ply\nformat ascii 1.0\nelement vertex 1000000000\nproperty float x\nproperty float y\nproperty float z\n"
                          "end_header\n1 2 3\n",
                          "b.ply"),
              "b.ply: element vertex 1000000000 needs at least 5999999999 bytes of ascii data"));
  // An ascii body with just enough bytes still ends short of the points: a clear truncation.
  EXPECT_TRUE(contains(parse_error(xyz + "POINTS 3\nDATA ascii\n1 2 3 4 5 6 7 8 9 10 11 12 13 14\n", "b.pcd"),
              "b.pcd: truncated: expected 3 points, found 1"));
}

TEST(CloudIo, NonFiniteValuesAreRefused) {
  const std::string xyzi = pcd_header("x y z intensity", "4 4 4 4", "F F F F", "", "POINTS 1\nDATA binary\n");
  EXPECT_TRUE(contains(parse_error(xyzi + raw<float>({1, 2, 3, NAN}), "n.pcd"), "n.pcd: point 1 has an intensity that is not a finite float32 value"));
  EXPECT_TRUE(contains(parse_error(xyzi + raw<float>({1, INFINITY, 3, 0}), "n.pcd"), "n.pcd: point 1 has a non-finite coordinate"));
  const std::string xyzd = pcd_header("x y z intensity", "4 4 4 8", "F F F F", "", "POINTS 1\nDATA binary\n");
  EXPECT_TRUE(contains(parse_error(xyzd + raw<float>({1, 2, 3}) + raw<double>({1e300}), "n.pcd"), "not a finite float32 value"));
  EXPECT_TRUE(contains(parse_error(pcd_header("x y z intensity", "4 4 4 4", "F F F F", "", "POINTS 1\nDATA ascii\n1 2 3 nan\n"), "n.pcd"),
              "n.pcd: point 1 has an intensity that is not a number"));
  EXPECT_TRUE(contains(parse_error("# origin 1000 8.4 100\n" + pcd_header("x y z", "4 4 4", "F F F", "", "POINTS 0\nDATA ascii\n"), "n.pcd"),
              "n.pcd: \"# origin LAT LON ALT\" must have lat in [-90, 90] and lon in [-180, 180] degrees"));
  const std::string ply = "ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\n"
                          "property float intensity\nend_header\n";
  EXPECT_TRUE(contains(parse_error(ply + raw<float>({1, 2, 3, NAN}), "n.ply"), "n.ply: point 1 has an intensity that is not a finite float32 value"));
  EXPECT_TRUE(contains(parse_error(raw<float>({1, 2, 3, NAN}), "000000.bin"), "000000.bin: point 0 has a non-finite reflectance"));
  EXPECT_TRUE(contains(parse_error(raw<float>({1, NAN, 3, 0}), "000000.bin"), "000000.bin: point 0 has a non-finite coordinate"));
}

TEST(CloudIo, PlyVertexElementMustComeFirst) {
  // The camera's record would have been read as the first vertex.
  const std::string ply = "ply\nformat binary_little_endian 1.0\nelement camera 1\nproperty float view_x\nelement vertex 1\n"
                          "property float x\nproperty float y\nproperty float z\nend_header\n" + std::string(16, '\0');
  EXPECT_TRUE(contains(parse_error(ply, "c.ply"), "c.ply: PLY element camera comes before the vertex element; the vertex element must come first"));
}

TEST(CloudIo, AFolderIsNotACloud) {
  // A folder opens like a file on Linux; its "size" is not bytes present.
  TempDir dir;
  std::filesystem::create_directories(dir / "scan.bin");
  std::filesystem::create_directories(dir / "map.pcd");
  EXPECT_TRUE(contains(error_of(dir / "scan.bin"), "scan.bin: not a regular file"));
  EXPECT_TRUE(contains(error_of(dir / "map.pcd"), "map.pcd: cannot read (Is a directory)"));
}
