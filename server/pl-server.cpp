// pl-server: serves the map store over HTTP (see schema/openapi.yaml). The service is pl_server;
// this is the command line.
#include <cstdio>
#include <ctime>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>

#include "pl/common/cli.hpp"
#include "pl/common/error.hpp"
#include "pl/common/text.hpp"
#include "pl/schema/signed_manifest.hpp"
#include "pl/schema/store.hpp"
#include "pl/server/server.hpp"

namespace {

bool log_json = false;

// A line of the server's own (not a request's): plain "pl-server: MSG", or with --log-json a JSON
// object with the time and level.
void say(FILE* out, const char* level, const std::string& msg) {
  if (log_json) {
    const std::time_t t = std::time(nullptr);
    char when[32];
    std::tm tm{};
    gmtime_r(&t, &tm);
    std::strftime(when, sizeof(when), "%Y-%m-%dT%H:%M:%SZ", &tm);
    std::fprintf(out, "%s\n",
                 nlohmann::json({{"time", when}, {"level", level}, {"msg", "pl-server: " + msg}})
                     .dump(-1, ' ', false, nlohmann::json::error_handler_t::replace)
                     .c_str());
  } else {
    std::fprintf(out, "pl-server: %s\n", msg.c_str());
  }
  std::fflush(out);
}

}  // namespace

int main(int argc, char** argv) {
  pl::cli::Tool tool("pl-server", "Serves the maps of a pl-map store: manifests, Draco tiles, region-of-interest queries and "
                     "map uploads (bearer tokens of the upload role), plus /healthz, /readyz and /metrics.");
  CLI::App& app = tool.app();
  pl::server::ServerConfig cfg;
  std::string listen = cfg.host + ":" + std::to_string(cfg.port), tokens;
  cfg.threads = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  std::size_t cache_mb = cfg.api.blob_cache_bytes >> 20;
  bool quiet = !cfg.access_log;
  app.add_option("--db", cfg.api.db, "the map store written by pl-map: a SQLite file or a postgresql://USER@HOST/DB URL")
      ->required()
      ->type_name("FILE|URL");
  app.add_option("--listen", listen, "address or host name to listen on (127.0.0.1:8080, localhost:8080, [::1]:8080, "
                 "0.0.0.0:8080); port 0 picks a free one (printed at start)")->type_name("HOST:PORT")->capture_default_str();
  pl::cli::number(app, "--threads", cfg.threads, "worker threads (default: the cores)", pl::cli::between(1, 256))->default_str("");
  app.add_option("--tokens", tokens, "lines of \"ROLE TOKEN\" (read, report, upload or admin) added to the store, hashed")->type_name("FILE");
  app.add_flag("--read-token-required", cfg.api.read_token_required, "reading maps needs a token too");
  app.add_flag("--plain-uploads", cfg.api.plain_uploads,
               "take uploads over plain HTTP from other machines too (a TLS proxy on another machine forwards them); default: only from this machine");
  pl::cli::number(app, "--upload-rate", cfg.api.upload_rate, "uploads a second each token may send on average (429 beyond; 0: no limit)",
                  pl::cli::between(0, 1e9));
  pl::cli::number(app, "--upload-burst", cfg.api.upload_burst, "... and at once", pl::cli::between(1, 1e9));
  std::vector<std::string> fleet_key_files;
  app.add_option("--fleet-key", fleet_key_files, "a PEM file of the fleet's Ed25519 public keys (pl-map key-gen), repeatable: "
                 "publishes must then be signed by one of these keys (pl-map push, with the private key)")->type_name("FILE");
  std::string timestamp_key_file;
  app.add_option("--timestamp-key", timestamp_key_file, "an Ed25519 private key (pl-map key-gen; every replica the same): GET "
                 "/v1/maps/{map}/current then answers the map's current version signed with it, so that vehicles given its public key "
                 "tell a fresh answer from one a cache or the network holds back")->type_name("FILE");
  pl::cli::number(app, "--timestamp-lifetime", cfg.api.timestamp_lifetime_s, "seconds a signed current version stays valid: how long a "
                  "held-back answer can hide a newer version", pl::cli::between(10, 86400));
  pl::cli::number(app, "--cache-mb", cache_mb, "memory for tiles served often, MB", pl::cli::between(0, 1 << 20));
  app.add_option("--viewer-dir", cfg.api.viewer_dir, "the map viewer's files, served at /viewer/ (default: the installed viewer "
                 "beside this binary, else the build's, " + pl::server::default_viewer_dir() + ")")->type_name("DIR");
  pl::cli::number(app, "--event-streams", cfg.api.max_event_streams, "event streams (GET /v1/maps/{map}/events) open at once, 503 beyond",
                  pl::cli::between(1, 100000));
  pl::cli::number(app, "--vehicles", cfg.api.max_vehicles, "live vehicles kept (POST /v1/maps/{map}/vehicles/{id}), 503 for a new one beyond",
                  pl::cli::between(1, 1000000));
  pl::cli::number(app, "--vehicle-timeout", cfg.api.vehicle_timeout_s, "seconds a vehicle stays listed after its last report",
                  pl::cli::between(1, 86400));
  app.add_flag("--quiet", quiet, "no access log");
  app.add_flag("--log-json", cfg.api.log_json, "log as JSON lines (time, level, msg, request_id, ...) for a log collector");
  app.set_config("--config", "", "a file of these options, one NAME = VALUE a line (TOML: db = \"/var/lib/pl/maps.sqlite\", "
                 "threads = 4, quiet = true); options given on the command line win")
      ->type_name("FILE");
  app.footer("SIGTERM or SIGINT: stop accepting, finish the requests in flight (10 s at most), exit 0.");

  tool.body([&] {
    log_json = cfg.api.log_json;
    pl::server::parse_listen(listen, cfg);
    cfg.api.blob_cache_bytes = cache_mb << 20;
    for (const auto& f : fleet_key_files)
      for (auto& k : pl::signing::load_public_keys(f)) cfg.api.fleet_keys.push_back(std::move(k));
    if (!timestamp_key_file.empty())
      cfg.api.timestamp_key = std::make_shared<const pl::signing::SigningKey>(pl::signing::SigningKey::load(timestamp_key_file));
    cfg.access_log = !quiet;
    if (!pl::store::is_postgres_url(cfg.api.db) && !pl::file_exists(cfg.api.db)) throw pl::Error(cfg.api.db + ": no such map store (create one with pl-map tile)");
    if (!tokens.empty()) {
      auto store = pl::store::Store::open(cfg.api.db, false);
      const std::size_t n = pl::store::add_token_file(store, tokens, [&](std::size_t line) {
        say(stderr, "warning", tokens + " line " + std::to_string(line) +
                                   ": this token was revoked (pl-map token-list): not in force; remove it from the file");
      });
      say(stderr, "info", std::to_string(n) + " tokens from " + tokens);
    }
    if (!cfg.api.viewer_dir.empty() && !pl::file_exists(cfg.api.viewer_dir + "/index.html"))
      throw pl::Error("--viewer-dir " + cfg.api.viewer_dir + ": no index.html there (give the folder the build assembles, BUILD_DIR/viewer, "
                      "or the installed PREFIX/share/pointlocalization/viewer)");
    pl::server::Server server(cfg);
    std::string where;
    for (const auto& a : server.addresses()) where += (where.empty() ? "" : ", ") + a;
    const bool v6 = cfg.host.find(':') != std::string::npos;
    const std::string url = "http://" + (v6 ? "[" + cfg.host + "]" : cfg.host) + ":" + std::to_string(server.port());
    say(stdout, "info", "listening on " + url + " (" + where + "; " + std::to_string(cfg.threads) + " threads, map store " +
                            pl::store::display_name(cfg.api.db) + ")");
    const std::string viewer = cfg.api.viewer_dir.empty() ? pl::server::default_viewer_dir() : cfg.api.viewer_dir;
    if (pl::file_exists(viewer + "/index.html"))
      say(stdout, "info", "map viewer at " + url + "/viewer/ (files in " + viewer + ")");
    else
      say(stderr, "warning", "no map viewer: " + (viewer.empty() ? std::string("this build has none") : viewer + " holds no index.html") +
                                 " (build it: cmake --build BUILD_DIR --target viewer; or give --viewer-dir)");
    std::fflush(stdout);
    server.run();
    say(stdout, "info", "stopped");
    return 0;
  });
  return tool.main(argc, argv);
}
