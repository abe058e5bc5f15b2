// Tile codec against Draco's own tools: normals exactly as Draco's decoder gives them, Debian's
// draco_decoder reads our tiles, and Draco point clouds written by draco_encoder decode.
#include <draco/compression/decode.h>
#include <gtest/gtest.h>

#include <cstdint>
#include <sstream>
#include <string>

#include "pl/common/tile_codec.hpp"
#include "test_util.hpp"
#include "tile_clouds.hpp"

namespace {

using pl::TileCloud;
using pl::TileCodecConfig;
using pl::test::Errors;
using pl::test::compare;
using pl::test::random_cloud;
using pl::test::realistic_tile;

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
