// Tile codec: real Draco bytes round trip within the configured error bounds, equal tiles give equal
// bytes, and bad input (wrong sizes, garbage, truncated or corrupted bytes) is refused with pl::Error.
#include "pl/common/tile_codec.hpp"

#include <gtest/gtest.h>
#include <sys/resource.h>

#include <filesystem>

#include <Eigen/Geometry>
#include <draco/compression/decode.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <sstream>
#include <unordered_map>

#include "pl/common/error.hpp"
#include "test_util.hpp"

namespace {

using pl::TileCloud;
using pl::TileCodecConfig;

Eigen::Vector3f perturbed(Eigen::Vector3f n, std::mt19937& rng, double sigma_deg) {
  std::normal_distribution<float> g(0.f, static_cast<float>(sigma_deg * M_PI / 180.0));
  return (n + Eigen::Vector3f(g(rng), g(rng), g(rng))).normalized();
}

// A 20 m map tile as the voxel map (0.2 m) stores it: voxel centroids on the ground (with road
// markings), on a facade, on poles, and some clutter, with noisy normals and intensity. `corner` is
// the tile's low corner in ENU.
TileCloud realistic_tile(const Eigen::Vector3d& corner, unsigned seed, double normal_sigma_deg = 2.0) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  std::normal_distribution<double> g(0, 1);
  TileCloud t;
  auto add = [&](const Eigen::Vector3d& p, const Eigen::Vector3f& n, double intensity) {
    t.points.push_back(corner + p);
    t.normals.push_back(perturbed(n, rng, normal_sigma_deg));
    t.intensity.push_back(static_cast<float>(std::clamp(intensity, 0.0, 1.0)));
  };
  const double v = 0.2;
  for (int ix = 0; ix < 100; ++ix)  // ground, 20 m x 10 m, partly occluded
    for (int iy = 0; iy < 50; ++iy) {
      if (u(rng) > 0.6) continue;
      const double x = (ix + 0.5) * v + 0.02 * g(rng), y = (iy + 0.5) * v + 0.02 * g(rng);
      const bool marking = (iy == 20 || iy == 21) && ix % 10 < 5;
      add({x, y, 0.3 + 0.01 * x + 0.005 * g(rng)}, {0, 0, 1}, marking ? 0.8 + 0.05 * g(rng) : 0.2 + 0.04 * g(rng));
    }
  for (int ix = 0; ix < 100; ++ix)  // facade at y = 12 m, 5 m high
    for (int iz = 0; iz < 25; ++iz) {
      if (u(rng) > 0.7) continue;
      const double x = (ix + 0.5) * v + 0.02 * g(rng), z = 0.4 + (iz + 0.5) * v + 0.02 * g(rng);
      add({x, 12.0 + 0.005 * g(rng), z}, {0, -1, 0}, 0.5 + 0.1 * g(rng));
    }
  for (int k = 0; k < 6; ++k)  // poles
    for (int iz = 0; iz < 20; ++iz)
      for (int a = 0; a < 4; ++a) {
        const double angle = a * M_PI / 2 + 0.3 * g(rng);
        const Eigen::Vector3f n(static_cast<float>(std::cos(angle)), static_cast<float>(std::sin(angle)), 0.f);
        add({1.5 + 3.2 * k + 0.12 * std::cos(angle), 10.5 + 0.12 * std::sin(angle), 0.4 + iz * v + 0.03 * g(rng)}, n,
            0.6 + 0.1 * g(rng));
      }
  for (int k = 0; k < 300; ++k) {  // clutter
    const Eigen::Vector3f n = Eigen::Vector3f(g(rng), g(rng), g(rng)).normalized();
    add({u(rng) * 20, 10 + u(rng) * 1.5, 0.4 + u(rng) * 1.2}, n, 0.3 + 0.1 * g(rng));
  }
  return t;
}

// `n` random points in a box, with unit normals and intensity.
TileCloud random_cloud(std::size_t n, const Eigen::Vector3d& lo, const Eigen::Vector3d& size, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  std::normal_distribution<float> g(0.f, 1.f);
  TileCloud t;
  for (std::size_t i = 0; i < n; ++i) {
    t.points.push_back(lo + Eigen::Vector3d(u(rng) * size.x(), u(rng) * size.y(), u(rng) * size.z()));
    t.normals.push_back(Eigen::Vector3f(g(rng), g(rng), g(rng)).normalized());
    t.intensity.push_back(static_cast<float>(u(rng)));
  }
  return t;
}

double angle_between(const Eigen::Vector3f& a, const Eigen::Vector3f& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b));
}

// Largest angular error of a normal quantized with `bits` (octahedral in Draco's sequential coder,
// per component in its k-d tree coder): a few quantization steps of 2 / 2^bits.
double normal_tolerance(int bits) { return 4.5 / (std::ldexp(1.0, bits) - 2); }

// Worst errors between an input cloud and its decoding, after pairing each input point with a
// decoded one (decoding may reorder the points).
struct Errors {
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  // per axis
  double normal_rad = 0;
  double intensity = 0;
};

Errors compare(const TileCloud& in, const TileCloud& out, double pos_tol, double normal_tol, double intensity_tol) {
  Errors e;
  EXPECT_EQ(out.points.size(), in.points.size());
  EXPECT_EQ(out.normals.size(), in.normals.size());
  EXPECT_EQ(out.intensity.size(), in.intensity.size());
  if (out.points.size() != in.points.size() || out.normals.size() != in.normals.size() ||
      out.intensity.size() != in.intensity.size())
    return e;
  // Hash the decoded points on a grid of cells 2 * pos_tol wide; a partner lies in the 27 cells around.
  const double cell = 2 * pos_tol;
  auto key = [&](const Eigen::Vector3d& p, int dx, int dy, int dz) {
    const auto ix = static_cast<int64_t>(std::floor(p.x() / cell)) + dx;
    const auto iy = static_cast<int64_t>(std::floor(p.y() / cell)) + dy;
    const auto iz = static_cast<int64_t>(std::floor(p.z() / cell)) + dz;
    return (static_cast<uint64_t>(ix) * 73856093u) ^ (static_cast<uint64_t>(iy) * 19349663u) ^
           (static_cast<uint64_t>(iz) * 83492791u);
  };
  std::unordered_multimap<uint64_t, std::size_t> grid;
  for (std::size_t j = 0; j < out.points.size(); ++j) grid.emplace(key(out.points[j], 0, 0, 0), j);
  std::vector<bool> used(out.points.size(), false);
  std::size_t unmatched = 0;
  for (std::size_t i = 0; i < in.points.size(); ++i) {
    std::size_t best = SIZE_MAX;
    double best_cost = std::numeric_limits<double>::infinity();
    for (int dx = -1; dx <= 1; ++dx)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dz = -1; dz <= 1; ++dz) {
          auto range = grid.equal_range(key(in.points[i], dx, dy, dz));
          for (auto it = range.first; it != range.second; ++it) {
            const std::size_t j = it->second;
            if (used[j]) continue;
            const Eigen::Vector3d d = (out.points[j] - in.points[i]).cwiseAbs();
            if (d.maxCoeff() > pos_tol) continue;
            double cost = d.maxCoeff() / pos_tol;
            if (!in.normals.empty()) cost += angle_between(in.normals[i], out.normals[j]) / normal_tol;
            if (!in.intensity.empty()) cost += std::abs(in.intensity[i] - out.intensity[j]) / intensity_tol;
            if (cost < best_cost) {
              best_cost = cost;
              best = j;
            }
          }
        }
    if (best == SIZE_MAX) {
      if (++unmatched <= 5) ADD_FAILURE() << "input point " << i << " has no decoded point within " << pos_tol << " m";
      continue;
    }
    used[best] = true;
    e.position = e.position.cwiseMax((out.points[best] - in.points[i]).cwiseAbs());
    if (!in.normals.empty()) e.normal_rad = std::max(e.normal_rad, angle_between(in.normals[i], out.normals[best]));
    if (!in.intensity.empty())
      e.intensity = std::max(e.intensity, static_cast<double>(std::abs(in.intensity[i] - out.intensity[best])));
  }
  EXPECT_EQ(unmatched, 0u);
  return e;
}

// Encodes, decodes and checks every bound of `cfg`.
Errors round_trip(const TileCloud& in, const TileCodecConfig& cfg = {}) {
  const std::string bytes = pl::encode_tile(in, cfg);
  const TileCloud out = pl::decode_tile(bytes);
  const double normal_tol = normal_tolerance(cfg.normal_bits);
  const double intensity_tol = 1.0 / std::ldexp(1.0, cfg.intensity_bits);
  const Errors e = compare(in, out, cfg.max_error_m, normal_tol, intensity_tol);
  for (int c = 0; c < 3; ++c) EXPECT_LE(e.position[c], cfg.max_error_m) << "axis " << c;
  EXPECT_LE(e.normal_rad, normal_tol);
  EXPECT_LE(e.intensity, intensity_tol);
  for (const auto& n : out.normals) EXPECT_NEAR(n.norm(), 1.0f, 1e-5f);
  const pl::TileSummary s = pl::inspect_tile(bytes);
  EXPECT_EQ(s.points, in.size());
  EXPECT_EQ(s.has_normals, !in.normals.empty());
  EXPECT_EQ(s.has_intensity, !in.intensity.empty());
  return e;
}

TEST(TileCodec, RealisticTileFarFromOriginWithinBounds) {
  const TileCloud tile = realistic_tile({4000.0, -2500.0, 35.0}, 1);
  ASSERT_GT(tile.size(), 3000u);
  const std::string bytes = pl::encode_tile(tile);
  // 28 bytes a point raw (float32 xyz, normal, intensity): Draco should do several times better.
  EXPECT_LT(bytes.size(), tile.size() * 28 / 4);
  const Errors e = round_trip(tile);
  // The bound is used, not wasted: the error is within a factor 2 of it.
  EXPECT_GT(e.position.maxCoeff(), TileCodecConfig{}.max_error_m / 2);
}

TEST(TileCodec, ErrorBoundsForSeveralConfigs) {
  const TileCloud tile = realistic_tile({-123456.0, 654321.0, -20.0}, 2);
  for (double max_error : {0.0005, 0.002, 0.01, 0.05, 0.3})
    for (int speed : {0, 5, 10}) {
      SCOPED_TRACE("max_error " + std::to_string(max_error) + " speed " + std::to_string(speed));
      TileCodecConfig cfg;
      cfg.max_error_m = max_error;
      cfg.speed = speed;
      round_trip(tile, cfg);
    }
}

TEST(TileCodec, FewerBitsGiveFewerBytes) {
  const TileCloud tile = realistic_tile({0, 0, 0}, 3);
  TileCodecConfig fine, coarse;
  fine.max_error_m = 0.001;
  coarse.max_error_m = 0.02;
  coarse.normal_bits = 7;
  coarse.intensity_bits = 5;
  EXPECT_LT(pl::encode_tile(tile, coarse).size(), pl::encode_tile(tile, fine).size());
}

TEST(TileCodec, RandomCloudsWithinBounds) {
  for (unsigned seed = 0; seed < 4; ++seed) {
    SCOPED_TRACE("seed " + std::to_string(seed));
    const TileCloud cloud = random_cloud(500 + 700 * seed, {4000.0 + seed, -2500.0, 10.0}, {20, 20, 6}, seed);
    round_trip(cloud);
  }
  // A tile hundreds of kilometres from the map origin, and one in a tiny box.
  round_trip(random_cloud(800, {-350000.25, 420000.75, 1200.0}, {20, 20, 20}, 9));
  round_trip(random_cloud(300, {10.0, 20.0, 30.0}, {0.01, 0.02, 0.005}, 10));
}

TEST(TileCodec, PlanarAndDegenerateExtents) {
  TileCodecConfig cfg;
  // All points on a horizontal plane: zero extent on z.
  TileCloud plane = random_cloud(2000, {4000.0, -2500.0, 12.345}, {20, 20, 0}, 11);
  const TileCloud plane_out = pl::decode_tile(pl::encode_tile(plane, cfg));
  round_trip(plane, cfg);
  for (const auto& p : plane_out.points) EXPECT_NEAR(p.z(), 12.345, cfg.max_error_m);
  // On a vertical line: zero extent on x and y.
  round_trip(random_cloud(200, {-7.5, 3.25, 0.0}, {0, 0, 4}, 12), cfg);
  // One point, and several copies of one point.
  round_trip(random_cloud(1, {4000.7, -2500.3, 99.9}, {0, 0, 0}, 13), cfg);
  TileCloud copies = random_cloud(1, {4000.7, -2500.3, 99.9}, {0, 0, 0}, 14);
  for (int k = 0; k < 4; ++k) {
    copies.points.push_back(copies.points[0]);
    copies.normals.push_back(copies.normals[0]);
    copies.intensity.push_back(copies.intensity[0]);
  }
  round_trip(copies, cfg);
  // Two points far apart in a tile that straddles the map origin's axes.
  TileCloud two;
  two.points = {{-0.3, -0.2, -0.1}, {19.7, 19.8, 0.1}};
  round_trip(two, cfg);
}

TEST(TileCodec, EmptyCloudEncodesToAnEmptyTile) {
  const std::string bytes = pl::encode_tile(TileCloud{});
  EXPECT_FALSE(bytes.empty());
  const TileCloud out = pl::decode_tile(bytes);
  EXPECT_EQ(out.size(), 0u);
  EXPECT_TRUE(out.normals.empty());
  EXPECT_TRUE(out.intensity.empty());
  EXPECT_EQ(pl::inspect_tile(bytes).points, 0u);
}

TEST(TileCodec, OptionalAttributes) {
  const TileCloud full = realistic_tile({4000.0, -2500.0, 0.0}, 4);
  TileCloud positions_only, with_normals, with_intensity;
  positions_only.points = with_normals.points = with_intensity.points = full.points;
  with_normals.normals = full.normals;
  with_intensity.intensity = full.intensity;
  for (const TileCloud* t : {&positions_only, &with_normals, &with_intensity}) round_trip(*t);
  EXPECT_LT(pl::encode_tile(positions_only).size(), pl::encode_tile(with_normals).size());
  EXPECT_LT(pl::encode_tile(with_normals).size(), pl::encode_tile(full).size());
}

// Draco's k-d tree coder wins on noise-free normals at speeds up to 4 (its best level), the sequential
// one on noisy normals; both stay within every bound. (Byte 8 of a Draco header is the coder.)
TEST(TileCodec, BothDracoCodersStayWithinBounds) {
  TileCodecConfig fast_kd;
  fast_kd.speed = 0;
  const TileCloud smooth = realistic_tile({4000.0, -2500.0, 35.0}, 20, 0.0);
  const std::string kd_bytes = pl::encode_tile(smooth, fast_kd);
  EXPECT_EQ(kd_bytes[8], 1) << "expected the k-d tree coder";
  round_trip(smooth, fast_kd);
  const TileCloud noisy = realistic_tile({4000.0, -2500.0, 35.0}, 21, 2.0);
  EXPECT_EQ(pl::encode_tile(noisy, fast_kd)[8], 0) << "expected the sequential coder";
  round_trip(noisy, fast_kd);
}

TEST(TileCodec, NormalsWithinTheAngularErrorOfTheirBits) {
  const TileCloud tile = random_cloud(1500, {4000.0, -2500.0, 0.0}, {20, 20, 5}, 15);
  for (int bits : {4, 6, 8, 10, 12, 16}) {
    SCOPED_TRACE("normal_bits " + std::to_string(bits));
    TileCodecConfig cfg;
    cfg.normal_bits = bits;
    const Errors e = round_trip(tile, cfg);
    EXPECT_GT(e.normal_rad, 0.1 * normal_tolerance(bits));  // the bits are used, not exceeded
  }
  // Noise-free normals on planes (the k-d tree coder may win there) and normals that are not unit
  // length on input (they are stored as directions).
  TileCloud planar = realistic_tile({0, 0, 0}, 16, 0.0);
  round_trip(planar);
  TileCloud scaled = planar;
  for (auto& n : scaled.normals) n *= 3.0f;
  const TileCloud out = pl::decode_tile(pl::encode_tile(scaled));
  for (const auto& n : out.normals) EXPECT_NEAR(n.norm(), 1.0f, 1e-5f);
}

// decode_tile turns octahedral codes into normals itself (a table for up to 8 bits, Draco's tool box
// beyond): the vectors must be exactly those Draco's own decoder gives, point for point.
TEST(TileCodec, NormalsEqualDracosOwnDecoding) {
  const TileCloud tile = random_cloud(2000, {4000.0, -2500.0, 0.0}, {20, 20, 5}, 23);
  for (int bits : {3, 8, 9, 12}) {
    SCOPED_TRACE("normal_bits " + std::to_string(bits));
    TileCodecConfig cfg;
    cfg.normal_bits = bits;
    cfg.speed = 10;  // the sequential coder: octahedral normals, points kept in the encoded order
    const std::string bytes = pl::encode_tile(tile, cfg);
    draco::DecoderBuffer buffer;
    buffer.Init(bytes.data(), bytes.size());
    draco::Decoder decoder;
    auto reference = decoder.DecodePointCloudFromBuffer(&buffer);
    ASSERT_TRUE(reference.ok()) << reference.status().error_msg_string();
    const auto& pc = *reference.value();
    const draco::PointAttribute* att = pc.GetNamedAttribute(draco::GeometryAttribute::NORMAL);
    ASSERT_NE(att, nullptr);
    const TileCloud ours = pl::decode_tile(bytes);
    ASSERT_EQ(ours.normals.size(), pc.num_points());
    int differ = 0;
    for (uint32_t i = 0; i < pc.num_points(); ++i) {
      Eigen::Vector3f expected;
      ASSERT_TRUE(att->ConvertValue<float>(att->mapped_index(draco::PointIndex(i)), 3, expected.data()));
      if (ours.normals[i] != expected) ++differ;
    }
    EXPECT_EQ(differ, 0);
  }
}

TEST(TileCodec, IntensityWithinItsBits) {
  TileCloud tile = random_cloud(1000, {4000.0, -2500.0, 0.0}, {20, 20, 5}, 17);
  for (int bits : {1, 4, 8, 12, 16}) {
    SCOPED_TRACE("intensity_bits " + std::to_string(bits));
    TileCodecConfig cfg;
    cfg.intensity_bits = bits;
    round_trip(tile, cfg);
  }
  std::fill(tile.intensity.begin(), tile.intensity.end(), 0.25f);  // constant
  const TileCloud out = pl::decode_tile(pl::encode_tile(tile));
  for (float v : out.intensity) EXPECT_NEAR(v, 0.25f, 1.0 / 256);
}

TEST(TileCodec, EqualTilesGiveEqualBytes) {
  const TileCloud tile = realistic_tile({4000.0, -2500.0, 0.0}, 5);
  std::mt19937 rng(42);
  for (int speed : {0, 5, 10}) {
    SCOPED_TRACE("speed " + std::to_string(speed));
    TileCodecConfig cfg;
    cfg.speed = speed;
    const std::string bytes = pl::encode_tile(tile, cfg);
    EXPECT_EQ(pl::encode_tile(tile, cfg), bytes);
    for (int trial = 0; trial < 3; ++trial) {
      std::vector<std::size_t> perm(tile.size());
      for (std::size_t i = 0; i < perm.size(); ++i) perm[i] = i;
      std::shuffle(perm.begin(), perm.end(), rng);
      TileCloud shuffled;
      for (std::size_t i : perm) {
        shuffled.points.push_back(tile.points[i]);
        shuffled.normals.push_back(tile.normals[i]);
        shuffled.intensity.push_back(tile.intensity[i]);
      }
      EXPECT_EQ(pl::encode_tile(shuffled, cfg), bytes);
    }
  }
  // Negative zeros are zeros.
  TileCloud zeros;
  zeros.points = {{0.0, 0.0, 0.0}, {1.5, -0.0, 2.0}, {-0.0, 3.0, -0.0}};
  zeros.normals = {{0.f, 0.f, 1.f}, {-0.f, 1.f, 0.f}, {1.f, 0.f, -0.f}};
  zeros.intensity = {0.f, 0.5f, -0.f};
  TileCloud signed_zeros = zeros;
  for (auto& p : signed_zeros.points) p = -(-p);
  signed_zeros.points[0] = {-0.0, -0.0, -0.0};
  signed_zeros.normals[0] = {-0.f, -0.f, 1.f};
  signed_zeros.intensity[0] = -0.f;
  zeros.points[2] = {0.0, 3.0, 0.0};
  EXPECT_EQ(pl::encode_tile(signed_zeros), pl::encode_tile(zeros));
  // Positions only (the k-d tree coder's case), with repeated points.
  TileCloud positions;
  positions.points = tile.points;
  positions.points.insert(positions.points.end(), tile.points.begin(), tile.points.begin() + 50);
  const std::string bytes = pl::encode_tile(positions);
  std::reverse(positions.points.begin(), positions.points.end());
  EXPECT_EQ(pl::encode_tile(positions), bytes);
}

TEST(TileCodec, DifferentTilesGiveDifferentBytes) {
  const TileCloud tile = realistic_tile({4000.0, -2500.0, 0.0}, 6);
  const std::string bytes = pl::encode_tile(tile);
  TileCloud moved = tile;
  moved.points[100].x() += 0.1;
  EXPECT_NE(pl::encode_tile(moved), bytes);
  TileCloud brighter = tile;
  brighter.intensity[100] = brighter.intensity[100] > 0.5f ? 0.0f : 1.0f;
  EXPECT_NE(pl::encode_tile(brighter), bytes);
  TileCloud turned = tile;
  turned.normals[100] = -turned.normals[100];
  EXPECT_NE(pl::encode_tile(turned), bytes);
  TileCloud fewer = tile;
  fewer.points.pop_back();
  fewer.normals.pop_back();
  fewer.intensity.pop_back();
  EXPECT_NE(pl::encode_tile(fewer), bytes);
  TileCloud shifted = tile;  // same shape one metre east: another origin
  for (auto& p : shifted.points) p.x() += 1.0;
  EXPECT_NE(pl::encode_tile(shifted), bytes);
}

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

// Debian's draco_decoder reads our tiles (as offsets from the tile origin).
TEST(TileCodec, DracoDecoderReadsTiles) {
  ASSERT_EQ(pl::test::run("command -v draco_decoder").exit_code, 0)
      << "draco_decoder is missing: apt-get install draco (./pl test installs it)";
  const pl::test::TempDir dir;
  const TileCloud tile = realistic_tile({4000.0, -2500.0, 0.0}, 8);
  TileCloud positions_only;
  positions_only.points = tile.points;
  for (const TileCloud* cloud : std::initializer_list<const TileCloud*>{&tile, &positions_only}) {
    pl::test::write_file(dir / "tile.drc", pl::encode_tile(*cloud));
    const auto r = pl::test::run("draco_decoder -i " + (dir / "tile.drc") + " -o " + (dir / "out.ply"));
    ASSERT_EQ(r.exit_code, 0) << r.output;
    const std::string ply = pl::test::read_file(dir / "out.ply");
    EXPECT_EQ(ply.rfind("ply\n", 0), 0u);
    EXPECT_NE(ply.find("element vertex " + std::to_string(cloud->size()) + "\n"), std::string::npos)
        << ply.substr(0, 300);
  }
}

// A Draco point cloud written by another tool (no "pl.origin" metadata) decodes with origin 0.
TEST(TileCodec, DecodesForeignDracoPointClouds) {
  ASSERT_EQ(pl::test::run("command -v draco_encoder").exit_code, 0)
      << "draco_encoder is missing: apt-get install draco (./pl test installs it)";
  const pl::test::TempDir dir;
  const TileCloud cloud = random_cloud(300, {-5.0, 2.0, 1.0}, {10, 10, 3}, 19);
  std::ostringstream ply;
  ply << "ply\nformat ascii 1.0\nelement vertex " << cloud.size()
      << "\nproperty float x\nproperty float y\nproperty float z\nend_header\n";
  for (const auto& p : cloud.points) ply << p.x() << ' ' << p.y() << ' ' << p.z() << '\n';
  pl::test::write_file(dir / "in.ply", ply.str());
  const auto r = pl::test::run("draco_encoder -point_cloud -qp 20 -i " + (dir / "in.ply") + " -o " + (dir / "in.drc"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const std::string bytes = pl::test::read_file(dir / "in.drc");
  const pl::TileSummary s = pl::inspect_tile(bytes);
  EXPECT_EQ(s.points, cloud.size());
  EXPECT_FALSE(s.has_normals);
  EXPECT_FALSE(s.has_intensity);
  TileCloud positions;
  positions.points = cloud.points;
  const TileCloud out = pl::decode_tile(bytes);
  const Errors e = compare(positions, out, 1e-3, 1, 1);  // 13 m at 20 bits, printed with 6 digits
  EXPECT_LT(e.position.maxCoeff(), 1e-3);
}

}  // namespace
