#include <gtest/gtest.h>

#include <filesystem>

#include <cmath>
#include <random>
#include <regex>

#include "pl/common/cloud_io.hpp"
#include "pl/common/error.hpp"
#include "pl/maps/map_builder.hpp"
#include "pl/registration/normals.hpp"
#include "pl/schema/http_client.hpp"
#include "pl/schema/signed_manifest.hpp"
#include "pl/schema/store.hpp"
#include "server_process.hpp"
#include "test_util.hpp"

using pl::test::TempDir;

namespace {
std::string pl_map(const std::string& args) { return pl::test::tool("pl-map") + " " + args; }
}  // namespace

TEST(Maps, VoxelAccumulatorAveragesOverAllScans) {
  pl::maps::VoxelAccumulator acc(0.5);
  acc.add({0.1, 0.1, 0.1}, 1.0f);
  acc.add({0.3, 0.3, 0.3}, 3.0f);  // same voxel, a later "scan"
  acc.add({0.3, 0.3, 0.3}, 3.0f);
  acc.add({-0.1, 0.1, 0.1}, 5.0f);
  std::vector<float> intensity;
  auto c = acc.centroids(intensity);
  ASSERT_EQ(c.size(), 2u);
  EXPECT_TRUE(c[0].isApprox(Eigen::Vector3d(0.7 / 3, 0.7 / 3, 0.7 / 3)));  // exact mean, not a mean of means
  EXPECT_FLOAT_EQ(intensity[0], 7.0f / 3);
  EXPECT_FLOAT_EQ(intensity[1], 5.0f);
}

TEST(Maps, VoxelAccumulatorFindsAVoxelAgainAfterOthersAndRefusesPointsBeyondItsReach) {
  pl::maps::VoxelAccumulator acc(0.2);
  const Eigen::Vector3d far(150e3, -150e3, 40.0);  // 150 km out: still within reach at 0.2 m
  acc.add(far, 1.0f);
  acc.add({0.05, 0.05, 0.05}, 2.0f);
  acc.add(far + Eigen::Vector3d(0.01, 0.01, 0.01), 3.0f);  // the first voxel again, after another
  acc.add({0.15, 0.05, 0.05}, 4.0f);
  std::vector<float> intensity;
  auto c = acc.centroids(intensity);
  ASSERT_EQ(c.size(), 2u);
  EXPECT_TRUE(c[0].isApprox(far + Eigen::Vector3d(0.005, 0.005, 0.005)));
  EXPECT_FLOAT_EQ(intensity[0], 2.0f);
  EXPECT_FLOAT_EQ(intensity[1], 3.0f);
  try {
    acc.add({0.0, 300e3, 0.0}, 1.0f);  // 300 km: beyond 2^20 voxels
    FAIL() << "no error";
  } catch (const pl::Error& e) {
    EXPECT_NE(std::string(e.what()).find("too far from the map's origin"), std::string::npos) << e.what();
  }
  EXPECT_EQ(acc.size(), 2u);  // nothing added by the refused point
}

TEST(Maps, NormalsOfPlanesFarFromTheOrigin) {
  pl::Points3d pts;
  Eigen::Vector3d offset(3500.0, -2200.0, 80.0);
  for (int i = 0; i < 40; ++i)
    for (int j = 0; j < 40; ++j) {
      pts.push_back(offset + Eigen::Vector3d(0.2 * i, 0.2 * j, 0.0));                 // ground
      pts.push_back(offset + Eigen::Vector3d(0.2 * i, 10.0, 0.2 * j + 0.5));          // a wall facing y
    }
  std::vector<float> planarity;
  auto n = pl::registration::estimate_normals(pts, 0.6, &planarity);
  for (std::size_t k = 0; k < pts.size(); k += 2) {
    EXPECT_NEAR(n[k].z(), 1.0f, 1e-4f) << k;  // oriented up
    EXPECT_NEAR(std::abs(n[k + 1].y()), 1.0f, 1e-4f) << k;
    EXPECT_GT(planarity[k], 0.99f);
  }
  pl::Points3d lonely = {Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(5, 5, 5)};
  EXPECT_EQ(pl::registration::estimate_normals(lonely, 0.6)[0], Eigen::Vector3f::UnitZ());
}

TEST(Maps, CutIntoTilesKeepsEveryPointInItsHalfOpenTile) {
  pl::Points3d pts = {Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(19.999, 5, 0), Eigen::Vector3d(20, 5, 0), Eigen::Vector3d(-0.001, -3, 0)};
  auto tiles = pl::maps::cut_into_tiles(pts, {}, {}, pl::TileGrid(20.0));
  ASSERT_EQ(tiles.size(), 3u);
  EXPECT_EQ(tiles.at({0, 0}).size(), 2u);
  EXPECT_EQ(tiles.at({1, 0}).size(), 1u);
  EXPECT_EQ(tiles.at({-1, -1}).size(), 1u);
}

TEST(Maps, BuildTileVersionsDiffRollbackFromTheCommandLine) {
  TempDir dir;
  // A drive to build from: a few VLP-16 scans of the town loop.
  auto sim = pl::test::run(pl::test::tool("pl-sim") + " --route loop --frames 6 --lidar vlp16 --out " + (dir / "drive"));
  ASSERT_EQ(sim.exit_code, 0) << sim.output;
  auto build = pl::test::run(pl_map("build --dataset " + (dir / "drive") + " --poses gt --out " + (dir / "map.pcd")));
  ASSERT_EQ(build.exit_code, 0) << build.output;
  pl::Cloud map = pl::read_cloud(dir / "map.pcd");
  ASSERT_GT(map.size(), 10000u);
  ASSERT_TRUE(map.origin.has_value());
  std::string db = dir / "maps.sqlite";
  auto tile = pl::test::run(pl_map("tile --cloud " + (dir / "map.pcd") + " --db " + db + " --map loop"));
  ASSERT_EQ(tile.exit_code, 0) << tile.output;
  EXPECT_NE(tile.output.find("version 1 staged (no parent)"), std::string::npos) << tile.output;
  // Published, then the same cloud again: every tile unchanged against its parent, stored once.
  EXPECT_EQ(pl::test::run(pl_map("publish --db " + db + " --map loop --version 1")).exit_code, 0);
  auto again = pl::test::run(pl_map("tile --cloud " + (dir / "map.pcd") + " --db " + db + " --map loop"));
  ASSERT_EQ(again.exit_code, 0) << again.output;
  EXPECT_NE(again.output.find("version 2 staged (parent v1)"), std::string::npos) << again.output;
  EXPECT_NE(again.output.find("(0 new or changed"), std::string::npos) << again.output;
  {
    auto store = pl::store::Store::open(db, false);
    auto t1 = store.list_tiles("loop", 1), t2 = store.list_tiles("loop", 2);
    ASSERT_EQ(t1.size(), t2.size());
    for (std::size_t i = 0; i < t1.size(); ++i) EXPECT_EQ(t1[i].hash, t2[i].hash);
  }
  EXPECT_EQ(pl::test::run(pl_map("publish --db " + db + " --map loop --version 2")).exit_code, 0);
  auto list = pl::test::run(pl_map("list --db " + db + " --map loop"));
  EXPECT_NE(list.output.find("* v2"), std::string::npos) << list.output;
  EXPECT_NE(list.output.find("retired"), std::string::npos) << list.output;
  auto info = pl::test::run(pl_map("info --db " + db + " --map loop"));
  EXPECT_NE(info.output.find("version      2 (published), current"), std::string::npos) << info.output;
  EXPECT_NE(info.output.find("MB per km2"), std::string::npos) << info.output;
  auto diff = pl::test::run(pl_map("diff --db " + db + " --map loop --from 1 --to 2"));
  EXPECT_NE(diff.output.find("0 added, 0 removed, 0 changed"), std::string::npos) << diff.output;
  auto rb = pl::test::run(pl_map("rollback --db " + db + " --map loop"));
  EXPECT_NE(rb.output.find("version 3 is current (the content of version 1)"), std::string::npos) << rb.output;
  EXPECT_EQ(pl::store::Store::open(db, false).find_version("loop", 3)->parent, 1);
  // Bad input says what to do and changes nothing.
  auto wrong = pl::test::run(pl_map("tile --cloud " + (dir / "map.pcd") + " --db " + db + " --map loop --tile-size 25"));
  EXPECT_EQ(wrong.exit_code, 2);
  EXPECT_NE(wrong.output.find("--tile-size 20"), std::string::npos) << wrong.output;
  pl::write_pcd(dir / "bare.pcd", {Eigen::Vector3d(1, 2, 3)}, {});
  auto bare = pl::test::run(pl_map("tile --cloud " + (dir / "bare.pcd") + " --db " + db + " --map other"));
  EXPECT_NE(bare.output.find("--origin LAT,LON,ALT"), std::string::npos) << bare.output;
  auto pub = pl::test::run(pl_map("publish --db " + db + " --map loop --version 1"));
  EXPECT_EQ(pub.exit_code, 2) << pub.output;
  EXPECT_EQ(pl::store::Store::open(db, false).find_map("loop")->current.value(), 3);
}

TEST(Maps, PushUploadsOnlyWhatTheServerLacks) {
  TempDir dir;
  pl::Points3d pts;
  for (double x = 0.1; x < 60; x += 0.4)
    for (double y = 0.1; y < 40; y += 0.4) pts.emplace_back(x, y, 0.05 * std::sin(x));
  pl::write_pcd(dir / "a.pcd", pts, {}, pl::GeoPoint{49.0, 8.4, 100.0});
  std::string local = dir / "local.sqlite", remote = dir / "remote.sqlite";
  ASSERT_EQ(pl::test::run(pl_map("tile --cloud " + (dir / "a.pcd") + " --db " + local + " --map m")).exit_code, 0);
  // The server's store exists (with the tokens) but has no map yet.
  { auto s = pl::store::Store::open(remote); }
  pl::test::write_file(dir / "tokens.txt", "admin adm-1\nupload up-1\n");
  pl::test::ServerProcess server(remote, {"--tokens", dir / "tokens.txt"});
  auto up = pl::test::run(pl_map("push --db " + local + " --map m --version 1 --server " + server.url() + " --token up-1"));
  EXPECT_EQ(up.exit_code, 2);  // creating the map needs the admin role
  EXPECT_NE(up.output.find("403"), std::string::npos) << up.output;
  auto first = pl::test::run(pl_map("push --db " + local + " --map m --version 1 --server " + server.url() + " --token adm-1"));
  ASSERT_EQ(first.exit_code, 0) << first.output;
  std::smatch m;
  std::regex re("([0-9]+) tiles, ([0-9]+) uploaded");
  ASSERT_TRUE(std::regex_search(first.output, m, re)) << first.output;
  EXPECT_EQ(m[1], m[2]);
  // Change one corner of the cloud: a second push uploads that tile only.
  for (auto& p : pts)
    if (p.x() < 20 && p.y() < 20) p.z() += 0.5;
  pl::write_pcd(dir / "b.pcd", pts, {}, pl::GeoPoint{49.0, 8.4, 100.0});
  ASSERT_EQ(pl::test::run(pl_map("tile --cloud " + (dir / "b.pcd") + " --db " + local + " --map m")).exit_code, 0);
  // The corner tile changes, and so do its neighbours' normals along the seam; nothing else.
  std::size_t changed = 0;
  {
    auto s = pl::store::Store::open(local, false);
    auto t1 = s.list_tiles("m", 1), t2 = s.list_tiles("m", 2);
    ASSERT_EQ(t1.size(), t2.size());
    for (std::size_t i = 0; i < t1.size(); ++i) changed += t1[i].hash != t2[i].hash;
  }
  ASSERT_GE(changed, 1u);
  ASSERT_LT(changed, 6u);
  // The second version has places (opaque to the store and the server): the push carries them.
  pl::store::Store::open(local, false).put_places("m", 2, "places of v2");
  auto second = pl::test::run(pl_map("push --db " + local + " --map m --version 2 --server " + server.url() + " --token up-1"));
  ASSERT_EQ(second.exit_code, 0) << second.output;
  EXPECT_NE(second.output.find("as v2: 6 tiles, " + std::to_string(changed) + " uploaded"), std::string::npos) << second.output;
  auto store = pl::store::Store::open(remote, false);
  EXPECT_EQ(store.find_map("m")->current.value(), 2);
  EXPECT_FALSE(store.places("m", 1).has_value());
  EXPECT_EQ(store.places("m", 2).value_or("none"), "places of v2");
  auto a = pl::store::Store::open(local, false).list_tiles("m", 2), b = store.list_tiles("m", 2);
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) EXPECT_EQ(a[i].hash, b[i].hash);
}

// Signed maps end to end: pl-map key-gen makes the fleet's pair; pl-map publish --signing-key
// signs a local version; a server with --fleet-key takes only pushes signed with the fleet's key,
// and serves the signed manifest, which verifies against the public key and names exactly the
// pushed tiles.
TEST(Maps, SignedPublishAndPushWithTheFleetKey) {
  TempDir dir;
  pl::Points3d pts;
  for (double x = 0.1; x < 50; x += 0.4)
    for (double y = 0.1; y < 30; y += 0.4) pts.emplace_back(x, y, 0.05 * std::sin(x));
  pl::write_pcd(dir / "a.pcd", pts, {}, pl::GeoPoint{49.0, 8.4, 100.0});
  const std::string local = dir / "local.sqlite", remote = dir / "remote.sqlite";
  ASSERT_EQ(pl::test::run(pl_map("tile --cloud " + (dir / "a.pcd") + " --db " + local + " --map m")).exit_code, 0);

  auto gen = pl::test::run(pl_map("key-gen --out " + (dir / "fleet")));
  ASSERT_EQ(gen.exit_code, 0) << gen.output;
  const auto fleet = pl::signing::load_public_keys(dir / "fleet.pub");
  ASSERT_EQ(fleet.size(), 1u);
  EXPECT_NE(gen.output.find("key " + pl::signing::key_id(fleet[0])), std::string::npos) << gen.output;
  EXPECT_EQ(pl::signing::SigningKey::load(dir / "fleet.key").public_key(), fleet[0]);
  auto again = pl::test::run(pl_map("key-gen --out " + (dir / "fleet")));
  EXPECT_EQ(again.exit_code, 2);
  EXPECT_NE(again.output.find("never written over"), std::string::npos) << again.output;
  EXPECT_EQ(pl::signing::SigningKey::load(dir / "fleet.key").public_key(), fleet[0]);  // untouched
  ASSERT_EQ(pl::test::run(pl_map("key-gen --out " + (dir / "other"))).exit_code, 0);

  // A local publish, signed: pl-map info checks the signature against the store's manifest.
  auto pub = pl::test::run(pl_map("publish --db " + local + " --map m --version 1 --signing-key " + (dir / "fleet.key")));
  ASSERT_EQ(pub.exit_code, 0) << pub.output;
  EXPECT_NE(pub.output.find("signed by key " + pl::signing::key_id(fleet[0])), std::string::npos) << pub.output;
  auto info = pl::test::run(pl_map("info --db " + local + " --map m"));
  EXPECT_NE(info.output.find("key " + pl::signing::key_id(fleet[0])), std::string::npos) << info.output;
  EXPECT_NE(info.output.find(": verifies"), std::string::npos) << info.output;

  // A server that takes signed publishes only.
  { auto s = pl::store::Store::open(remote); }
  pl::test::write_file(dir / "tokens.txt", "admin adm-1\nupload up-1\n");
  pl::test::ServerProcess server(remote, {"--tokens", dir / "tokens.txt", "--fleet-key", dir / "fleet.pub"});
  const std::string push = pl_map("push --db " + local + " --map m --version 1 --server " + server.url() + " --token adm-1");
  auto unsigned_push = pl::test::run(push);
  EXPECT_EQ(unsigned_push.exit_code, 2);
  EXPECT_NE(unsigned_push.output.find("signed versions only"), std::string::npos) << unsigned_push.output;
  auto wrong_key = pl::test::run(push + " --signing-key " + (dir / "other.key"));
  EXPECT_EQ(wrong_key.exit_code, 2);
  EXPECT_NE(wrong_key.output.find("not one of this server's fleet keys"), std::string::npos) << wrong_key.output;
  EXPECT_FALSE(pl::store::Store::open(remote, false).find_map("m")->current);  // nothing published yet
  auto good = pl::test::run(push + " --signing-key " + (dir / "fleet.key"));
  ASSERT_EQ(good.exit_code, 0) << good.output;

  // The served manifest: signed, verifying against the fleet key, naming the local tiles.
  pl::api::HttpClient http(server.url());
  const auto store = pl::store::Store::open(remote, false);
  const std::int64_t v = *store.find_map("m")->current;
  auto res = http.get("/v1/maps/m/versions/" + std::to_string(v) + "/manifest");
  ASSERT_EQ(res.status, 200) << res.body;
  EXPECT_EQ(res.header("cache-control"), "public, max-age=31536000, immutable");
  EXPECT_EQ(res.header("etag"), "\"" + pl::store::content_hash(res.body) + "\"");
  const auto sm = pl::signing::verify_signed_manifest(res.body, fleet);
  const auto mine = pl::store::Store::open(local, false).list_tiles("m", 1);
  ASSERT_EQ(sm.manifest.tiles.size(), mine.size());
  for (std::size_t i = 0; i < mine.size(); ++i) EXPECT_EQ(sm.manifest.tiles[i].hash, mine[i].hash);
  EXPECT_EQ(sm.manifest.version, v);
  EXPECT_EQ(http.get("/v1/maps/m/versions/" + std::to_string(v) + "/manifest", {{"If-None-Match", res.header("etag")}}).status, 304);
  // The upload log names the key; the remote store's info checks the signature too.
  bool logged = false;
  for (const auto& e : store.upload_log("m")) logged |= e.action == "publish" && e.detail == "signed by key " + pl::signing::key_id(fleet[0]);
  EXPECT_TRUE(logged);
  auto remote_info = pl::test::run(pl_map("info --db " + remote + " --map m"));
  EXPECT_NE(remote_info.output.find(": verifies"), std::string::npos) << remote_info.output;

  // A rollback of a signed map: refused unsigned (the fleet would refuse it), nothing written; signed,
  // a new version with the old content whose signature verifies.
  {
    auto s = pl::store::Store::open(local, false);
    s.create_version("m", std::nullopt, "v2");
  }
  ASSERT_EQ(pl::test::run(pl_map("publish --db " + local + " --map m --version 2 --signing-key " + (dir / "fleet.key"))).exit_code, 0);
  auto unsigned_rb = pl::test::run(pl_map("rollback --db " + local + " --map m"));
  EXPECT_EQ(unsigned_rb.exit_code, 2);
  EXPECT_NE(unsigned_rb.output.find("version 2 is signed"), std::string::npos) << unsigned_rb.output;
  EXPECT_NE(unsigned_rb.output.find("--signing-key"), std::string::npos) << unsigned_rb.output;
  EXPECT_EQ(pl::store::Store::open(local, false).list_versions("m").size(), 2u);
  auto signed_rb = pl::test::run(pl_map("rollback --db " + local + " --map m --signing-key " + (dir / "fleet.key")));
  ASSERT_EQ(signed_rb.exit_code, 0) << signed_rb.output;
  EXPECT_NE(signed_rb.output.find("version 3 is current (the content of version 1), signed by key " + pl::signing::key_id(fleet[0])),
            std::string::npos)
      << signed_rb.output;
  const auto after = pl::store::Store::open(local, false);
  const auto sig = after.signature("m", 3);
  ASSERT_TRUE(sig);
  EXPECT_TRUE(pl::signing::verify(sig->public_key, pl::signing::manifest_text(pl::signing::manifest_of(after, "m", 3)), sig->signature));
  ASSERT_EQ(after.list_tiles("m", 3).size(), mine.size());
  for (std::size_t i = 0; i < mine.size(); ++i) EXPECT_EQ(after.list_tiles("m", 3)[i].hash, mine[i].hash);
  bool rolled = false;
  for (const auto& e : after.upload_log("m"))
    rolled |= e.action == "rollback" && e.version == 3 && e.detail == "the content of v1, signed by key " + pl::signing::key_id(fleet[0]);
  EXPECT_TRUE(rolled);
}

// The cloud readers behind pl-map tile: every PCD and PLY the fuzzers found crashing or over-
// allocating is refused by the real tool with an error naming the file, and writes no map.
TEST(Maps, TileRefusesEveryCrashingCloudTheFuzzersFound) {
  pl::test::TempDir dir;
  const std::string db = dir / "maps.sqlite";
  int files = 0;
  for (const std::string kind : {"pcd", "ply"}) {
    for (const auto& e : std::filesystem::directory_iterator(std::string(PL_SOURCE_DIR) + "/tests/fuzz/regressions/" + kind)) {
      const std::string path = dir / (e.path().filename().string() + "." + kind);
      std::filesystem::copy_file(e.path(), path);
      auto r = pl::test::run(pl_map("tile --cloud " + path + " --db " + db + " --map m"));
      ++files;
      if (r.exit_code == 0) continue;  // a few findings were bad only in how they were read: now they read
      EXPECT_EQ(r.exit_code, 2) << path << ": " << r.output;  // pl-map's error exit, not a sanitizer report or a signal
      EXPECT_NE(r.output.find(path), std::string::npos) << r.output;
      EXPECT_EQ(r.output.find("Sanitizer"), std::string::npos) << r.output;
    }
  }
  EXPECT_GE(files, 5);
}

// A failed import changes nothing: into a new --db path it leaves no file (also when the failure
// comes after the store was created: an invalid map name is refused by create_map); into an
// existing store it leaves no new map and no new version.
TEST(Maps, FailedImportLeavesNoStoreMapOrVersion) {
  TempDir dir;
  pl::write_pcd(dir / "empty.pcd", {}, {}, pl::GeoPoint{49.0, 8.4, 100.0});
  pl::Points3d pts;
  for (double x = 0.1; x < 30; x += 0.4)
    for (double y = 0.1; y < 30; y += 0.4) pts.emplace_back(x, y, 0.0);
  pl::write_pcd(dir / "a.pcd", pts, {}, pl::GeoPoint{49.0, 8.4, 100.0});
  pl::test::write_file(dir / "garbage.pcd", "not a point cloud\n");
  const std::string fresh = dir / "fresh.sqlite";
  struct Case {
    std::string args, expected;
  };
  const std::vector<Case> failing = {
      {"--cloud " + (dir / "empty.pcd") + " --map m", "empty.pcd: no points"},
      {"--cloud " + (dir / "missing.pcd") + " --map m", "missing.pcd"},
      {"--cloud " + (dir / "garbage.pcd") + " --map m", "garbage.pcd"},
      {"--cloud " + (dir / "a.pcd") + " --map 'bad name!'", "invalid map name"},
      {"--cloud " + (dir / "a.pcd") + " --map m --normal-radius 1", "give --normal-bits 6 too"},
  };
  for (const auto& c : failing) {
    auto r = pl::test::run(pl_map("tile " + c.args + " --db " + fresh));
    EXPECT_EQ(r.exit_code, 2) << c.args << "\n" << r.output;
    EXPECT_NE(r.output.find(c.expected), std::string::npos) << c.args << "\n" << r.output;
    EXPECT_FALSE(std::filesystem::exists(fresh)) << c.args;
    EXPECT_FALSE(std::filesystem::exists(fresh + "-wal")) << c.args;
  }
  // An existing store with one map of one version: the same failures add nothing to it.
  const std::string db = dir / "maps.sqlite";
  ASSERT_EQ(pl::test::run(pl_map("tile --cloud " + (dir / "a.pcd") + " --db " + db + " --map m")).exit_code, 0);
  for (const auto& c : failing) {
    for (const std::string map : {"m", "n"}) {
      std::string args = c.args;
      if (c.expected != "invalid map name") args.replace(args.rfind(" --map m"), 8, " --map " + map);
      auto r = pl::test::run(pl_map("tile " + args + " --db " + db));
      EXPECT_EQ(r.exit_code, 2) << args << "\n" << r.output;
      auto store = pl::store::Store::open(db, false);
      ASSERT_EQ(store.list_maps().size(), 1u) << args;
      EXPECT_EQ(store.list_versions("m").size(), 1u) << args;
    }
  }
}

// Output paths are checked before the work: a path under a regular file (root may write anywhere
// else) or in a folder that does not exist fails at once, naming the path and the fix, and the
// drive is not even read.
TEST(Maps, UnwritableOutputsFailBeforeTheWork) {
  TempDir dir;
  auto sim = pl::test::run(pl::test::tool("pl-sim") + " --route loop --frames 3 --lidar vlp16 --out " + (dir / "drive"));
  ASSERT_EQ(sim.exit_code, 0) << sim.output;
  pl::test::write_file(dir / "file.txt", "a regular file\n");
  const std::string under_file = dir / "file.txt/map.pcd", no_dir = dir / "no/such/folder/map.pcd";
  const std::string build = "build --dataset " + (dir / "drive") + " --poses lidar ";
  const std::vector<std::pair<std::string, std::string>> cases = {
      {build + "--out " + under_file, under_file},
      {build + "--out " + no_dir, no_dir},
      {build + "--out " + (dir / "ok.pcd") + " --traj-out " + under_file, under_file},
      {build + "--out " + (dir / "ok.pcd") + " --report " + no_dir, no_dir},
      {build + "--out " + (dir / "ok.pcd") + " --odometry-out " + no_dir, no_dir},
      {"tile --cloud " + (dir / "ok.pcd") + " --map m --db " + under_file, under_file},
  };
  for (const auto& [args, path] : cases) {
    auto r = pl::test::run(pl_map(args));
    EXPECT_EQ(r.exit_code, 2) << args << "\n" << r.output;
    EXPECT_NE(r.output.find("cannot write " + path), std::string::npos) << args << "\n" << r.output;
    EXPECT_EQ(r.output.find("lidar odometry"), std::string::npos) << args << "\n" << r.output;  // no work was done
    EXPECT_FALSE(std::filesystem::exists(dir / "ok.pcd"));
  }
  auto r = pl::test::run(pl_map(build + "--out " + under_file));
  EXPECT_NE(r.output.find(dir / "file.txt is a file, not a folder"), std::string::npos) << r.output;
  r = pl::test::run(pl_map(build + "--out " + no_dir));
  EXPECT_NE(r.output.find("the folder " + (dir / "no/such/folder") + " does not exist"), std::string::npos) << r.output;
}
