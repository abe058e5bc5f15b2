// pl_fleet: a load generator of virtual vehicles against the map service. Each vehicle drives its
// own route over the map at its own speed and asks for tiles exactly as the tile client does
// (client/src/fetch_plan.hpp, tile_index.hpp, wire.hpp: ROI queries with have=, the wanted tiles
// nearest first, the look-ahead disc, the backoff after failures), one kept-alive HTTP/1.1
// connection per vehicle, every answer checked as the client checks it (tile bytes against their
// SHA-256, never decoded). At each 10 Hz scan it counts the tiles the localizer's ROI map needs and
// does not have yet (stalls). Real time: the point is real request timing. docs/pl-fleet.md says
// what each figure means.
#pragma once

#include <cstddef>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "pl/common/tile_key.hpp"

namespace pl::fleet {

struct FleetOptions {
  std::string server;                       // http://HOST:PORT or https://HOST:PORT: pl-server, the cache
                                            // tier in front of it, or the TLS site in front of that
  std::string ca_file;                      // https: PEM of the CA the server's certificate must chain to
                                            // (empty: the system's), as TileClientConfig::ca_file
  std::string map;                          // map name
  std::optional<long long> version;         // pinned version; default: the map's current version
  int vehicles = 20;                        // virtual vehicles
  double duration_s = 10;                   // wall time from the start of the run to its end
  double speed_min = 10, speed_max = 25;    // m/s; each vehicle's speed is drawn in [min, max]
  double ramp_s = 1;                        // vehicles start at times spread evenly at random over this
  unsigned long long seed = 1;              // routes, speeds, start times, backoff jitter
  double block_m = 100;                     // spacing of the street grid the routes follow
  int threads = 1;                          // I/O threads (each vehicle has its own connection)
  double scan_hz = 10;                      // scans a second (each one is checked for stalls)
  // The tile client's and localizer's settings, read from their config structs at run time when
  // left at 0 (lookahead_s: -1): radius = max(TileClientConfig::radius_m, LocalizerConfig::
  // roi_radius_m + 20) as VehicleLocalizer sets it; roi = LocalizerConfig::roi_radius_m (the disc
  // whose tiles a scan needs); lookahead = VehicleLocalizerConfig::lookahead_s; timeout and backoff
  // from TileClientConfig.
  double radius_m = 0, roi_radius_m = 0, lookahead_s = -1, timeout_s = 0, retry_min_s = 0, retry_max_s = 0;
  double start_wait_s = -1;                 // how long a vehicle waits for its start tiles (-1: VehicleLocalizerConfig's)
  double memory_mb = 0;                     // each vehicle's tile memory (0: TileClientConfig's), counted
                                            // as the client bounds it before decoding (40 B a point)
  std::string token;                        // bearer token for reads, when the server requires one
  std::string fleet_keys;                   // PEM of the fleet's public key(s): versions used only once
                                            // their signed manifest verifies (wire::verified_manifest)
  std::string timestamp_keys;               // PEM of the map service's timestamp key(s) (with fleet_keys):
                                            // the version a fresh signed statement names current
                                            // (GET /v1/maps/{map}/current, wire::verified_current)
  std::vector<std::string> origin_metrics;  // each replica's /metrics URL, scraped before and after
  bool record_fetches = false;              // keep every fetched tile (key, hash of the bytes, size) in
                                            // VehicleReport::fetched (for tests; not in the JSON)

  // Throws pl::Error naming the first field at fault and the fix ("fleet: speed_max 20 is below
  // speed_min 30: ..."); run_fleet calls it first.
  void validate() const;
};

// Percentiles of a set of latencies, milliseconds (all 0 when count is 0).
struct Latency {
  std::size_t count = 0;
  double p50 = 0, p90 = 0, p99 = 0, max = 0, mean = 0;
};

struct FetchedTile {
  TileKey key;
  std::string hash;  // SHA-256 of the bytes that arrived (equal to the hash asked for)
  std::size_t bytes = 0;
};

struct VehicleReport {
  int id = 0;
  double speed = 0;         // m/s
  double start_s = 0;       // when it began (after the run's start)
  double ready_s = -1;      // when its version and tile size were known (-1: never)
  double driving_s = -1;    // when its start tiles were all there and it drove off (-1: never;
                            // after start_wait_s it drives anyway, counting stalls)
  double distance_m = 0;    // driven
  std::size_t scans = 0;    // scans while driving
  std::size_t stalled_scans = 0;  // scans with at least one needed tile missing
  std::size_t missing_tiles = 0;  // needed tiles missing, summed over the scans
  std::size_t tile_requests = 0;  // blob (or by-key tile) GETs sent
  std::size_t tiles = 0;          // tiles that arrived and matched their hash
  std::size_t tile_bytes = 0;     // the bytes of those tiles
  std::size_t roi_queries = 0;    // ROI queries sent
  std::size_t roi_with_have = 0;  // of them, naming known tiles by hash (have=)
  std::size_t manifest_requests = 0;  // map manifests and signed manifests asked for
  std::size_t bytes = 0;          // every answer body received (tiles, ROI answers, manifests, errors)
  std::size_t rejected = 0;       // answers refused as the client's status().rejected counts them: tile
                                  // bytes not matching their hash, signed manifests that did not verify
  std::size_t failures = 0;       // requests that failed: no connection, timeout, error status, refused
  std::size_t retries = 0;        // requests sent while backing off after a failure
  std::size_t evicted = 0;        // tiles dropped to stay within memory_mb
  Latency tile_latency, roi_latency;
  std::vector<FetchedTile> fetched;  // with FleetOptions::record_fetches
};

// Answers by the cache's X-Cache header (none when the header is absent), per kind of request.
struct CacheCounts {
  std::size_t answers = 0;  // answered requests of the kind
  std::size_t with_header = 0, hit = 0, miss = 0, pass = 0, stale = 0, other = 0;
  std::map<std::string, std::size_t> values;  // each X-Cache value as sent, lower-cased
  double hit_ratio() const { return with_header ? static_cast<double>(hit) / static_cast<double>(with_header) : 0.0; }
};

// The increase of a replica's pl_requests_total over the run, by kind of route.
struct OriginCounts {
  std::string url;
  bool ok = false;           // scraped before and after, and no counter went down (a restart)
  std::string error;         // why not ok
  double tiles = 0;          // /v1/blobs/{hash} + /v1/maps/{map}/versions/{v}/tiles/{tx}/{ty}
  double roi = 0;            // /v1/maps/{map}/roi
  double manifests = 0;      // /v1/maps/{map} and /v1/maps/{map}/versions/{v}/manifest (signed manifests)
  double other = 0;          // every other route but /metrics, /healthz and /readyz
  double errors_5xx = 0;     // of all of them, answered 5xx
};

struct FleetReport {
  std::string server, map;
  long long version = 0;
  double tile_size = 0;
  std::size_t map_tiles = 0;  // tiles of the version
  double extent[4] = {0, 0, 0, 0};  // min x, min y, max x, max y of the version's tiles (m)
  int vehicles = 0;
  double duration_s = 0;      // measured wall time
  double fleet_cpu_s = 0;     // CPU time pl-fleet itself used while the vehicles drove (all threads)
  double radius_m = 0, roi_radius_m = 0, lookahead_s = 0;
  // Sums over the vehicles.
  std::size_t scans = 0, stalled_scans = 0, missing_tiles = 0, tile_requests = 0, tiles = 0, tile_bytes = 0, roi_queries = 0,
              roi_with_have = 0, manifest_requests = 0, bytes = 0, rejected = 0, failures = 0, retries = 0, evicted = 0;
  std::map<std::string, std::size_t> failure_kinds;  // failures by kind: "HTTP 503", "timeout", "Connection refused",
                                                      // "refused tile bytes", "refused manifest", "unreadable answer", ...
  int vehicles_ready = 0, vehicles_driving = 0, vehicles_stalled = 0;  // ... that stalled at least once
  Latency tile_latency, roi_latency;  // over every vehicle's answers
  CacheCounts cache_tiles, cache_roi, cache_manifests;
  std::vector<OriginCounts> origins;
  bool origin_ok = false;     // every replica's counts are usable
  double origin_tiles = 0, origin_roi = 0, origin_all = 0;
  double origin_tile_share = 0;  // origin_tiles / tile_requests
  double origin_roi_share = 0;   // origin_roi / roi_queries
  std::vector<VehicleReport> per_vehicle;
};

// What run_fleet says while it runs, about once a second.
struct FleetProgress {
  double elapsed_s = 0, duration_s = 0;
  int ready = 0, driving = 0;
  std::size_t scans = 0, stalled_scans = 0, tile_requests = 0, roi_queries = 0, failures = 0, rejected = 0;
};
using FleetObserver = std::function<void(const FleetProgress&)>;

// Runs the fleet: validates the options, reads the version's tile list from the server, scrapes the
// origins, drives every vehicle for duration_s, scrapes again. Throws pl::Error for bad options or
// a server that cannot be set up against (no map, unreachable); failures during the run are counted.
FleetReport run_fleet(const FleetOptions& options, const FleetObserver& observer = nullptr);

// The report as JSON (every figure, and a row per vehicle).
std::string report_json(const FleetReport& report);
// The report for people: a few lines.
std::string report_text(const FleetReport& report);

}  // namespace pl::fleet
