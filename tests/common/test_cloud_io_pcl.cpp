// PCD files as PCL and drivers write them: binary_compressed (LZF) data, points without a return,
// POINTS against WIDTH x HEIGHT, and damaged compressed data refused.
#include <gtest/gtest.h>
#include <liblzf/lzf.h>

#include <array>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "pl/common/cloud_io.hpp"
#include "cloud_files.hpp"
#include "test_util.hpp"

namespace {

using pl::test::TempDir;
using pl::test::write_file;
using pl::test::from_hex;
using pl::test::cloud_files::contains;
using pl::test::cloud_files::error_of;
using pl::test::cloud_files::parse_error;
using pl::test::cloud_files::pcd_header;
using pl::test::cloud_files::raw;
using pl::test::cloud_files::kPclXyziAscii;
using pl::test::cloud_files::kPclXyziBinary;
using pl::test::cloud_files::kPclXyziCompressed;
using pl::test::cloud_files::kPclXyziIntensity;
using pl::test::cloud_files::kPclXyziPoints;

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

}  // namespace
