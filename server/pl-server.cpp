// pl-server: serves the map store over HTTP (see schema/openapi.yaml).
#include <cstdio>
#include <thread>

#include "pl/common/cli.hpp"
#include "pl/common/error.hpp"
#include "pl/common/text.hpp"
#include "pl/schema/store.hpp"
#include "pl/server/server.hpp"

namespace {

const char* kUsage =
    "usage: pl-server --db FILE [--listen 127.0.0.1:8080] [--threads N] [--tokens FILE] [--read-token-required]\n"
    "                 [--cache-mb 256] [--quiet]\n"
    "\n"
    "Serves the maps of a pl-map store: manifests, Draco tiles, region-of-interest queries and map\n"
    "uploads (bearer tokens of the upload role), plus /healthz, /readyz and /metrics.\n"
    "  --listen HOST:PORT     address or host name to listen on (127.0.0.1:8080, localhost:8080,\n"
    "                         [::1]:8080, 0.0.0.0:8080); port 0 picks a free one (printed at start)\n"
    "  --threads N            worker threads (default: the cores)\n"
    "  --tokens FILE          lines of \"ROLE TOKEN\" (read, upload or admin) added to the store, hashed\n"
    "  --read-token-required  reading maps needs a token too\n"
    "  --cache-mb N           memory for tiles served often (default 256)\n"
    "  --quiet                no access log\n"
    "SIGTERM or SIGINT: stop accepting, finish the requests in flight (10 s at most), exit 0.\n";

int body(int argc, char** argv) {
  for (int i = 1; i < argc; ++i)
    if (std::string(argv[i]) == "--help" || std::string(argv[i]) == "-h") {
      std::fputs(kUsage, stdout);
      return 0;
    }
  pl::Args args(argc, argv, 1, {"--read-token-required", "--quiet"});
  pl::server::ServerConfig cfg;
  cfg.api.db = args.require("--db", "FILE (the map store written by pl-map)");
  std::string listen = args.get_or("--listen", "127.0.0.1:8080");
  cfg.threads = static_cast<int>(args.get_int("--threads", std::max(1u, std::thread::hardware_concurrency())));
  auto tokens = args.get("--tokens");
  cfg.api.read_token_required = args.has("--read-token-required");
  cfg.api.blob_cache_bytes = static_cast<std::size_t>(args.get_int("--cache-mb", 256)) << 20;
  cfg.access_log = !args.has("--quiet");
  args.finish();
  if (!args.positional().empty()) throw pl::Error("unexpected argument \"" + args.positional()[0] + "\" (see --help)");
  // HOST:PORT with HOST an IPv4 address, a name, or an IPv6 address in brackets ([::1]:8080).
  auto colon = listen.rfind(':');
  long long port = -1;
  std::string host = colon == std::string::npos ? "" : listen.substr(0, colon);
  if (host.size() >= 2 && host.front() == '[' && host.back() == ']') host = host.substr(1, host.size() - 2);
  else if (host.find(':') != std::string::npos) host.clear();  // an IPv6 address needs its brackets
  if (host.empty() || !pl::parse_int(listen.substr(colon + 1), port) || port < 0 || port > 65535)
    throw pl::Error("--listen takes HOST:PORT (127.0.0.1:8080, localhost:8080, [::1]:8080, 0.0.0.0:8080), got \"" + listen + "\"");
  cfg.host = host;
  cfg.port = static_cast<std::uint16_t>(port);
  if (cfg.threads < 1 || cfg.threads > 256) throw pl::Error("--threads takes 1 to 256");
  if (!pl::file_exists(cfg.api.db)) throw pl::Error(cfg.api.db + ": no such map store (create one with pl-map tile)");
  if (tokens) {
    auto store = pl::store::Store::open(cfg.api.db, false);
    pl::LineReader reader(*tokens);
    std::string line;
    std::size_t n = 0;
    while (reader.next(line)) {
      auto f = pl::split_fields(line, " \t\r");
      auto role = f.size() == 2 ? pl::store::parse_role(f[0]) : std::nullopt;
      if (!role) reader.fail("\"ROLE TOKEN\" with ROLE read, upload or admin", line);
      if (!store.check_token(std::string(f[1]))) store.add_token(std::string(f[1]), *role, "from " + *tokens);
      ++n;
    }
    std::fprintf(stderr, "pl-server: %zu tokens from %s\n", n, tokens->c_str());
  }
  pl::server::Server server(cfg);
  std::string where;
  for (const auto& a : server.addresses()) where += (where.empty() ? "" : ", ") + a;
  const bool v6 = cfg.host.find(':') != std::string::npos;
  std::printf("pl-server: listening on http://%s:%u (%s; %d threads, map store %s)\n", (v6 ? "[" + cfg.host + "]" : cfg.host).c_str(),
              server.port(), where.c_str(), cfg.threads, cfg.api.db.c_str());
  std::fflush(stdout);
  server.run();
  std::printf("pl-server: stopped\n");
  return 0;
}

}  // namespace

int main(int argc, char** argv) { return pl::run_cli("pl-server", body, argc, argv); }
