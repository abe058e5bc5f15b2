// pl-map: build maps from drives, cut them into Draco tiles in a versioned SQLite store, publish.
// The pipelines are in pl_maps (gloam.hpp, import.hpp, catalog.hpp, push.hpp); this is the command line.
#include <cstdio>
#include <fstream>
#include <functional>
#include <sstream>
#include <memory>
#include <optional>
#include <string>

#include "pl/common/cli.hpp"
#include "pl/common/cloud_io.hpp"
#include "pl/common/error.hpp"
#include "pl/common/output_path.hpp"
#include "pl/common/progress.hpp"
#include "pl/common/text.hpp"
#include "pl/schema/signed_manifest.hpp"
#include "pl/maps/catalog.hpp"
#include "pl/maps/change_detect.hpp"
#include "pl/maps/gloam.hpp"
#include "pl/maps/import.hpp"
#include "pl/maps/map_update.hpp"
#include "pl/maps/push.hpp"
#include "pl/schema/store.hpp"
#include "pl/schema/store_copy.hpp"

namespace {

using pl::cli::Tool;
namespace maps = pl::maps;

// --db FILE of an existing store, or (`create`) of one that may be created.
CLI::Option* db_option(CLI::App& c, std::string& db, bool create) {
  auto check = [create](std::string& path) -> std::string {
    if (pl::store::is_postgres_url(path) || pl::file_exists(path)) return "";
    return create ? pl::output_file_problem(path) : path + ": no such map store (create one with pl-map tile)";
  };
  return c.add_option("--db", db,
                      create ? "the map store: a SQLite file (created when missing) or a postgresql://USER@HOST/DB URL"
                             : "the map store: a SQLite file or a postgresql://USER@HOST/DB URL")
      ->required()->type_name("FILE|URL")->check(CLI::Validator(check, ""));
}

void add_build(Tool& tool) {
  struct State {
    std::string dataset, out, traj_out, odometry_out, report, poses = "gt", deskew = "auto";
    pl::DatasetOptions topics;
    maps::GloamConfig cfg;
  };
  auto s = std::make_shared<State>();
  CLI::App& c = tool.command("build", "merge a drive's scans into a voxelized map (PCD in the dataset's world frame, its "
                             "geodetic origin in the header) at ground-truth or LiDAR-odometry poses", [s] {
    s->cfg.poses = s->poses == "gt" ? maps::PoseSource::GroundTruth : maps::PoseSource::Lidar;
    s->cfg.deskew = s->deskew == "on" ? maps::Deskew::On : s->deskew == "off" ? maps::Deskew::Off : maps::Deskew::Auto;
    maps::check_gloam_config(s->cfg);
    if (!s->odometry_out.empty() && s->cfg.poses != maps::PoseSource::Lidar)
      throw pl::Error("--odometry-out needs --poses lidar (with --poses gt no odometry runs)");
    const pl::Dataset ds = pl::open_dataset(s->dataset, s->topics);
    pl::StageProgress bars;
    maps::GloamObserver observer;
    observer.progress = [&](const std::string& stage, std::size_t done, std::size_t total) { bars.update(stage, done, total); };
    observer.log = [&](const std::string& line) {
      bars.finish();
      std::printf("%s\n", line.c_str());
    };
    const maps::GloamResult r = maps::build_gloam_map(ds, s->cfg, observer);
    bars.finish();
    std::fputs(maps::write_gloam_outputs(r, s->out, s->traj_out, s->report, s->odometry_out).c_str(), stdout);
    return 0;
  });
  maps::MapBuildConfig& merge = s->cfg.merge;
  pl::cli::dataset_option(c, s->dataset, s->topics, "the drive to build the map from");
  pl::cli::output_file(c, "--out", s->out, "where to write the map (PCD)")->required();
  pl::cli::choice(c, "--poses", s->poses, "gt: the dataset's ground truth; lidar: LiDAR odometry (without --gps started at the "
                  "first ground-truth pose when there is one)", {"gt", "lidar"});
  c.add_flag("--gps", s->cfg.gps, "(with --poses lidar) a pose graph of keyframes over the odometry with the drive's GPS fixes "
             "(robust to multipath) sets the poses; the ground truth is not used");
  c.add_flag("--loops", s->cfg.loops, "(with --poses lidar) loop closures found by position and by a place descriptor, verified "
             "by ICP, join the graph (re-solved on each)");
  pl::cli::output_file(c, "--traj-out", s->traj_out, "write the LiDAR pose of every scan, line for line with the dataset (KITTI; "
                       "TUM with the scan times when FILE ends in .tum)");
  pl::cli::output_file(c, "--odometry-out", s->odometry_out, "(with --poses lidar) write the LiDAR odometry's pose of every scan, "
                       "before --gps and --loops corrected them (moved as a whole to start where the graph put the first "
                       "scan), in the format of --traj-out: the drift and the correction from one run");
  pl::cli::output_file(c, "--report", s->report, "write JSON: keyframes, GPS edges and outliers, GPS residuals, loops proposed/"
                       "accepted/rejected (and why), the mean error against ground truth before and after the graph, times");
  pl::cli::choice(c, "--deskew", s->deskew, "correct each scan for the motion during the sweep, timed by azimuth (auto: the LiDAR "
                  "odometry's features for recordings without meta.json, and everything for drives with point_times/ "
                  "such as pl-sim's; the merged map of a KITTI raw drive only with on, as there it did not help)", {"auto", "on", "off"});
  pl::cli::number(c, "--voxel", merge.voxel_m, "voxel side of the map, metres", pl::cli::above(0));
  pl::cli::number(c, "--every", merge.every, "merge every N-th scan (the odometry still uses them all)", pl::cli::at_least(1));
  pl::cli::number(c, "--min-range", merge.scan.min_range_m, "returns closer than this are not merged, metres", pl::cli::at_least(0));
  pl::cli::number(c, "--max-range", merge.scan.max_range_m, "returns farther than this are not merged, metres", pl::cli::above(0));
}

void add_tile(Tool& tool) {
  struct State {
    std::string cloud, db, map, origin, places = "auto";
    maps::ImportConfig cfg;
  };
  auto s = std::make_shared<State>();
  CLI::App& c = tool.command("tile", "voxelize a cloud, estimate normals, cut it into tiles, Draco-encode them and write a new "
                             "staged version (the map is created on first use; unchanged tiles share their stored bytes)", [s] {
    maps::check_import_config(s->cfg);
    if (!s->origin.empty()) s->cfg.origin = pl::cli::geo_point(s->origin, "--origin");
    if (s->places == "auto") s->cfg.places = pl::file_exists(maps::places_path(s->cloud)) ? maps::places_path(s->cloud) : "";
    else if (s->places != "none") s->cfg.places = s->places;
    const pl::Cloud cloud = pl::read_cloud(s->cloud);
    std::unique_ptr<pl::Progress> bar;
    const maps::ImportResult r = maps::import_cloud(s->db, s->map, cloud, s->cloud, s->cfg, [&](std::size_t done, std::size_t total) {
      if (!bar) bar = std::make_unique<pl::Progress>("encoding tiles", total);
      bar->update(done);
    });
    if (bar) bar->finish();
    const auto number = static_cast<long long>(r.version.number);
    const std::string parent = r.version.parent ? "parent v" + std::to_string(*r.version.parent) : "no parent";
    std::printf("map %s version %lld staged (%s): %zu tiles (%zu new or changed, %zu unchanged, %zu removed), %zu points, %s\n",
                s->map.c_str(), number, parent.c_str(), r.tiles, r.changed, r.unchanged, r.removed, r.points,
                maps::megabytes(r.bytes).c_str());
    if (r.places > 0) std::printf("%zu places for relocalization from %s\n", r.places, s->cfg.places.c_str());
    else std::printf("no places: the localizer can start and relocalize only near a given pose (pl-map build writes them)\n");
    std::printf("publish it with: pl-map publish --db %s --map %s --version %lld\n", pl::store::display_name(s->db).c_str(),
                s->map.c_str(), number);
    return 0;
  });
  c.add_option("--cloud", s->cloud, "the cloud (.pcd, .ply or .bin), in the map's local ENU frame")->required()->type_name("FILE");
  db_option(c, s->db, true);
  c.add_option("--map", s->map, "the map's name (1 to 64 of A-Z a-z 0-9 _ . -)")->required()->type_name("NAME");
  pl::cli::geo_option(c, "--origin", s->origin, "the geodetic origin of the cloud's ENU frame (when the cloud does not record it)");
  pl::cli::number(c, "--voxel", s->cfg.voxel_m, "voxel side, metres", pl::cli::above(0));
  pl::cli::number(c, "--tile-size", s->cfg.tile_size_m, "tile side, metres", pl::cli::at_least(1));
  pl::cli::number(c, "--normal-radius", s->cfg.normal_radius_m, "neighbourhood of the normals, metres (default: 3 x --voxel)",
                  pl::cli::above(0))->default_str("");
  pl::cli::number(c, "--max-error", s->cfg.codec.max_error_m, "largest position error after decoding, metres",
                  pl::cli::above_up_to(0, 0.1));
  c.add_option("--note", s->cfg.note, "the version's note (default: \"tiled from CLOUD\")");
  c.add_option("--places", s->places, "the places stored with the version for relocalization: a .places FILE, none, or auto "
               "(the CLOUD's name with .places, as pl-map build writes it, when that file exists)")->type_name("FILE|none|auto");
}

// publish, rollback, list, info, diff: --db and --map of an existing store.
struct StoreArgs {
  std::string db, map, signing_key;
  std::int64_t version = 0, from = 0, to = 0;
  pl::store::Store open() const { return pl::store::Store::open(db, false); }
};

CLI::App& store_command(Tool& tool, const std::string& name, const std::string& help, std::shared_ptr<StoreArgs>& s,
                        std::function<int()> body, bool map_required = true) {
  CLI::App& c = tool.command(name, help, std::move(body));
  db_option(c, s->db, false);
  auto* map = c.add_option("--map", s->map, "the map's name")->type_name("NAME");
  if (map_required) map->required();
  return c;
}

void add_store_commands(Tool& tool) {
  auto s = std::make_shared<StoreArgs>();
  CLI::App& publish = store_command(tool, "publish", "make a staged version current (one transaction), signed with --signing-key", s, [s] {
    std::optional<pl::signing::SigningKey> key;
    if (!s->signing_key.empty()) key = pl::signing::SigningKey::load(s->signing_key);  // before anything is written
    auto store = s->open();
    maps::need_map(store, s->map);
    maps::publish_version(store, s->map, s->version, key ? &*key : nullptr);
    const std::string how = key ? ", signed by key " + pl::signing::key_id(key->public_key()) : std::string();
    std::printf("map %s: version %lld is current%s\n", s->map.c_str(), static_cast<long long>(s->version), how.c_str());
    return 0;
  });
  pl::cli::number(publish, "--version", s->version, "the staged version to publish", pl::cli::at_least(1))->required()->default_str("");
  publish.add_option("--signing-key", s->signing_key, "sign the version's manifest with this Ed25519 private key (PEM, pl-map key-gen) "
                     "as it is published; vehicles holding the public key use only signed versions")->type_name("FILE");
  CLI::App& rollback = store_command(tool, "rollback", "publish the previously published version's content again, as a new version "
                                     "(signed with --signing-key)", s, [s] {
    std::optional<pl::signing::SigningKey> key;
    if (!s->signing_key.empty()) key = pl::signing::SigningKey::load(s->signing_key);  // before anything is written
    auto store = s->open();
    maps::need_map(store, s->map);
    const auto v = maps::rollback_version(store, s->map, key ? &*key : nullptr);
    const auto info = store.find_version(s->map, v);
    const std::string how = key ? ", signed by key " + pl::signing::key_id(key->public_key()) : std::string();
    std::printf("map %s: rolled back, version %lld is current (the content of version %lld)%s\n", s->map.c_str(),
                static_cast<long long>(v), static_cast<long long>(info->parent.value_or(0)), how.c_str());
    return 0;
  });
  rollback.add_option("--signing-key", s->signing_key, "sign the new version's manifest with this Ed25519 private key (PEM, pl-map "
                      "key-gen); vehicles holding the public key use only signed versions")->type_name("FILE");
  store_command(tool, "list", "the maps, or the versions of one map", s, [s] {
    std::fputs((s->map.empty() ? maps::maps_text(s->open()) : maps::versions_text(s->open(), s->map)).c_str(), stdout);
    return 0;
  }, false);
  CLI::App& info = store_command(tool, "info", "a version's manifest", s, [s] {
    std::fputs(maps::version_text(s->open(), s->map, s->version).c_str(), stdout);
    return 0;
  });
  pl::cli::number(info, "--version", s->version, "the version", pl::cli::at_least(1))->default_str("the current one");
  CLI::App& diff = store_command(tool, "diff", "tiles added, removed and changed between two versions", s, [s] {
    std::fputs(maps::diff_versions(s->open(), s->map, s->from, s->to).text.c_str(), stdout);
    return 0;
  });
  pl::cli::number(diff, "--from", s->from, "the first version", pl::cli::at_least(1))->required()->default_str("");
  pl::cli::number(diff, "--to", s->to, "the second version", pl::cli::at_least(1))->required()->default_str("");
}

void add_push(Tool& tool) {
  auto o = std::make_shared<maps::PushOptions>();
  CLI::App& c = tool.command("push", "upload a local version to a server (only the tiles it lacks), then publish it there", [o] {
    const auto r = maps::push_version(*o);
    std::printf("pushed map %s v%lld to %s as v%lld: %zu tiles, %zu uploaded (%s), %zu already there, %zu deleted; published\n",
                o->map.c_str(), static_cast<long long>(o->version), o->server.c_str(), static_cast<long long>(r.remote_version),
                r.tiles, r.uploaded, maps::megabytes(static_cast<double>(r.bytes)).c_str(), r.skipped, r.deleted);
    return 0;
  });
  db_option(c, o->db, false);
  c.add_option("--map", o->map, "the map's name")->required()->type_name("NAME");
  pl::cli::number(c, "--version", o->version, "the local version to push", pl::cli::at_least(1))->required()->default_str("");
  c.add_option("--server", o->server, "the server, e.g. http://127.0.0.1:8080")->required()->type_name("URL");
  c.add_option("--token", o->token, "a token of the upload role (admin to create the map there)")->required();
  c.add_option("--ca-file", o->ca_file, "https: PEM file of the CA the server's certificate must chain to (default: the system's)")->type_name("FILE");
  c.add_flag("--insecure-http", o->insecure_http, "allow plain http:// to another machine (the token crosses the network in clear)");
  c.add_option("--signing-key", o->signing_key, "sign the version's manifest with this Ed25519 private key (PEM, pl-map key-gen): "
               "what the server holds is checked against the local version first")->type_name("FILE");
}

// The fleet's signing key: the private half signs versions as they are published (pl-map publish
// and push --signing-key), the public half goes to every vehicle (pl-localize --fleet-key) and to
// the servers that take uploads (pl-server --fleet-key).
void add_key_gen(Tool& tool) {
  auto out = std::make_shared<std::string>();
  CLI::App& c = tool.command("key-gen", "make an Ed25519 key pair for signing map versions: PREFIX.key (private, mode 0600) and PREFIX.pub", [out] {
    const auto key = pl::signing::SigningKey::generate();
    const std::string priv = *out + ".key", pub = *out + ".pub";
    if (pl::file_exists(priv) || pl::file_exists(pub))
      throw pl::Error(priv + " or " + pub + " exists already: a key is never written over (move the old pair away, or pick another --out)");
    key.save(priv);
    pl::signing::save_public_key(key.public_key(), pub);
    std::printf("key %s: private key %s (keep it where versions are published; never on a vehicle), public key %s "
                "(pl-localize --fleet-key, pl-server --fleet-key)\n",
                pl::signing::key_id(key.public_key()).c_str(), priv.c_str(), pub.c_str());
    return 0;
  });
  c.add_option("--out", *out, "the files' path without .key/.pub, e.g. /etc/pointlocalization/fleet")->required()->type_name("PREFIX");
}

}  // namespace

// Tokens: made here (random), stored hashed, revoked without restarting any server.
void add_token_commands(Tool& tool) {
  struct State {
    std::string db, role = "read", note;
    std::int64_t id = 0;
  };
  auto s = std::make_shared<State>();
  CLI::App& add = tool.command("token-add", "make a new bearer token and register it (the store keeps only its SHA-256)", [s] {
    auto store = pl::store::Store::open(s->db, false);
    const auto role = pl::store::parse_role(s->role);
    if (!role) throw pl::Error("--role " + s->role + ": expected read, report, upload or admin");
    const std::string token = pl::store::random_token();
    const auto id = store.add_token(token, *role, s->note);
    std::printf("%s\n", token.c_str());
    std::fprintf(stderr, "token %lld (%s) registered: keep it now, the store holds only its hash; revoke it with pl-map token-revoke --id %lld\n",
                 static_cast<long long>(id), s->role.c_str(), static_cast<long long>(id));
    return 0;
  });
  db_option(add, s->db, false);
  add.add_option("--role", s->role, "read, report (a vehicle's: reads maps, sends change reports), upload or admin (each "
                 "includes the ones before it)")->check(CLI::IsMember({"read", "report", "upload", "admin"}));
  add.add_option("--note", s->note, "what or who the token is for");
  CLI::App& list = tool.command("token-list", "the tokens: id, role, created, revoked, note (never a token)", [s] {
    auto store = pl::store::Store::open(s->db, false);
    std::printf("%-6s %-7s %-25s %-25s %s\n", "id", "role", "created", "revoked", "note");
    for (const auto& t : store.list_tokens())
      std::printf("%-6lld %-7s %-25s %-25s %s\n", static_cast<long long>(t.id), pl::store::role_name(t.role), t.created.c_str(),
                  t.revoked ? t.revoked->c_str() : "-", pl::printable(t.note).c_str());
    return 0;
  });
  db_option(list, s->db, false);
  CLI::App& revoke = tool.command("token-revoke", "take a token out of force, at once for every server on the store", [s] {
    auto store = pl::store::Store::open(s->db, false);
    if (!store.revoke_token(s->id))
      throw pl::Error("token " + std::to_string(s->id) + ": no such token, or revoked already (pl-map token-list --db " + pl::store::display_name(s->db) + ")");
    std::printf("token %lld revoked\n", static_cast<long long>(s->id));
    return 0;
  });
  db_option(revoke, s->db, false);
  pl::cli::number(revoke, "--id", s->id, "the token's id (pl-map token-list)", pl::cli::at_least(1))->required()->default_str("");
}

// migrate: the exact copy of a whole store into an empty one, between SQLite and PostgreSQL either
// way (pl/schema/store_copy.hpp). Never prints a URL's password (display_name).
void add_migrate(Tool& tool) {
  struct State {
    std::string from, to;
  };
  auto s = std::make_shared<State>();
  CLI::App& c = tool.command("migrate", "copy a whole store, exactly (ids, times, history, tokens, the upload log, change "
                             "reports), into an "
                             "empty one: SQLite to PostgreSQL, back, or within one engine; verified by a digest of both", [s] {
    pl::StageProgress bars;
    const auto r = pl::store::copy_store(s->from, s->to, [&](const std::string& stage, std::size_t done, std::size_t total) {
      bars.update(stage, done, total);
    });
    bars.finish();
    std::printf("copied %s to %s: %lld maps, %lld versions, %lld tiles, %lld blobs (%s), %lld places, %lld signatures, "
                "%lld tokens, %lld upload log entries, %lld change reports\n",
                pl::store::display_name(s->from).c_str(), pl::store::display_name(s->to).c_str(), static_cast<long long>(r.maps),
                static_cast<long long>(r.versions), static_cast<long long>(r.tiles), static_cast<long long>(r.blobs),
                maps::megabytes(static_cast<double>(r.blob_bytes)).c_str(), static_cast<long long>(r.places),
                static_cast<long long>(r.signatures), static_cast<long long>(r.tokens), static_cast<long long>(r.log_entries),
                static_cast<long long>(r.reports));
    std::printf("content digest %s: the same on both\n", r.digest.c_str());
    return 0;
  });
  auto exists = [](std::string& path) -> std::string {
    if (pl::store::is_postgres_url(path) || pl::file_exists(path)) return "";
    return path + ": no such map store";
  };
  auto creatable = [](std::string& path) -> std::string {
    if (pl::store::is_postgres_url(path) || pl::file_exists(path)) return "";
    return pl::output_file_problem(path);
  };
  c.add_option("--from", s->from, "the store to copy: a SQLite file or a postgresql://USER@HOST/DB URL")
      ->required()->type_name("FILE|URL")->check(CLI::Validator(exists, ""));
  c.add_option("--to", s->to, "the empty store to copy into: a SQLite file (created when missing) or the URL of an existing, "
               "empty PostgreSQL database")
      ->required()->type_name("FILE|URL")->check(CLI::Validator(creatable, ""));
}

// check: the whole store checked (as integrity_ok: the engine's own check, every rule the schema
// states, every blob against its hash) and its content digest, the one migrate prints, in one read
// of every blob (checked_digest): after an outage or a copy, whether anything was lost or damaged.
// Exit 1 when it is damaged.
void add_check(Tool& tool) {
  auto db = std::make_shared<std::string>();
  CLI::App& c = tool.command("check", "check a whole store (every rule of the schema, every blob against its hash) and print "
                             "its content digest (the one pl-map migrate prints)", [db] {
    auto store = pl::store::Store::open(*db, false);
    const auto maps = store.list_maps();
    std::size_t versions = 0;
    for (const auto& m : maps) versions += store.list_versions(m.name).size();
    const std::optional<std::string> digest = pl::store::checked_digest(*db);
    std::printf("%s: %zu maps, %zu versions, %s\n", store.path().c_str(), maps.size(), versions,
                digest ? "sound" : "DAMAGED: restore it from a backup, or rebuild it with pl-map");
    if (!digest) return 1;
    std::printf("content digest %s\n", digest->c_str());
    return 0;
  });
  db_option(c, *db, false);
}

std::vector<pl::schema::ChangeReport> read_reports(const std::vector<std::string>& paths) {
  std::vector<pl::schema::ChangeReport> reports;
  for (const std::string& path : paths) {
    std::ifstream f(path, std::ios::binary);
    if (!f) throw pl::Error(path + ": cannot read the change report");
    std::ostringstream text;
    text << f.rdbuf();
    try {
      reports.push_back(pl::schema::parse_change_report(text.str()));
    } catch (const pl::Error& e) {
      throw pl::Error(path + ": " + e.what());
    }
  }
  return reports;
}

void rule_options(CLI::App& c, maps::ChangeRule& rule) {
  pl::cli::number(c, "--min-drives", rule.min_drives, "independent passes that must agree on a voxel", pl::cli::between(1, 100));
  pl::cli::number(c, "--window", rule.window, "... among a tile's last this many passes", pl::cli::between(1, 1000));
  pl::cli::number(c, "--min-cells", rule.min_cells, "agreed voxels for a tile to be a candidate", pl::cli::at_least(1));
  pl::cli::number(c, "--independent-s", rule.independent_s, "drives of one vehicle starting closer than this are one pass, s",
                  pl::cli::at_least(0));
}

// A staged version from the change reports: only the candidate tiles rebuilt (pl/maps/map_update.hpp).
void add_update(Tool& tool) {
  struct Opts {
    std::string db, map, signing_key;
    std::vector<std::string> reports;
    bool publish = false;
    maps::MapUpdateConfig cfg;
  };
  auto o = std::make_shared<Opts>();
  CLI::App& c = tool.command("update", "stage a new version of a map from its change reports: only the tiles independent drives "
                             "agree changed are rebuilt (old points minus the removed, plus the added), every other tile keeps its "
                             "bytes (docs/map-updates.md)", [o] {
    std::optional<pl::signing::SigningKey> key;
    if (!o->signing_key.empty()) key = pl::signing::SigningKey::load(o->signing_key);  // before anything is written
    auto store = pl::store::Store::open(o->db, false);
    // The reports given, else those the store holds against the current version (sent by the
    // vehicles: POST /v1/maps/{map}/reports).
    std::vector<pl::schema::ChangeReport> reports = read_reports(o->reports);
    if (o->reports.empty()) {
      const auto m = maps::need_map(store, o->map);
      if (m.current) reports = maps::stored_reports(store, o->map, *m.current);
    }
    const maps::MapUpdateResult r = maps::update_map(store, o->map, reports, o->cfg);
    std::size_t candidates = 0;
    for (const auto& t : r.summary.tiles) candidates += t.candidate;
    std::printf("%zu reports, %zu independent passes against v%lld; %zu change candidates\n", r.summary.reports, r.summary.used,
                static_cast<long long>(r.parent), candidates);
    if (!r.version) {
      std::printf("nothing to update: no tile changed (v%lld stays current)\n", static_cast<long long>(r.parent));
      return 0;
    }
    for (const auto& t : r.tiles) std::printf("~ %d %d: %s\n", t.key.tx, t.key.ty, t.reason().c_str());
    const auto number = static_cast<long long>(r.version->number);
    std::printf("map %s version %lld staged (parent v%lld): %zu tiles rebuilt, %zu keep their bytes\n", o->map.c_str(), number,
                static_cast<long long>(r.parent), r.tiles.size(), r.unchanged);
    if (o->publish) {
      maps::publish_version(store, o->map, r.version->number, key ? &*key : nullptr);
      std::printf("map %s: version %lld is current\n", o->map.c_str(), number);
    }
    return 0;
  });
  db_option(c, o->db, false);
  c.add_option("--map", o->map, "the map's name")->required()->type_name("NAME");
  c.add_option("--reports", o->reports, "change reports (JSON, pl-localize --change-report) instead of those the store holds "
               "(sent to pl-server by the vehicles); those against other versions than the current one do not count")
      ->expected(1, -1)->type_name("FILE...")->check(CLI::ExistingFile);
  rule_options(c, o->cfg.rule);
  c.add_flag("--publish", o->publish, "publish the staged version at once");
  c.add_option("--signing-key", o->signing_key, "(with --publish) sign the version's manifest with this Ed25519 private key")
      ->type_name("FILE");
}

// Change candidates from change reports (pl-localize --change-report): which tiles independent
// drives agree changed (pl/maps/change_detect.hpp states the rule).
void add_changes(Tool& tool) {
  struct Opts {
    std::vector<std::string> reports;
    long long version = 0;
    std::string out;
    maps::ChangeRule rule;
  };
  auto o = std::make_shared<Opts>();
  CLI::App& c = tool.command("changes", "which tiles changed, from the change reports of several drives (pl-localize "
                             "--change-report): a tile is a candidate when independent drives agree (docs/map-updates.md)", [o] {
    const std::vector<pl::schema::ChangeReport> reports = read_reports(o->reports);
    long long version = o->version;
    if (version == 0)
      for (const auto& r : reports) version = std::max<long long>(version, r.version);
    const maps::ChangeSummary s = maps::detect_changes(reports, version, o->rule);
    std::size_t candidates = 0;
    for (const auto& t : s.tiles) candidates += t.candidate;
    std::printf("%zu reports, %zu independent passes against v%lld; %zu tiles seen, %zu change candidates "
                "(%d of the last %d passes agreeing on %zu voxels or more)\n",
                s.reports, s.used, version, s.tiles.size(), candidates, o->rule.min_drives, o->rule.window, o->rule.min_cells);
    if (!o->out.empty()) {
      std::ofstream f(o->out, std::ios::binary | std::ios::trunc);
      f << maps::change_summary_csv(s);
      if (!f.flush()) throw pl::Error(o->out + ": write failed");
    }
    return 0;
  });
  c.add_option("--reports", o->reports, "change reports (JSON)")->required()->expected(1, -1)->type_name("FILE...")
      ->check(CLI::ExistingFile);
  pl::cli::number(c, "--version", o->version, "the map version the reports were made against (default: the newest named)",
                  pl::cli::at_least(1))->default_str("");
  pl::cli::output_file(c, "--out", o->out, "the tiles as CSV: tx,ty,passes,agreed,added,removed,candidate,drives");
  rule_options(c, o->rule);
}

int main(int argc, char** argv) {
  Tool tool("pl-map", "Build maps from drives, cut them into Draco tiles in a versioned SQLite map store, publish them.");
  add_build(tool);
  add_tile(tool);
  add_store_commands(tool);
  add_token_commands(tool);
  add_push(tool);
  add_key_gen(tool);
  add_migrate(tool);
  add_check(tool);
  add_changes(tool);
  add_update(tool);
  return tool.main(argc, argv);
}
