// Tile codec: bad input (wrong sizes, non-finite values, bad settings) is refused on encoding, and
// garbage, truncated or corrupted bytes, declared sizes beyond the budget, old bitstreams and the
// fuzzers' findings are refused on decoding, with pl::Error.
#include <gtest/gtest.h>
#include <sys/resource.h>

#include <cstdint>
#include <filesystem>
#include <limits>
#include <random>
#include <string>
#include <string_view>

#include "pl/common/error.hpp"
#include "pl/common/tile_codec.hpp"
#include "test_util.hpp"
#include "tile_clouds.hpp"

namespace {

using pl::TileCloud;
using pl::TileCodecConfig;
using pl::test::random_cloud;
using pl::test::realistic_tile;

TEST(TileCodec, BadInputIsRefused) {
  const TileCloud tile = random_cloud(10, {0, 0, 0}, {1, 1, 1}, 18);
  auto expect_error = [](const TileCloud& t, const TileCodecConfig& cfg, const std::string& part) {
    try {
      pl::encode_tile(t, cfg);
      ADD_FAILURE() << "no error, expected one mentioning \"" << part << "\"";
    } catch (const pl::Error& e) {
      EXPECT_NE(std::string(e.what()).find(part), std::string::npos) << e.what();
    }
  };
  TileCloud t = tile;
  t.normals.pop_back();
  expect_error(t, {}, "9 normals for 10 points");
  t = tile;
  t.intensity.push_back(0.5f);
  expect_error(t, {}, "11 intensity values for 10 points");
  t = tile;
  t.points[3].y() = std::numeric_limits<double>::quiet_NaN();
  expect_error(t, {}, "point 3 is not finite");
  t = tile;
  t.points[4].z() = std::numeric_limits<double>::infinity();
  expect_error(t, {}, "point 4 is not finite");
  t = tile;
  t.normals[5].x() = std::numeric_limits<float>::infinity();
  expect_error(t, {}, "normal 5 is not finite");
  t = tile;
  t.normals[6] = Eigen::Vector3f::Zero();
  expect_error(t, {}, "normal 6 has zero length");
  t = tile;
  t.intensity[7] = std::numeric_limits<float>::quiet_NaN();
  expect_error(t, {}, "intensity 7 is not finite");

  t = tile;
  t.intensity[8] = -3e38f;
  t.intensity[9] = 3e38f;
  expect_error(t, {}, "span more than float32");

  TileCodecConfig cfg;
  cfg.max_error_m = 0;
  expect_error(tile, cfg, "max_error_m");
  cfg = {};
  cfg.max_error_m = 1e-9;  // below float32 resolution
  expect_error(tile, cfg, "float32");
  cfg = {};
  cfg.normal_bits = 1;
  expect_error(tile, cfg, "normal_bits");
  cfg = {};
  cfg.intensity_bits = 31;
  expect_error(tile, cfg, "intensity_bits");
  cfg = {};
  cfg.speed = 11;
  expect_error(tile, cfg, "speed");
}

// Decoding must either succeed with a consistent cloud or throw pl::Error; anything else fails.
void decode_or_refuse(std::string_view bytes, int& refused) {
  try {
    const TileCloud out = pl::decode_tile(bytes);
    EXPECT_TRUE(out.normals.empty() || out.normals.size() == out.points.size());
    EXPECT_TRUE(out.intensity.empty() || out.intensity.size() == out.points.size());
    for (const auto& p : out.points) EXPECT_TRUE(p.allFinite());
  } catch (const pl::Error& e) {
    EXPECT_NE(std::string(e.what()).find("not a valid Draco point cloud: "), std::string::npos) << e.what();
    ++refused;
  }
  try {
    pl::inspect_tile(bytes);
  } catch (const pl::Error&) {
  }
}

TEST(TileCodec, GarbageIsRefusedWithoutCrashing) {
  int refused = 0;
  decode_or_refuse("", refused);
  decode_or_refuse("DRACO", refused);
  decode_or_refuse("ply\nformat ascii 1.0\n", refused);
  EXPECT_EQ(refused, 3);
  EXPECT_THROW(pl::inspect_tile("hello"), pl::Error);

  TileCloud small = realistic_tile({4000.0, -2500.0, 0.0}, 7);
  small.points.resize(150);
  small.normals.resize(150);
  small.intensity.resize(150);
  TileCloud positions_only;
  positions_only.points = small.points;
  std::mt19937 rng(7);
  for (const TileCloud* cloud : {&small, &positions_only}) {
    const std::string valid = pl::encode_tile(*cloud);
    // Every truncation is refused.
    for (std::size_t len = 0; len < valid.size(); ++len) {
      SCOPED_TRACE("truncated to " + std::to_string(len) + " of " + std::to_string(valid.size()));
      EXPECT_THROW(pl::decode_tile(std::string_view(valid).substr(0, len)), pl::Error);
      EXPECT_THROW(pl::inspect_tile(std::string_view(valid).substr(0, len)), pl::Error);
    }
    // Corrupted bytes: every position, a few random flips each, then several bytes at once.
    refused = 0;
    for (std::size_t pos = 0; pos < valid.size(); ++pos)
      for (int k = 0; k < 3; ++k) {
        std::string bad = valid;
        bad[pos] = static_cast<char>(bad[pos] ^ static_cast<char>(1 + rng() % 255));
        decode_or_refuse(bad, refused);
      }
    EXPECT_GT(refused, 0);
    for (int trial = 0; trial < 300; ++trial) {
      std::string bad = valid;
      for (int k = 0; k < 4; ++k) bad[rng() % bad.size()] = static_cast<char>(rng());
      decode_or_refuse(bad, refused);
    }
    // A valid header followed by random bytes.
    for (int trial = 0; trial < 300; ++trial) {
      std::string bad = valid.substr(0, 11 + rng() % 8);
      const std::size_t tail = rng() % 200;
      for (std::size_t k = 0; k < tail; ++k) bad.push_back(static_cast<char>(rng()));
      decode_or_refuse(bad, refused);
    }
  }
  // Random bytes.
  for (int trial = 0; trial < 200; ++trial) {
    std::string bad(rng() % 300, '\0');
    for (char& c : bad) c = static_cast<char>(rng());
    decode_or_refuse(bad, refused);
  }
}

// A stream that declares far more points than its size can hold is refused before Draco allocates
// for them (a few corrupted bytes must not cost gigabytes).
TEST(TileCodec, DeclaredSizesBeyondTheBudgetAreRefused) {
  TileCloud small = realistic_tile({4000.0, -2500.0, 0.0}, 22);
  small.points.resize(150);
  small.normals.resize(150);
  small.intensity.resize(150);
  const std::string valid = pl::encode_tile(small);
  // The point count (int32, little-endian) follows the geometry metadata: "pl.origin", 24 bytes of
  // doubles, the count of sub-metadata.
  const std::size_t after_origin = valid.find("pl.origin") + 9 + 1 + 24;
  const std::size_t at = valid.find(std::string("\x96\0\0\0", 4), after_origin);
  ASSERT_NE(at, std::string::npos);
  ASSERT_LT(at, after_origin + 4);
  auto with_count = [&](uint32_t count) {
    std::string bad = valid;
    for (int b = 0; b < 4; ++b) bad[at + b] = static_cast<char>((count >> (8 * b)) & 0xff);
    return bad;
  };
  EXPECT_EQ(pl::decode_tile(with_count(150)).size(), 150u);
  auto expect_refused = [](const std::string& bytes, const std::string& part) {
    try {
      pl::decode_tile(bytes);
      ADD_FAILURE() << "decoded; expected an error mentioning \"" << part << "\"";
    } catch (const pl::Error& e) {
      EXPECT_NE(std::string(e.what()).find(part), std::string::npos) << e.what();
    }
  };
  expect_refused(with_count(1u << 22), "would need about");
  expect_refused(with_count(0x7fffffffu), "out of range");
  expect_refused(with_count(0x80000000u), "out of range");
}

// Only the bitstreams of current encoders are read: 2.2 and 2.3, the k-d tree coder only at 2.3
// (its older data declares point counts of its own that Draco sizes buffers by, unchecked).
TEST(TileCodec, BitstreamsOfOldEncodersAreRefused) {
  TileCloud positions;
  positions.points = realistic_tile({10.0, 20.0, 0.0}, 5).points;
  pl::TileCodecConfig sequential, kd;
  sequential.speed = 10;
  kd.speed = 0;
  const std::string seq_bytes = pl::encode_tile(positions, sequential), kd_bytes = pl::encode_tile(positions, kd);
  ASSERT_EQ(seq_bytes[8], 0);  // POINT_CLOUD_SEQUENTIAL_ENCODING
  ASSERT_EQ(kd_bytes[8], 1);   // POINT_CLOUD_KD_TREE_ENCODING
  auto with_version = [](std::string bytes, int major, int minor) {
    bytes[5] = static_cast<char>(major);
    bytes[6] = static_cast<char>(minor);
    return bytes;
  };
  auto refused = [](const std::string& bytes) {
    try {
      pl::decode_tile(bytes);
    } catch (const pl::Error& e) {
      return std::string(e.what());
    }
    return std::string("(decoded)");
  };
  EXPECT_EQ(pl::decode_tile(seq_bytes).size(), positions.size());
  EXPECT_EQ(pl::decode_tile(kd_bytes).size(), positions.size());
  EXPECT_NE(refused(with_version(seq_bytes, 2, 1)).find("bitstream version 2.1 is not one this build reads"), std::string::npos);
  EXPECT_NE(refused(with_version(seq_bytes, 1, 3)).find("bitstream version 1.3"), std::string::npos);
  EXPECT_NE(refused(with_version(kd_bytes, 2, 2)).find("k-d tree stream of bitstream version 2.2"), std::string::npos);
  EXPECT_NE(refused(with_version(seq_bytes, 2, 4)).find("not one this build reads"), std::string::npos);
}

// Every input the fuzzers (and an attacker) found is refused with a message, without the memory it
// asked for (some asked for 14 GB) and without an exception other than pl::Error.
TEST(TileCodec, EveryFuzzFindingIsRefusedWithoutItsMemory) {
  rusage before{};
  getrusage(RUSAGE_SELF, &before);
  int n = 0;
  for (const auto& e : std::filesystem::directory_iterator(std::string(PL_SOURCE_DIR) + "/tests/fuzz/regressions/tile")) {
    const std::string bytes = pl::test::read_file(e.path().string());
    try {
      pl::decode_tile(bytes);
      ADD_FAILURE() << e.path() << " decoded";
    } catch (const pl::Error& err) {
      EXPECT_NE(std::string(err.what()).find("not a valid Draco point cloud"), std::string::npos) << err.what();
    }
    ++n;
  }
  EXPECT_GE(n, 5);
  rusage after{};
  getrusage(RUSAGE_SELF, &after);
  EXPECT_LT(after.ru_maxrss - before.ru_maxrss, 256 * 1024) << "peak memory grew by more than 256 MiB (kB: " << after.ru_maxrss << ")";
}

}  // namespace
