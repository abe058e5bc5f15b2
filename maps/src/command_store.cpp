// pl-map's commands on a map store: publish, rollback, list, info and diff (catalog.hpp); push to a
// server (push.hpp); migrate, the exact copy of a store (store_copy.hpp); check, its integrity.
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <utility>

#include "command.hpp"
#include "pl/common/output_path.hpp"
#include "pl/common/progress.hpp"
#include "pl/common/text.hpp"
#include "pl/maps/catalog.hpp"
#include "pl/maps/push.hpp"
#include "pl/schema/signed_manifest.hpp"
#include "pl/schema/store.hpp"
#include "pl/schema/store_copy.hpp"

namespace pl::maps {

namespace {

// publish, rollback, list, info, diff: --db and --map of an existing store.
struct StoreArgs {
  std::string db, map, signing_key;
  std::int64_t version = 0, from = 0, to = 0;
  pl::store::Store open() const { return pl::store::Store::open(db, false); }
};

CLI::App& store_command(cli::Tool& tool, const std::string& name, const std::string& help, std::shared_ptr<StoreArgs>& s,
                        std::function<int()> body, bool map_required = true) {
  CLI::App& c = tool.command(name, help, std::move(body));
  db_option(c, s->db, false);
  auto* map = c.add_option("--map", s->map, "the map's name")->type_name("NAME");
  if (map_required) map->required();
  return c;
}

}  // namespace

void add_store_commands(cli::Tool& tool, std::ostream& out) {
  auto s = std::make_shared<StoreArgs>();
  CLI::App& publish = store_command(tool, "publish", "make a staged version current (one transaction), signed with --signing-key", s, [s, &out] {
    std::optional<pl::signing::SigningKey> key;
    if (!s->signing_key.empty()) key = pl::signing::SigningKey::load(s->signing_key);  // before anything is written
    auto store = s->open();
    need_map(store, s->map);
    publish_version(store, s->map, s->version, key ? &*key : nullptr);
    const std::string how = key ? ", signed by key " + pl::signing::key_id(key->public_key()) : std::string();
    out << format_text("map %s: version %lld is current%s\n", s->map.c_str(), static_cast<long long>(s->version), how.c_str());
    return 0;
  });
  cli::number(publish, "--version", s->version, "the staged version to publish", cli::at_least(1))->required()->default_str("");
  publish.add_option("--signing-key", s->signing_key, "sign the version's manifest with this Ed25519 private key (PEM, pl-map key-gen) "
                     "as it is published; vehicles holding the public key use only signed versions")->type_name("FILE");
  CLI::App& rollback = store_command(tool, "rollback", "publish the previously published version's content again, as a new version "
                                     "(signed with --signing-key)", s, [s, &out] {
    std::optional<pl::signing::SigningKey> key;
    if (!s->signing_key.empty()) key = pl::signing::SigningKey::load(s->signing_key);  // before anything is written
    auto store = s->open();
    need_map(store, s->map);
    const auto v = rollback_version(store, s->map, key ? &*key : nullptr);
    const auto info = store.find_version(s->map, v);
    const std::string how = key ? ", signed by key " + pl::signing::key_id(key->public_key()) : std::string();
    out << format_text("map %s: rolled back, version %lld is current (the content of version %lld)%s\n", s->map.c_str(),
          static_cast<long long>(v), static_cast<long long>(info->parent.value_or(0)), how.c_str());
    return 0;
  });
  rollback.add_option("--signing-key", s->signing_key, "sign the new version's manifest with this Ed25519 private key (PEM, pl-map "
                      "key-gen); vehicles holding the public key use only signed versions")->type_name("FILE");
  store_command(tool, "list", "the maps, or the versions of one map", s, [s, &out] {
    out << (s->map.empty() ? maps_text(s->open()) : versions_text(s->open(), s->map));
    return 0;
  }, false);
  CLI::App& info = store_command(tool, "info", "a version's manifest", s, [s, &out] {
    out << version_text(s->open(), s->map, s->version);
    return 0;
  });
  cli::number(info, "--version", s->version, "the version", cli::at_least(1))->default_str("the current one");
  CLI::App& diff = store_command(tool, "diff", "tiles added, removed and changed between two versions", s, [s, &out] {
    out << diff_versions(s->open(), s->map, s->from, s->to).text;
    return 0;
  });
  cli::number(diff, "--from", s->from, "the first version", cli::at_least(1))->required()->default_str("");
  cli::number(diff, "--to", s->to, "the second version", cli::at_least(1))->required()->default_str("");
}

void add_push(cli::Tool& tool, std::ostream& out) {
  auto o = std::make_shared<PushOptions>();
  CLI::App& c = tool.command("push", "upload a local version to a server (only the tiles it lacks), then publish it there", [o, &out] {
    const auto r = push_version(*o);
    out << format_text("pushed map %s v%lld to %s as v%lld: %zu tiles, %zu uploaded (%s), %zu already there, %zu deleted; published\n",
          o->map.c_str(), static_cast<long long>(o->version), o->server.c_str(), static_cast<long long>(r.remote_version),
          r.tiles, r.uploaded, megabytes(static_cast<double>(r.bytes)).c_str(), r.skipped, r.deleted);
    return 0;
  });
  db_option(c, o->db, false);
  c.add_option("--map", o->map, "the map's name")->required()->type_name("NAME");
  cli::number(c, "--version", o->version, "the local version to push", cli::at_least(1))->required()->default_str("");
  c.add_option("--server", o->server, "the server, e.g. http://127.0.0.1:8080")->required()->type_name("URL");
  c.add_option("--token", o->token, "a token of the upload role (admin to create the map there)")->required();
  c.add_option("--ca-file", o->ca_file, "https: PEM file of the CA the server's certificate must chain to (default: the system's)")->type_name("FILE");
  c.add_flag("--insecure-http", o->insecure_http, "allow plain http:// to another machine (the token crosses the network in clear)");
  c.add_option("--signing-key", o->signing_key, "sign the version's manifest with this Ed25519 private key (PEM, pl-map key-gen): "
               "what the server holds is checked against the local version first")->type_name("FILE");
}

// migrate: the exact copy of a whole store into an empty one, between SQLite and PostgreSQL either
// way (pl/schema/store_copy.hpp). Never prints a URL's password (display_name).
void add_migrate(cli::Tool& tool, std::ostream& out) {
  struct State {
    std::string from, to;
  };
  auto s = std::make_shared<State>();
  CLI::App& c = tool.command("migrate", "copy a whole store, exactly (ids, times, history, tokens, the upload log, change "
                             "reports), into an "
                             "empty one: SQLite to PostgreSQL, back, or within one engine; verified by a digest of both", [s, &out] {
    pl::StageProgress bars;
    const auto r = pl::store::copy_store(s->from, s->to, [&](const std::string& stage, std::size_t done, std::size_t total) {
      bars.update(stage, done, total);
    });
    bars.finish();
    out << format_text("copied %s to %s: %lld maps, %lld versions, %lld tiles, %lld blobs (%s), %lld places, %lld signatures, "
          "%lld tokens, %lld upload log entries, %lld change reports\n",
          pl::store::display_name(s->from).c_str(), pl::store::display_name(s->to).c_str(), static_cast<long long>(r.maps),
          static_cast<long long>(r.versions), static_cast<long long>(r.tiles), static_cast<long long>(r.blobs),
          megabytes(static_cast<double>(r.blob_bytes)).c_str(), static_cast<long long>(r.places),
          static_cast<long long>(r.signatures), static_cast<long long>(r.tokens), static_cast<long long>(r.log_entries),
          static_cast<long long>(r.reports));
    out << format_text("content digest %s: the same on both\n", r.digest.c_str());
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
void add_check(cli::Tool& tool, std::ostream& out) {
  auto db = std::make_shared<std::string>();
  CLI::App& c = tool.command("check", "check a whole store (every rule of the schema, every blob against its hash) and print "
                             "its content digest (the one pl-map migrate prints)", [db, &out] {
    auto store = pl::store::Store::open(*db, false);
    const auto maps = store.list_maps();
    std::size_t versions = 0;
    for (const auto& m : maps) versions += store.list_versions(m.name).size();
    const std::optional<std::string> digest = pl::store::checked_digest(*db);
    out << format_text("%s: %zu maps, %zu versions, %s\n", store.path().c_str(), maps.size(), versions,
          digest ? "sound" : "DAMAGED: restore it from a backup, or rebuild it with pl-map");
    if (!digest) return 1;
    out << format_text("content digest %s\n", digest->c_str());
    return 0;
  });
  db_option(c, *db, false);
}

}  // namespace pl::maps
