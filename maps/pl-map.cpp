// pl-map: build maps from drives, cut them into Draco tiles in a versioned SQLite store, publish.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <memory>
#include <optional>
#include <set>

#include "pl/common/cli.hpp"
#include "pl/common/cloud_io.hpp"
#include "pl/common/error.hpp"
#include "pl/common/progress.hpp"
#include "pl/common/text.hpp"
#include "pl/common/output_path.hpp"
#include "pl/maps/gloam.hpp"
#include "pl/maps/import.hpp"
#include "pl/maps/push.hpp"
#include "pl/schema/store.hpp"

namespace {

const char* kUsage =
    "usage: pl-map COMMAND [options]\n"
    "\n"
    "  build    --dataset DIR --out map.pcd [--poses gt|lidar] [--gps] [--loops] [--traj-out poses.txt] [--report FILE.json]\n"
    "           [--deskew auto|on|off] [--voxel 0.2] [--every N] [--max-range 80]\n"
    "           merge a drive's scans at their ground-truth poses (gt) or at the poses of LiDAR odometry\n"
    "           (lidar; without --gps started at the first ground-truth pose when there is one, with --gps the\n"
    "           ground truth is not used; deskew auto: on\n"
    "           for recordings without meta.json) into a voxelized map (PCD in the dataset's world\n"
    "           frame, its geodetic origin recorded in the header); --traj-out writes the LiDAR pose of\n"
    "           every scan, line for line with the dataset (KITTI format; TUM with the scan times when FILE\n"
    "           ends in .tum); --gps (with --poses lidar): a pose graph\n"
    "           of keyframes over the odometry with the drive's GPS fixes (robust to multipath) sets the poses;\n"
    "           --loops (with --poses lidar): loop closures found by position and by a place descriptor, verified\n"
    "           by ICP, join the graph (re-solved on each); --report writes JSON: keyframes, GPS edges and outliers,\n"
    "           GPS residuals, loops proposed/accepted/rejected (and why), the mean translation error against\n"
    "           ground truth (when there is one) before and after the graph, times\n"
    "  tile     --cloud FILE(.pcd|.ply|.bin) --db maps.sqlite --map NAME [--origin LAT,LON,ALT]\n"
    "           [--voxel 0.2] [--tile-size 20] [--normal-radius 0.6] [--max-error 0.005] [--note TEXT]\n"
    "           voxelize, estimate normals, cut into tiles, Draco-encode them and write a new staged\n"
    "           version (the map is created on first use; unchanged tiles share their stored bytes)\n"
    "  publish  --db FILE --map NAME --version N      make a staged version current (one transaction)\n"
    "  rollback --db FILE --map NAME                  make the previously published version current again\n"
    "  list     --db FILE [--map NAME]                maps, or the versions of one map\n"
    "  info     --db FILE --map NAME [--version N]    a map's manifest (default: the current version)\n"
    "  diff     --db FILE --map NAME --from A --to B  tiles added, removed and changed between versions\n"
    "  push     --db FILE --map NAME --version N --server URL --token T\n"
    "           upload a local version to a server (only the tiles it lacks), then publish it there\n";

std::string mb(double bytes) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.2f MB", bytes / 1e6);
  return buf;
}

int cmd_build(const pl::Args& a) {
  std::string dir = a.require("--dataset", "DIR (the drive to build the map from)");
  std::string poses = a.get_or("--poses", "gt");
  std::string out = a.require("--out", "FILE.pcd (where to write the map)");
  auto traj_out = a.get("--traj-out");
  auto report_path = a.get("--report");
  std::string deskew = a.get_or("--deskew", "auto");
  pl::maps::GloamConfig cfg;
  cfg.gps = a.has("--gps");
  cfg.loops = a.has("--loops");
  cfg.merge.voxel_m = a.get_double("--voxel", cfg.merge.voxel_m);
  cfg.merge.every = static_cast<std::size_t>(std::max<long long>(1, a.get_int("--every", 1)));
  cfg.merge.scan.min_range_m = a.get_double("--min-range", cfg.merge.scan.min_range_m);
  cfg.merge.scan.max_range_m = a.get_double("--max-range", cfg.merge.scan.max_range_m);
  a.finish();
  if (poses != "gt" && poses != "lidar")
    throw pl::Error("--poses takes gt (the dataset's ground truth) or lidar (LiDAR odometry alone), not " + poses);
  if (deskew != "auto" && deskew != "on" && deskew != "off") throw pl::Error("--deskew takes auto, on or off, not " + deskew);
  cfg.poses = poses == "gt" ? pl::maps::PoseSource::GroundTruth : pl::maps::PoseSource::Lidar;
  cfg.deskew = deskew == "on" ? pl::maps::Deskew::On : deskew == "off" ? pl::maps::Deskew::Off : pl::maps::Deskew::Auto;
  pl::maps::check_gloam_config(cfg);
  // Every output is checked before the work starts: a bad path fails now, not after hours.
  pl::check_output_file(out);
  if (traj_out) pl::check_output_file(*traj_out);
  if (report_path) pl::check_output_file(*report_path);
  const pl::Dataset ds = pl::open_dataset(dir);
  pl::StageProgress bars;
  pl::maps::GloamObserver observer;
  observer.progress = [&](const std::string& stage, std::size_t done, std::size_t total) { bars.update(stage, done, total); };
  observer.log = [&](const std::string& line) {
    bars.finish();
    std::printf("%s\n", line.c_str());
  };
  const pl::maps::GloamResult r = pl::maps::build_gloam_map(ds, cfg, observer);
  bars.finish();
  if (report_path) {
    std::ofstream f(*report_path);
    f << r.report_json;
    if (!f) throw pl::Error(*report_path + ": cannot write the report");
    std::printf("wrote %s\n", report_path->c_str());
  }
  if (traj_out) {
    // KITTI (12 numbers a line), or TUM with the scan times when the file name ends in .tum.
    const bool tum = traj_out->size() > 4 && traj_out->compare(traj_out->size() - 4, 4, ".tum") == 0;
    pl::write_trajectory(*traj_out, r.poses, tum ? pl::PoseFormat::Tum : pl::PoseFormat::Kitti);
    std::printf("wrote %s: %zu LiDAR poses (%s), one per scan\n", traj_out->c_str(), r.poses.size(), r.source.c_str());
  }
  pl::write_pcd(out, r.map.points, r.map.intensity, r.origin);
  std::printf("wrote %s: %zu points from %zu scans at %.2f m voxels\n", out.c_str(), r.map.points.size(), r.merged_scans,
              cfg.merge.voxel_m);
  return 0;
}

int cmd_tile(const pl::Args& a) {
  std::string cloud_path = a.require("--cloud", "FILE (.pcd, .ply or .bin, in the map's local ENU frame)");
  std::string db = a.require("--db", "FILE (the SQLite map store; created when missing)");
  std::string name = a.require("--map", "NAME");
  auto origin_flag = a.get("--origin");
  pl::maps::ImportConfig cfg;
  cfg.voxel_m = a.get_double("--voxel", cfg.voxel_m);
  cfg.tile_size_m = a.get_double("--tile-size", cfg.tile_size_m);
  cfg.normal_radius_m = a.get_double("--normal-radius", cfg.normal_radius_m);
  cfg.codec.max_error_m = a.get_double("--max-error", cfg.codec.max_error_m);
  cfg.note = a.get_or("--note", "");
  a.finish();
  pl::maps::check_import_config(cfg);
  if (origin_flag) {
    auto v = pl::parse_number_list(*origin_flag, 3, "--origin");
    cfg.origin = pl::GeoPoint{v[0], v[1], v[2]};
  }
  if (!pl::file_exists(db)) pl::check_output_file(db);  // before the cloud is read
  const pl::Cloud cloud = pl::read_cloud(cloud_path);
  std::unique_ptr<pl::Progress> bars;
  const pl::maps::ImportResult r = pl::maps::import_cloud(db, name, cloud, cloud_path, cfg, [&](std::size_t done, std::size_t total) {
    if (!bars) bars = std::make_unique<pl::Progress>("encoding tiles", total);
    bars->update(done);
  });
  if (bars) bars->finish();
  const pl::store::VersionInfo& v = r.version;
  std::string parent = v.parent ? "parent v" + std::to_string(*v.parent) : "no parent";
  std::printf("map %s version %lld staged (%s): %zu tiles (%zu new or changed, %zu unchanged, %zu removed), %zu points, %s\n",
              name.c_str(), static_cast<long long>(v.number), parent.c_str(), r.tiles, r.changed, r.unchanged, r.removed, r.points,
              mb(r.bytes).c_str());
  std::printf("publish it with: pl-map publish --db %s --map %s --version %lld\n", db.c_str(), name.c_str(),
              static_cast<long long>(v.number));
  return 0;
}

pl::store::MapInfo need_map(const pl::store::Store& s, const std::string& name) {
  auto m = s.find_map(name);
  if (!m) throw pl::Error(s.path() + ": no map named \"" + name + "\" (pl-map list --db " + s.path() + " shows the maps)");
  return *m;
}

void print_version(const pl::store::VersionInfo& v, bool current) {
  std::printf("  %s v%-4lld %-9s %6lld tiles %10lld points %10s  %s%s%s\n", current ? "*" : " ", static_cast<long long>(v.number),
              pl::store::state_name(v.state), static_cast<long long>(v.tiles), static_cast<long long>(v.points),
              mb(static_cast<double>(v.bytes)).c_str(), v.created.c_str(), v.note.empty() ? "" : "  ", v.note.c_str());
}

int cmd_publish(const pl::Args& a) {
  std::string db = a.require("--db", "FILE"), name = a.require("--map", "NAME");
  long long version = a.get_int("--version", -1);
  a.finish();
  if (version < 1) throw pl::Error("missing --version N (the staged version to publish)");
  auto store = pl::store::Store::open(db, false);
  need_map(store, name);
  store.publish(name, version);
  store.log_upload(name, version, "publish", "", "pl-map");
  std::printf("map %s: version %lld is current\n", name.c_str(), version);
  return 0;
}

int cmd_rollback(const pl::Args& a) {
  std::string db = a.require("--db", "FILE"), name = a.require("--map", "NAME");
  a.finish();
  auto store = pl::store::Store::open(db, false);
  need_map(store, name);
  auto v = store.rollback(name);
  store.log_upload(name, v, "rollback", "", "pl-map");
  std::printf("map %s: rolled back, version %lld is current\n", name.c_str(), static_cast<long long>(v));
  return 0;
}

int cmd_list(const pl::Args& a) {
  std::string db = a.require("--db", "FILE");
  auto name = a.get("--map");
  a.finish();
  auto store = pl::store::Store::open(db, false);
  if (name) {
    auto m = need_map(store, *name);
    std::printf("map %s (tile %.1f m, voxel %.2f m)\n", m.name.c_str(), m.tile_size, m.voxel_size);
    for (const auto& v : store.list_versions(*name)) print_version(v, m.current && *m.current == v.number);
    return 0;
  }
  auto maps = store.list_maps();
  if (maps.empty()) std::printf("no maps in %s\n", db.c_str());
  for (const auto& m : maps)
    std::printf("%-24s current %s, tile %.1f m, voxel %.2f m, origin %.7f %.7f %.2f\n", m.name.c_str(),
                m.current ? ("v" + std::to_string(*m.current)).c_str() : "none", m.tile_size, m.voxel_size, m.origin.lat_deg,
                m.origin.lon_deg, m.origin.alt_m);
  return 0;
}

int cmd_info(const pl::Args& a) {
  std::string db = a.require("--db", "FILE"), name = a.require("--map", "NAME");
  long long version = a.get_int("--version", 0);
  a.finish();
  auto store = pl::store::Store::open(db, false);
  auto m = need_map(store, name);
  if (version == 0) {
    if (!m.current) throw pl::Error("map " + name + " has no published version yet: give --version N");
    version = *m.current;
  }
  auto v = store.find_version(name, version);
  if (!v) throw pl::Error("map " + name + " has no version " + std::to_string(version));
  auto tiles = store.list_tiles(name, version);
  double lo_x = INFINITY, lo_y = INFINITY, hi_x = -INFINITY, hi_y = -INFINITY;
  for (const auto& t : tiles) lo_x = std::min(lo_x, t.min_x), lo_y = std::min(lo_y, t.min_y), hi_x = std::max(hi_x, t.max_x), hi_y = std::max(hi_y, t.max_y);
  double area_km2 = static_cast<double>(tiles.size()) * m.tile_size * m.tile_size / 1e6;
  std::printf("map          %s\n", m.name.c_str());
  std::printf("version      %lld (%s)%s, created %s\n", version, pl::store::state_name(v->state),
              m.current && *m.current == version ? ", current" : "", v->created.c_str());
  std::printf("origin       lat %.9f, lon %.9f, alt %.3f m\n", m.origin.lat_deg, m.origin.lon_deg, m.origin.alt_m);
  std::printf("grid         %.1f m tiles, %.2f m voxels\n", m.tile_size, m.voxel_size);
  std::printf("tiles        %zu covering %.4f km2, %lld points, %s (%.1f MB per km2 of tiles)\n", tiles.size(), area_km2,
              static_cast<long long>(v->points), mb(static_cast<double>(v->bytes)).c_str(),
              area_km2 > 0 ? static_cast<double>(v->bytes) / 1e6 / area_km2 : 0.0);
  if (!tiles.empty()) std::printf("bounds       x %.1f .. %.1f, y %.1f .. %.1f m\n", lo_x, hi_x, lo_y, hi_y);
  return 0;
}

int cmd_diff(const pl::Args& a) {
  std::string db = a.require("--db", "FILE"), name = a.require("--map", "NAME");
  long long from = a.get_int("--from", -1), to = a.get_int("--to", -1);
  a.finish();
  if (from < 1 || to < 1) throw pl::Error("diff needs --from A --to B (version numbers)");
  auto store = pl::store::Store::open(db, false);
  need_map(store, name);
  for (long long v : {from, to})
    if (!store.find_version(name, v)) throw pl::Error("map " + name + " has no version " + std::to_string(v));
  std::map<pl::TileKey, std::string> a_tiles, b_tiles;
  for (const auto& t : store.list_tiles(name, from)) a_tiles[t.key] = t.hash;
  for (const auto& t : store.list_tiles(name, to)) b_tiles[t.key] = t.hash;
  std::size_t added = 0, removed = 0, changed = 0, same = 0;
  for (const auto& [k, h] : b_tiles) {
    auto it = a_tiles.find(k);
    if (it == a_tiles.end()) {
      ++added;
      std::printf("+ %d %d\n", k.tx, k.ty);
    } else if (it->second != h) {
      ++changed;
      std::printf("~ %d %d\n", k.tx, k.ty);
    } else {
      ++same;
    }
  }
  for (const auto& [k, h] : a_tiles)
    if (!b_tiles.count(k)) {
      ++removed;
      std::printf("- %d %d\n", k.tx, k.ty);
    }
  std::printf("v%lld -> v%lld: %zu added, %zu removed, %zu changed, %zu unchanged\n", from, to, added, removed, changed, same);
  return 0;
}

int cmd_push(const pl::Args& a) {
  pl::maps::PushOptions o;
  o.db = a.require("--db", "FILE");
  o.map = a.require("--map", "NAME");
  o.version = a.get_int("--version", -1);
  o.server = a.require("--server", "URL (e.g. http://127.0.0.1:8080)");
  o.token = a.require("--token", "TOKEN (of the upload role; admin to create the map there)");
  a.finish();
  if (o.version < 1) throw pl::Error("missing --version N (the local version to push)");
  auto r = pl::maps::push_version(o);
  std::printf("pushed map %s v%lld to %s as v%lld: %zu tiles, %zu uploaded (%s), %zu already there, %zu deleted; published\n",
              o.map.c_str(), static_cast<long long>(o.version), o.server.c_str(), static_cast<long long>(r.remote_version), r.tiles,
              r.uploaded, mb(static_cast<double>(r.bytes)).c_str(), r.skipped, r.deleted);
  return 0;
}

int body(int argc, char** argv) {
  if (argc < 2 || std::string(argv[1]) == "--help" || std::string(argv[1]) == "-h") {
    std::fputs(kUsage, argc < 2 ? stderr : stdout);
    return argc < 2 ? 2 : 0;
  }
  std::string cmd = argv[1];
  pl::Args args(argc, argv, 2, {"--gps", "--loops"});
  if (!args.positional().empty()) throw pl::Error("unexpected argument \"" + args.positional()[0] + "\" (see pl-map --help)");
  if (cmd == "build") return cmd_build(args);
  if (cmd == "tile") return cmd_tile(args);
  if (cmd == "publish") return cmd_publish(args);
  if (cmd == "rollback") return cmd_rollback(args);
  if (cmd == "list") return cmd_list(args);
  if (cmd == "info") return cmd_info(args);
  if (cmd == "diff") return cmd_diff(args);
  if (cmd == "push") return cmd_push(args);
  throw pl::Error("unknown command \"" + cmd + "\" (build, tile, publish, rollback, list, info, diff or push; see --help)");
}

}  // namespace

int main(int argc, char** argv) { return pl::run_cli("pl-map", body, argc, argv); }
