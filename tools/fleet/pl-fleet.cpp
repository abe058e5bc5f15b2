// pl-fleet: N virtual vehicles driving over a served map with the tile client's request pattern,
// measuring stalls, latencies, bytes, the cache's hits and the origin's requests. The fleet is
// pl_fleet (tools/fleet); this is the command line. docs/pl-fleet.md.
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include "pl/common/cli.hpp"
#include "pl/common/error.hpp"
#include "pl/common/progress.hpp"
#include "pl/fleet/fleet.hpp"

int main(int argc, char** argv) {
  pl::cli::Tool tool("pl-fleet", "Drives N virtual vehicles over a map served by pl-server (or the cache in front of it), each "
                     "asking for tiles as the vehicle's tile client does, and reports stalls, latencies, bytes, cache hits and "
                     "origin requests (docs/pl-fleet.md).");
  CLI::App& app = tool.app();
  pl::fleet::FleetOptions o;
  long long version = 0;
  std::string json_out;

  app.add_option("--server", o.server, "pl-server, the cache tier in front of it, or the TLS site: http://HOST:PORT or "
                 "https://HOST:PORT")->required()->type_name("URL");
  app.add_option("--ca-file", o.ca_file, "https: the CA the server's certificate must chain to (default: the system's)")
      ->check(CLI::ExistingFile)->type_name("FILE.pem");
  app.add_option("--map", o.map, "the map's name")->required()->type_name("NAME");
  pl::cli::number(app, "--map-version", version, "pin this version of the map; 0: its current one", pl::cli::at_least(0));
  pl::cli::number(app, "--vehicles", o.vehicles, "virtual vehicles, one connection each", pl::cli::between(1, 100000));
  pl::cli::number(app, "--duration", o.duration_s, "seconds of driving (wall time: requests go at real speed)", pl::cli::above(0));
  pl::cli::number(app, "--speed-min", o.speed_min, "slowest vehicle, m/s", pl::cli::between(0, 100));
  pl::cli::number(app, "--speed-max", o.speed_max, "fastest vehicle, m/s", pl::cli::between(0, 100));
  pl::cli::number(app, "--ramp", o.ramp_s, "vehicles start at random times over this many seconds", pl::cli::at_least(0));
  pl::cli::number(app, "--seed", o.seed, "routes, speeds and start times; same seed, same fleet", pl::cli::at_least(0));
  pl::cli::number(app, "--block", o.block_m, "street grid spacing of the routes, metres", pl::cli::at_least(1));
  pl::cli::number(app, "--threads", o.threads, "I/O threads", pl::cli::between(1, 64));
  pl::cli::number(app, "--scan-hz", o.scan_hz, "scans a second, each checked for stalls", pl::cli::above_up_to(0, 100));
  pl::cli::number(app, "--radius", o.radius_m, "tiles kept within this of the vehicle and of its look-ahead point; 0: as "
                  "VehicleLocalizer sets it (max of TileClientConfig::radius_m and the ROI radius + 20 m)", pl::cli::between(0, 4000));
  pl::cli::number(app, "--roi-radius", o.roi_radius_m, "the localizer's ROI map: the tiles a scan needs; 0: LocalizerConfig's",
                  pl::cli::between(0, 4000));
  pl::cli::number(app, "--lookahead", o.lookahead_s, "seconds ahead of the look-ahead point; -1: VehicleLocalizerConfig's",
                  pl::cli::between(-1, 60));
  pl::cli::number(app, "--start-wait", o.start_wait_s, "a vehicle waits this long for its start tiles before it drives anyway; "
                  "-1: VehicleLocalizerConfig's", pl::cli::at_least(-1));
  pl::cli::number(app, "--timeout", o.timeout_s, "per request, seconds; 0: TileClientConfig's", pl::cli::at_least(0));
  pl::cli::number(app, "--retry-min", o.retry_min_s, "first backoff after a failure, seconds; 0: TileClientConfig's", pl::cli::at_least(0));
  pl::cli::number(app, "--retry-max", o.retry_max_s, "longest backoff, seconds; 0: TileClientConfig's", pl::cli::at_least(0));
  pl::cli::number(app, "--memory", o.memory_mb, "each vehicle's tile memory, MiB; 0: TileClientConfig's", pl::cli::at_least(0));
  app.add_option("--token", o.token, "bearer token for reads, when the server requires one")->type_name("TOKEN");
  app.add_option("--fleet-keys", o.fleet_keys, "the fleet's public key(s) (pl-map key-gen): a version is used only once its signed "
                 "manifest verifies")->check(CLI::ExistingFile)->type_name("FILE.pub");
  app.add_option("--timestamp-keys", o.timestamp_keys, "the map service's timestamp public key(s) (pl-server --timestamp-key; with "
                 "--fleet-keys): the version used is the one a fresh signed statement names current")
      ->check(CLI::ExistingFile)->type_name("FILE.pub");
  app.add_option("--origin-metrics", o.origin_metrics, "a replica's /metrics URL (repeat per replica), scraped before and after: the "
                 "origin's share of the requests")->type_name("URL");
  pl::cli::output_file(app, "--json", json_out, "every figure and a row per vehicle, as JSON");

  tool.body([&] {
    if (version > 0) o.version = version;
    o.validate();
    const bool progress = pl::Progress::enabled();
    pl::fleet::FleetObserver observer;
    if (progress)
      observer = [](const pl::fleet::FleetProgress& p) {
        std::fprintf(stderr, "\r%5.1f/%.0f s  ready %d  driving %d  scans %zu  stalled %zu  tiles %zu  ROI %zu  failures %zu  rejected %zu ",
                     p.elapsed_s, p.duration_s, p.ready, p.driving, p.scans, p.stalled_scans, p.tile_requests, p.roi_queries,
                     p.failures, p.rejected);
        std::fflush(stderr);
      };
    const pl::fleet::FleetReport r = pl::fleet::run_fleet(o, observer);
    if (progress) std::fprintf(stderr, "\n");
    std::fputs(pl::fleet::report_text(r).c_str(), stdout);
    if (!json_out.empty()) {
      std::ofstream out(json_out);
      out << pl::fleet::report_json(r);
      if (!out) throw pl::Error("--json: cannot write " + json_out);
      std::printf("  figures: %s\n", json_out.c_str());
    }
    return 0;
  });
  return tool.main(argc, argv);
}
