// Malformed cloud files. The tests here are the classes of the fuzzers' findings
// (tests/fuzz/regressions/pcd, ply, kitti_bin): each input was a crash, undefined behaviour, a
// multi-gigabyte allocation or a cloud with non-finite values before the readers checked it.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <string>

#include "pl/common/cloud_io.hpp"
#include "cloud_files.hpp"
#include "test_util.hpp"

namespace {

using pl::test::TempDir;
using pl::test::cloud_files::contains;
using pl::test::cloud_files::error_of;
using pl::test::cloud_files::parse_error;
using pl::test::cloud_files::pcd_header;
using pl::test::cloud_files::raw;

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
  // A PCD point without a finite position is a point without a return, dropped (test_cloud_io_pcl.cpp); a PLY has no such convention.
  EXPECT_EQ(pl::parse_pcd(xyzi + raw<float>({1, INFINITY, 3, 0}), "n.pcd").size(), 0u);
  const std::string xyzd = pcd_header("x y z intensity", "4 4 4 8", "F F F F", "", "POINTS 1\nDATA binary\n");
  EXPECT_TRUE(contains(parse_error(xyzd + raw<float>({1, 2, 3}) + raw<double>({1e300}), "n.pcd"), "not a finite float32 value"));
  EXPECT_TRUE(contains(parse_error(pcd_header("x y z intensity", "4 4 4 4", "F F F F", "", "POINTS 1\nDATA ascii\n1 2 3 nan\n"), "n.pcd"),
              "n.pcd: point 1 has an intensity that is not a number"));
  EXPECT_TRUE(contains(parse_error("# origin 1000 8.4 100\n" + pcd_header("x y z", "4 4 4", "F F F", "", "POINTS 0\nDATA ascii\n"), "n.pcd"),
              "n.pcd: \"# origin LAT LON ALT\" must have lat in [-90, 90] and lon in [-180, 180] degrees"));
  const std::string ply = "ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\n"
                          "property float intensity\nend_header\n";
  EXPECT_TRUE(contains(parse_error(ply + raw<float>({1, 2, 3, NAN}), "n.ply"), "n.ply: point 1 has an intensity that is not a finite float32 value"));
  EXPECT_TRUE(contains(parse_error(ply + raw<float>({NAN, 2, 3, 0}), "n.ply"), "n.ply: point 1 has a non-finite coordinate"));
  EXPECT_TRUE(
      contains(parse_error("ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\n"
                           "end_header\nnan 2 3\n",
                           "n.ply"),
               "n.ply: point 1 has a coordinate that is not a number"));
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

}  // namespace
