#include <gtest/gtest.h>
#include <liblzf/lzf.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <limits>
#include <nlohmann/json.hpp>

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

using pl::test::from_hex;

// A binary_compressed body as PCL writes one, from the uncompressed bytes (the values stored field
// after field): the compressed size, the uncompressed size, the LZF data.
std::string lzf_body(const std::string& plain) {
  std::string packed(plain.size() * 2 + 64, '\0');
  const unsigned n =
      lzf_compress(plain.data(), static_cast<unsigned>(plain.size()), packed.data(), static_cast<unsigned>(packed.size()));
  if (n == 0 && !plain.empty()) throw std::runtime_error("lzf_compress failed");
  packed.resize(n);
  return raw<std::uint32_t>({n, static_cast<std::uint32_t>(plain.size())}) + packed;
}

// The cloud the binary_compressed tests expect back.
void expect_cloud(const pl::Cloud& c, const pl::Points3d& points, const std::vector<float>& intensity) {
  EXPECT_EQ(c.points, points);
  EXPECT_EQ(c.intensity, intensity);
}

// What PCL 1.13 (Debian's libpcl-io, pcl::io::savePCDFileBinaryCompressed, savePCDFileBinary,
// savePCDFileASCII) wrote for an organised 3 x 2 pcl::PointXYZI cloud whose second and fifth points
// are NaN (no return), the others (1.5, -2.25, 0.125) 10, (100.75, 200.5, -3) 255.5, (-0.5, 0.25, 7) 3
// and (12, -13.5, 14.25) 65535.
const std::string kPclXyziHeader =
    "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS x y z intensity\nSIZE 4 4 4 4\nTYPE F F F F\n"
    "COUNT 1 1 1 1\nWIDTH 3\nHEIGHT 2\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 6\n";
const std::string kPclXyziCompressed =
    kPclXyziHeader + "DATA binary_compressed\n" +
    from_hex(
        "51000000600000000f0000c03f0000c07f0080c942000000bf600b06004041000010c0600b068048430000803e600b02"
        "0058c12023a00b0040201f01e04080170064202f00202003200001807f202f00402017200002ff7f47");
const std::string kPclXyziBinary =
    kPclXyziHeader + "DATA binary\n" +
    from_hex(
        "0000c03f000010c00000003e000020410000c07f0000c07f0000c07f000000000080c94200804843000040c000807f43"
        "000000bf0000803e0000e040000040400000c07f0000c07f0000c07f0000000000004041000058c10000644100ff7f47");
const std::string kPclXyziAscii = kPclXyziHeader +
                                  "DATA ascii\n1.5 -2.25 0.125 10\nnan nan nan 0\n100.75 200.5 -3 255.5\n-0.5 0.25 7 3\n"
                                  "nan nan nan 0\n12 -13.5 14.25 65535\n";
const pl::Points3d kPclXyziPoints = {Eigen::Vector3d(1.5, -2.25, 0.125), Eigen::Vector3d(100.75, 200.5, -3),
                                     Eigen::Vector3d(-0.5, 0.25, 7), Eigen::Vector3d(12, -13.5, 14.25)};
const std::vector<float> kPclXyziIntensity = {10, 255.5, 3, 65535};
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
  // A PCD point without a finite position is a point without a return, dropped (below); a PLY has no such convention.
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

// ---- binary_compressed, points without a return, POINTS against WIDTH x HEIGHT, the origin file ----

TEST(CloudIo, PcdBinaryCompressedAsPclWritesIt) {
  TempDir dir;
  write_file(dir / "pcl.pcd", kPclXyziCompressed);
  const pl::Cloud c = pl::read_pcd(dir / "pcl.pcd");
  expect_cloud(c, kPclXyziPoints, kPclXyziIntensity);
  EXPECT_FALSE(c.origin.has_value());
  // A driver's record as pcl::PCDWriter writes a pcl::PCLPointCloud2: x y z float32 at 0, 4, 8, a
  // uint16 intensity at 16, a uint8 ring at 18, 24 bytes a point, the second point NaN. In binary the
  // gaps become padding fields "_" (filled with 0xab and 0xcd here); binary_compressed leaves them
  // out. PCL fills the file up to a whole page with zeros: 16 of them stand for that.
  const std::string ring = "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\n";
  const std::string rest = "WIDTH 3\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 3\n";
  const pl::Points3d ring_points = {Eigen::Vector3d(-1.25, 2.5, 0.75), Eigen::Vector3d(30.5, -40.25, 1)};
  write_file(dir / "ring-binary.pcd",
             ring + "FIELDS x y z _ intensity ring _\nSIZE 4 4 4 1 2 1 1\nTYPE F F F U U U U\nCOUNT 1 1 1 4 1 1 5\n" + rest +
                 "DATA binary\n" +
                 from_hex("0000a0bf000020400000403fabababab070000cdcdcdcdcd0000c07f0000c07f0000c07fabababab000001cdcdcdcdcd"
                          "0000f441000021c20000803fabababab60ea0fcdcdcdcdcd") +
                 std::string(16, '\0'));
  expect_cloud(pl::read_pcd(dir / "ring-binary.pcd"), ring_points, {7, 60000});
  write_file(dir / "ring-compressed.pcd",
             ring + "FIELDS x y z intensity ring\nSIZE 4 4 4 2 1\nTYPE F F F U U\nCOUNT 1 1 1 1 1\n" + rest +
                 "DATA binary_compressed\n" +
                 from_hex("280000002d0000000f0000a0bf0000c07f0000f44100002040800b0521c20000403f800b0a803f0700000060ea00010f") +
                 std::string(16, '\0'));
  expect_cloud(pl::read_cloud(dir / "ring-compressed.pcd"), ring_points, {7, 60000});
  // PCL's empty cloud: both sizes 0.
  EXPECT_EQ(pl::parse_pcd(pcd_header("x y z", "4 4 4", "F F F", "", "WIDTH 0\nHEIGHT 1\nPOINTS 0\nDATA binary_compressed\n") +
                              std::string(8, '\0'),
                          "e.pcd")
                .size(),
            0u);
}

TEST(CloudIo, PcdBinaryCompressedRoundTripsThroughLzf) {
  // 600 points of a driver's record: float32 x y z, padding, a uint16 intensity, a uint8 ring, more
  // padding, a float64 time; written column by column, compressed with liblzf, read back exactly.
  // Rows repeat every 50 points, so the LZF data holds long back references, not just literals.
  const std::size_t n = 600;
  pl::Points3d points;
  std::vector<float> intensity;
  std::string x, y, z, pad3, in, ring, pad2, t;
  for (std::size_t i = 0; i < n; ++i) {
    const float k = static_cast<float>(i % 50);
    points.emplace_back(0.25 * k - 3, 1000.5 - k, 0.125 * static_cast<double>(i / 50));
    x += raw<float>({0.25f * k - 3});
    y += raw<float>({1000.5f - k});
    z += raw<float>({0.125f * static_cast<float>(i / 50)});
    pad3 += std::string(3, '\x5a');
    in += raw<std::uint16_t>({static_cast<std::uint16_t>(1000 * (i % 50))});
    intensity.push_back(static_cast<float>(1000 * (i % 50)));
    ring += raw<std::uint8_t>({static_cast<std::uint8_t>(i % 16)});
    pad2 += std::string(2, '\x00');
    t += raw<double>({1e-5 * static_cast<double>(i)});
  }
  const std::string fields = pcd_header("x y z _ intensity ring _ t", "4 4 4 1 2 1 1 8", "F F F U U U U F", "1 1 1 3 1 1 2 1",
                                        "WIDTH 600\nHEIGHT 1\nPOINTS 600\nDATA binary_compressed\n");
  // PCL leaves the padding out of the columns; Open3D's reader expects it in. Both are read.
  const std::string pcl_body = lzf_body(x + y + z + in + ring + t);
  ASSERT_LT(pcl_body.size(), (x + y + z + in + ring + t).size() / 2);  // it did compress
  expect_cloud(pl::parse_pcd(fields + pcl_body, "pcl.pcd"), points, intensity);
  expect_cloud(pl::parse_pcd(fields + lzf_body(x + y + z + pad3 + in + ring + pad2 + t), "padded.pcd"), points, intensity);
  // float64 coordinates far from the origin, a uint8 intensity named as CloudCompare names it, an
  // int16 field between them.
  std::string xd, yd, zd, s16, u8;
  pl::Points3d far;
  for (int i = 0; i < 3; ++i) {
    far.emplace_back(412345.125 + i, 5412345.5 - i, 101.25);
    xd += raw<double>({412345.125 + i});
    yd += raw<double>({5412345.5 - i});
    zd += raw<double>({101.25});
    s16 += raw<std::int16_t>({static_cast<std::int16_t>(-300 * i)});
    u8 += raw<std::uint8_t>({static_cast<std::uint8_t>(250 + i)});
  }
  expect_cloud(pl::parse_pcd(pcd_header("x y z label scalar_intensity", "8 8 8 2 1", "F F F I U", "",
                                        "WIDTH 3\nPOINTS 3\nDATA binary_compressed\n") +
                                 lzf_body(xd + yd + zd + s16 + u8),
                             "far.pcd"),
               far, {250, 251, 252});
}

TEST(CloudIo, PcdPointsWithoutAReturnAreDropped) {
  TempDir dir;
  // The same organised cloud from PCL in its three encodings: the NaN points go, with their intensity.
  for (const auto& [file, bytes] :
       {std::pair<std::string, std::string>{"a.pcd", kPclXyziAscii}, {"b.pcd", kPclXyziBinary}, {"c.pcd", kPclXyziCompressed}}) {
    write_file(dir / file, bytes);
    SCOPED_TRACE(file);
    expect_cloud(pl::read_pcd(dir / file), kPclXyziPoints, kPclXyziIntensity);
  }
  // A 3 x 2 cloud with NaN, -NaN and both infinities (the dropped points' intensity NaN too), in the
  // three encodings, in the spellings of PCL ("nan"), printf ("-nan", "inf") and others.
  const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
  const std::vector<std::array<float, 4>> rows = {{1, 2, 3, 0.5f},  {nan, nan, nan, nan}, {4, -nan, 6, 0},
                                                  {7, 8, 9, 0.25f}, {inf, 0, 0, 1},       {0, 0, -inf, 1}};
  const std::string header = pcd_header("x y z intensity", "4 4 4 4", "F F F F", "1 1 1 1", "WIDTH 3\nHEIGHT 2\nPOINTS 6\n");
  std::string binary, columns[4];
  for (const auto& r : rows) {
    binary += raw<float>({r[0], r[1], r[2], r[3]});
    for (int k = 0; k < 4; ++k) columns[k] += raw<float>({r[k]});
  }
  const std::string ascii = "1 2 3 0.5\nnan NaN nan nan\n4 -nan 6 0\n7 8 9 0.25\ninf 0 0 1\n0 0 -Infinity 1\n";
  const pl::Points3d kept = {Eigen::Vector3d(1, 2, 3), Eigen::Vector3d(7, 8, 9)};
  expect_cloud(pl::parse_pcd(header + "DATA ascii\n" + ascii, "a.pcd"), kept, {0.5f, 0.25f});
  expect_cloud(pl::parse_pcd(header + "DATA binary\n" + binary, "b.pcd"), kept, {0.5f, 0.25f});
  expect_cloud(
      pl::parse_pcd(header + "DATA binary_compressed\n" + lzf_body(columns[0] + columns[1] + columns[2] + columns[3]), "c.pcd"),
      kept, {0.5f, 0.25f});
  // A cloud of no returns at all is an empty cloud; a dropped point's line must still be numbers,
  // and a kept point's intensity finite.
  EXPECT_EQ(pl::parse_pcd(header + "DATA binary\n" + binary.substr(16, 16) + binary.substr(32, 16) + binary.substr(64, 16) +
                              binary.substr(80, 16) + binary.substr(16, 32),
                          "n.pcd")
                .size(),
            0u);
  const std::string two = pcd_header("x y z intensity", "4 4 4 4", "F F F F", "", "POINTS 2\nDATA ascii\n");
  EXPECT_TRUE(
      contains(parse_error(two + "1 2 3 0.5\nnan nan nan x\n", "n.pcd"), "n.pcd: point 2 has an intensity that is not a number"));
  EXPECT_TRUE(contains(parse_error(two + "1 2 3 0.5\nnan nan nano 0\n", "n.pcd"),
                       "n.pcd: point 2 has a coordinate that is not a number"));
  EXPECT_TRUE(
      contains(parse_error(two + "1 2 1e400 0.5\n4 5 6 7\n", "n.pcd"), "n.pcd: point 1 has a coordinate that is not a number"));
  EXPECT_TRUE(
      contains(parse_error(two + "nan nan nan 0\n1 2 3 inf\n", "n.pcd"), "n.pcd: point 2 has an intensity that is not a number"));
}

TEST(CloudIo, PcdPointsMustBeWidthTimesHeight) {
  TempDir dir;
  const std::string xyz = pcd_header("x y z", "4 4 4", "F F F", "", "");
  write_file(dir / "wh.pcd", xyz + "WIDTH 3\nHEIGHT 2\nPOINTS 5\nDATA ascii\n1 2 3\n1 2 3\n1 2 3\n1 2 3\n1 2 3\n1 2 3\n");
  EXPECT_TRUE(
      contains(error_of(dir / "wh.pcd"),
               dir / "wh.pcd: POINTS 5 but WIDTH 3 x HEIGHT 2 = 6: the header contradicts itself; make POINTS equal WIDTH x "
                     "HEIGHT (for an unorganised cloud, WIDTH = POINTS and HEIGHT 1)"));
  // POINTS 0 is no exception, and HEIGHT is 1 when missing.
  EXPECT_TRUE(
      contains(parse_error(xyz + "WIDTH 4\nPOINTS 0\nDATA ascii\n", "z.pcd"), "z.pcd: POINTS 0 but WIDTH 4 x HEIGHT 1 = 4"));
  EXPECT_EQ(pl::parse_pcd(xyz + "WIDTH 2\nPOINTS 2\nDATA ascii\n1 2 3\n4 5 6\n", "ok.pcd").size(), 2u);
  EXPECT_EQ(pl::parse_pcd(xyz + "WIDTH 1\nHEIGHT 2\nDATA ascii\n1 2 3\n4 5 6\n", "ok.pcd").size(),
            2u);  // no POINTS: WIDTH x HEIGHT
}

TEST(CloudIo, DamagedBinaryCompressedDataIsRefused) {
  const std::string header =
      pcd_header("x y z intensity", "4 4 4 4", "F F F F", "", "WIDTH 4\nHEIGHT 1\nPOINTS 4\nDATA binary_compressed\n");
  std::string plain;
  for (int k = 0; k < 4; ++k) plain += raw<float>({1.5f * k, 2.5f * k, 3.5f, 4.5f});
  const std::string body = lzf_body(plain);  // sizes, then the LZF data
  const std::size_t c = body.size() - 8;
  ASSERT_EQ(pl::parse_pcd(header + body, "x.pcd").size(), 4u);
  auto sizes = [](std::uint32_t compressed, std::uint32_t uncompressed) {
    return raw<std::uint32_t>({compressed, uncompressed});
  };
  // No room for the two sizes.
  EXPECT_TRUE(contains(parse_error(header + body.substr(0, 5), "x.pcd"),
                       "x.pcd: DATA binary_compressed needs 8 bytes after the header (the compressed and the uncompressed size), "
                       "the file has 5 (truncated?)"));
  // The file ends inside the compressed data.
  EXPECT_TRUE(contains(parse_error(header + body.substr(0, body.size() - 3), "x.pcd"),
                       "x.pcd: binary_compressed data of " + std::to_string(c) +
                           " bytes runs past the end of the file, which has " + std::to_string(c - 3) +
                           " after the sizes (truncated?)"));
  // The compressed data cut short, its size cut to match: it unpacks to too little.
  EXPECT_TRUE(contains(parse_error(header + sizes(static_cast<std::uint32_t>(c - 3), 64) + body.substr(8, c - 3), "x.pcd"),
                       "x.pcd: binary_compressed data is corrupt: its " + std::to_string(c - 3) + " bytes of LZF"));
  // The uncompressed size disagrees with POINTS x 16 bytes.
  EXPECT_TRUE(contains(
      parse_error(header + sizes(static_cast<std::uint32_t>(c), 68) + body.substr(8), "x.pcd"),
      "x.pcd: binary_compressed data unpacks to 68 bytes, but POINTS 4 of 16 bytes need 64: the header and the data disagree"));
  EXPECT_TRUE(contains(
      parse_error(pcd_header("x y z _", "4 4 4 1", "F F F U", "1 1 1 4", "POINTS 4\nDATA binary_compressed\n") +
                      sizes(static_cast<std::uint32_t>(c), 60) + body.substr(8),
                  "p.pcd"),
      "p.pcd: binary_compressed data unpacks to 60 bytes, but POINTS 4 of 12 bytes need 48 (64 with the padding fields \"_\")"));
  // Corrupt LZF: a back reference before the start of the data, and a literal run past its end.
  EXPECT_TRUE(contains(
      parse_error(header + sizes(4, 64) + std::string("\xe0\x10\x00\x00", 4), "x.pcd"),
      "x.pcd: binary_compressed data is corrupt: its 4 bytes of LZF do not unpack where the header says 64 (a damaged file?)"));
  EXPECT_TRUE(contains(parse_error(header + sizes(3, 64) + "\x1f\x01\x02", "x.pcd"), "x.pcd: binary_compressed data is corrupt"));
  // Unpacking to more than the header says.
  EXPECT_TRUE(contains(parse_error(pcd_header("x y z", "4 4 4", "F F F", "", "POINTS 1\nDATA binary_compressed\n") +
                                       sizes(static_cast<std::uint32_t>(c), 12) + body.substr(8),
                                   "x.pcd"),
                       "x.pcd: binary_compressed data is corrupt"));
  // 20 bytes that ask for 4 GiB: refused by LZF's limit before anything is allocated.
  EXPECT_TRUE(contains(parse_error(pcd_header("x y z", "4 4 4", "F F F", "", "POINTS 357913941\nDATA binary_compressed\n") +
                                       sizes(12, 4294967292u) + std::string(12, '\x1f'),
                                   "h.pcd"),
                       "h.pcd: binary_compressed data of 12 bytes cannot unpack to 4294967292 (LZF unpacks to at most 88 times "
                       "its size): a damaged file"));
  EXPECT_TRUE(
      contains(parse_error(header + sizes(0, 64), "x.pcd"), "x.pcd: binary_compressed data of 0 bytes cannot unpack to 64"));
  // POINTS too many for a uint32 size.
  EXPECT_TRUE(contains(
      parse_error(pcd_header("x y z", "4 4 4", "F F F", "", "POINTS 1537228672809129302\nDATA binary_compressed\n") + sizes(0, 0),
                  "o.pcd"),
      "o.pcd: binary_compressed data unpacks to 0 bytes, but POINTS 1537228672809129302 of 12 bytes need more than 2^64"));
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
