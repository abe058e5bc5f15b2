// The fleet: its options checked, the version's tiles read from the server, the origins scraped,
// the vehicles driven on one Asio io_context for duration_s, their figures summed. Its parts, each
// in its own header:
//   route.hpp               a vehicle's route over the street grid
//   vehicle.hpp             a vehicle: its clock and driving, what it asks next, its answers, its memory
//   vehicle_connection.hpp  its kept-alive connection, one request at a time
//   shared.hpp              what the vehicles share: settings, the version's tiles, progress counters
//   origin_metrics.hpp      each origin replica's /metrics, before and after
//   url.hpp                 the host, port and path of the URLs the fleet is given
//   report.hpp              latency summaries, cache tallies, the report as JSON and text
// What a vehicle asks for and what it accepts, the tile client's own code decides (client/src:
// make_plan, TileIndex, rows_of_answer, wire::parse_manifest / parse_roi / verified_manifest, Backoff);
// the fleet only moves the bytes, keeps the clock and counts.
#include "pl/fleet/fleet.hpp"

#include <sys/resource.h>

#include <algorithm>
#include <boost/asio.hpp>
#include <boost/asio/ssl.hpp>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <thread>
#include <utility>
#include <vector>

#include "origin_metrics.hpp"
#include "pl/client/tile_client.hpp"
#include "pl/client/vehicle_localizer.hpp"
#include "pl/common/error.hpp"
#include "pl/schema/api_rules.hpp"
#include "pl/schema/detail/tls_client.hpp"
#include "pl/schema/http_client.hpp"
#include "pl/schema/signed_manifest.hpp"
#include "report.hpp"
#include "shared.hpp"
#include "url.hpp"
#include "vehicle.hpp"
#include "wire.hpp"

namespace pl::fleet {

namespace net = boost::asio;
namespace beast = boost::beast;
using tcp = net::ip::tcp;
using json = nlohmann::json;
using client::CachedManifest;

namespace {

std::string num(double v) {
  char b[64];
  std::snprintf(b, sizeof b, "%g", v);
  return b;
}

}  // namespace

void FleetOptions::validate() const {
  auto need = [](bool ok, const std::string& what) {
    if (!ok) throw Error("fleet: " + what);
  };
  need(!server.empty(), "server is empty: give the URL of pl-server or of the cache in front of it (http://HOST:PORT)");
  const Url u = parse_url(server, "fleet: server");
  need(u.scheme == "http" || u.scheme == "https", "server " + server + ": write http://HOST:PORT or https://HOST:PORT");
  need(ca_file.empty() || u.scheme == "https", "ca_file goes with an https:// server");
  need(api::valid_map_name(map), "map must be a map name (1 to 64 of A-Z a-z 0-9 _ . -), got \"" + map + "\"");
  need(!version || *version >= 1, "version must be 1 or more (or empty for the map's current version)");
  need(vehicles >= 1 && vehicles <= 100000, "vehicles must be between 1 and 100000, got " + std::to_string(vehicles));
  need(std::isfinite(duration_s) && duration_s > 0, "duration_s must be a number of seconds > 0");
  need(std::isfinite(speed_min) && speed_min >= 0 && speed_min <= 100, "speed_min must be between 0 and 100 m/s, got " + num(speed_min));
  need(std::isfinite(speed_max) && speed_max >= 0 && speed_max <= 100, "speed_max must be between 0 and 100 m/s, got " + num(speed_max));
  need(speed_max >= speed_min, "speed_max " + num(speed_max) + " is below speed_min " + num(speed_min) + ": give speed_min <= speed_max");
  need(std::isfinite(ramp_s) && ramp_s >= 0, "ramp_s must be a number of seconds >= 0");
  need(std::isfinite(block_m) && block_m >= 1, "block_m must be a number of metres >= 1");
  need(threads >= 1 && threads <= 64, "threads must be between 1 and 64");
  need(std::isfinite(scan_hz) && scan_hz > 0 && scan_hz <= 100, "scan_hz must be above 0 and at most 100");
  need(radius_m == 0 || (radius_m > 0 && radius_m <= 4000), "radius_m must be between 0 and 4000 m (0: the vehicle's default)");
  need(roi_radius_m >= 0 && roi_radius_m <= 4000, "roi_radius_m must be between 0 and 4000 m (0: the localizer's default)");
  need(lookahead_s == -1 || (lookahead_s >= 0 && lookahead_s <= 60), "lookahead_s must be between 0 and 60 s (-1: the vehicle's default)");
  need(timeout_s >= 0 && std::isfinite(timeout_s), "timeout_s must be a number of seconds >= 0 (0: the tile client's default)");
  need(retry_min_s >= 0 && retry_max_s >= 0 && (retry_max_s == 0 || retry_max_s >= retry_min_s),
       "retry_min_s and retry_max_s: seconds, min <= max (0: the tile client's default)");
  need(start_wait_s == -1 || start_wait_s >= 0, "start_wait_s must be a number of seconds >= 0 (-1: the vehicle's default)");
  need(memory_mb >= 0 && std::isfinite(memory_mb), "memory_mb must be a number of MiB >= 0 (0: the tile client's default)");
  for (const auto& m : origin_metrics) {
    const Url mu = parse_url(m, "fleet: origin_metrics");
    need(mu.scheme == "http", "origin_metrics " + m + ": a replica's plain http:// address, e.g. http://127.0.0.1:8080/metrics");
  }
}

FleetReport run_fleet(const FleetOptions& options, const FleetObserver& observer) {
  options.validate();
  auto sh = std::make_unique<Shared>();
  FleetOptions& o = sh->o;
  o = options;
  // The vehicle's own settings where left to their defaults.
  {
    const client::TileClientConfig tc;
    const client::VehicleLocalizerConfig vc;
    if (o.roi_radius_m == 0) o.roi_radius_m = vc.localizer.roi_radius_m;
    if (o.radius_m == 0) o.radius_m = std::max(tc.radius_m, vc.localizer.roi_radius_m + 20.0);
    if (o.lookahead_s < 0) o.lookahead_s = vc.lookahead_s;
    if (o.start_wait_s < 0) o.start_wait_s = vc.start_wait_s;
    if (o.timeout_s == 0) o.timeout_s = tc.timeout_s;
    if (o.retry_min_s == 0) o.retry_min_s = tc.retry_min_s;
    if (o.retry_max_s == 0) o.retry_max_s = std::max(tc.retry_max_s, o.retry_min_s);
    if (o.memory_mb == 0) o.memory_mb = tc.memory_mb;
  }
  auto keys = [](const std::string& flag, const std::string& path) {
    try {
      return signing::load_public_keys(path);
    } catch (const Error& e) {
      throw Error(flag + ": " + e.what());
    }
  };
  if (!o.fleet_keys.empty()) sh->trusted = keys("--fleet-keys", o.fleet_keys);
  if (!o.timestamp_keys.empty()) {
    if (sh->trusted.empty()) throw Error("--timestamp-keys needs --fleet-keys: the versions a statement names current are used signed");
    sh->current_keys = keys("--timestamp-keys", o.timestamp_keys);
  }
  // Enough file descriptors for a connection per vehicle.
  rlimit lim{};
  if (getrlimit(RLIMIT_NOFILE, &lim) == 0) {
    const rlim_t want = static_cast<rlim_t>(o.vehicles) + 64;
    if (lim.rlim_cur < want) {
      if (lim.rlim_max != RLIM_INFINITY && lim.rlim_max < want)
        throw Error(std::to_string(o.vehicles) + " vehicles need " + std::to_string(want) + " open files, the limit is " +
                    std::to_string(lim.rlim_max) + ": raise it (ulimit -n) or run fewer vehicles");
      lim.rlim_cur = want;
      setrlimit(RLIMIT_NOFILE, &lim);
    }
  }

  // The version and its tiles: what the stalls are counted against.
  FleetReport rep;
  rep.server = o.server;
  rep.map = o.map;
  {
    api::HttpOptions ho;
    ho.timeout_s = std::max(o.timeout_s, 10.0);
    ho.insecure_http = true;
    ho.ca_file = o.ca_file;
    std::map<std::string, std::string> headers;
    if (!o.token.empty()) headers["Authorization"] = "Bearer " + o.token;
    api::HttpClient c(o.server, ho);
    api::HttpResponse r;
    try {
      r = c.get("/v1/maps/" + api::url_encode(o.map), headers);
    } catch (const std::exception& e) {
      throw Error("cannot reach " + o.server + " (" + e.what() + "): is pl-server (or the cache) running there?");
    }
    if (r.status != 200)
      throw Error(o.server + " answered HTTP " + std::to_string(r.status) + " for map " + o.map + " (" + client::wire::error_text(r.body) +
                  "): check --map (and --token)");
    CachedManifest m;
    try {
      m = client::wire::parse_manifest(r.body, o.map, o.version);
    } catch (const client::wire::WireError& e) {
      throw Error("the manifest of map " + o.map + " from " + o.server + ": " + e.what());
    }
    rep.version = m.version;
    rep.tile_size = sh->tile_size = m.tile_size;
    r = c.get("/v1/maps/" + api::url_encode(o.map) + "/versions/" + std::to_string(m.version) + "/tiles", headers);
    if (r.status != 200)
      throw Error(o.server + " answered HTTP " + std::to_string(r.status) + " for the tiles of map " + o.map + " version " +
                  std::to_string(m.version) + ": is that version published?");
    const json j = json::parse(r.body, nullptr, false);
    if (!j.is_object() || !j.contains("tiles") || !j["tiles"].is_array())
      throw Error("the tile list of map " + o.map + " from " + o.server + " is not what schema/openapi.yaml says");
    for (const auto& t : j["tiles"])
      sh->truth[TileKey{t.at("tx").get<std::int32_t>(), t.at("ty").get<std::int32_t>()}] = t.at("hash").get<std::string>();
    if (sh->truth.empty()) throw Error("map " + o.map + " version " + std::to_string(m.version) + " has no tiles: nothing to drive over");
    rep.map_tiles = sh->truth.size();
    int x0 = INT32_MAX, y0 = INT32_MAX, x1 = INT32_MIN, y1 = INT32_MIN;
    for (const auto& [k, h] : sh->truth) {
      x0 = std::min(x0, k.tx), y0 = std::min(y0, k.ty), x1 = std::max(x1, k.tx), y1 = std::max(y1, k.ty);
    }
    rep.extent[0] = x0 * m.tile_size, rep.extent[1] = y0 * m.tile_size;
    rep.extent[2] = (x1 + 1) * m.tile_size, rep.extent[3] = (y1 + 1) * m.tile_size;
    std::copy(rep.extent, rep.extent + 4, sh->extent);
  }
  rep.vehicles = o.vehicles;
  rep.radius_m = o.radius_m;
  rep.roi_radius_m = o.roi_radius_m;
  rep.lookahead_s = o.lookahead_s;

  std::vector<std::pair<std::string, std::optional<Counters>>> before;
  for (const auto& url : o.origin_metrics) {
    try {
      before.emplace_back(url, scrape(url, o));
    } catch (const std::exception& e) {
      throw Error("--origin-metrics " + url + ": " + e.what() + ": is that replica's /metrics reachable?");
    }
  }

  net::io_context ioc;
  {
    const Url u = parse_url(o.server, "server");
    tcp::resolver resolver(ioc);
    sh->endpoints = resolver.resolve(u.host, u.port);
    sh->host_header = u.host + ":" + u.port;
    sh->host = u.host;
    // As the tile client's HttpClient: TLS 1.2 at least, the chain checked here and the name per connection.
    if (u.scheme == "https") sh->tls.emplace(detail::tls_client_context(o.ca_file));
  }
  std::vector<std::shared_ptr<Vehicle>> fleet;
  fleet.reserve(static_cast<std::size_t>(o.vehicles));
  for (int i = 0; i < o.vehicles; ++i) fleet.push_back(std::make_shared<Vehicle>(ioc, *sh, i));
  sh->start = Clock::now() + std::chrono::milliseconds(50);
  sh->end = sh->start + dur(o.duration_s);
  for (auto& v : fleet) v->go();

  net::steady_timer progress(ioc);
  std::function<void(beast::error_code)> tick;
  if (observer) {
    tick = [&](beast::error_code ec) {
      if (ec) return;
      const auto now = Clock::now();
      FleetProgress p;
      p.elapsed_s = std::max(0.0, secs(now - sh->start));
      p.duration_s = o.duration_s;
      p.ready = sh->ready.load();
      p.driving = sh->driving.load();
      p.scans = sh->scans.load();
      p.stalled_scans = sh->stalled.load();
      p.tile_requests = sh->tile_requests.load();
      p.roi_queries = sh->roi_queries.load();
      p.failures = sh->failures.load();
      p.rejected = sh->rejected.load();
      observer(p);
      if (now < sh->end) {
        progress.expires_at(std::min(now + std::chrono::seconds(1), sh->end));
        progress.async_wait(tick);
      }
    };
    progress.expires_at(sh->start);
    progress.async_wait(tick);
  }
  auto cpu_now = [] {
    rusage u{};
    getrusage(RUSAGE_SELF, &u);
    return static_cast<double>(u.ru_utime.tv_sec + u.ru_stime.tv_sec) + 1e-6 * static_cast<double>(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
  };
  const double cpu0 = cpu_now();
  std::vector<std::thread> workers;
  for (int i = 1; i < o.threads; ++i) workers.emplace_back([&] { ioc.run(); });
  ioc.run();
  for (auto& w : workers) w.join();
  rep.duration_s = secs(Clock::now() - sh->start);
  rep.fleet_cpu_s = cpu_now() - cpu0;

  for (const auto& [url, b] : before) {
    try {
      rep.origins.push_back(origin_delta(url, *b, scrape(url, o)));
    } catch (const std::exception& e) {
      OriginCounts oc;
      oc.url = url;
      oc.error = std::string("not scraped after the run: ") + e.what();
      rep.origins.push_back(oc);
    }
  }

  std::vector<float> tile_ms, roi_ms;
  for (auto& v : fleet) {
    VehicleReport r = v->report();
    rep.scans += r.scans, rep.stalled_scans += r.stalled_scans, rep.missing_tiles += r.missing_tiles;
    rep.tile_requests += r.tile_requests, rep.tiles += r.tiles, rep.tile_bytes += r.tile_bytes, rep.roi_queries += r.roi_queries;
    rep.roi_with_have += r.roi_with_have, rep.manifest_requests += r.manifest_requests, rep.bytes += r.bytes;
    rep.rejected += r.rejected, rep.failures += r.failures, rep.retries += r.retries, rep.evicted += r.evicted;
    rep.vehicles_ready += r.ready_s >= 0;
    rep.vehicles_driving += r.driving_s >= 0;
    rep.vehicles_stalled += r.stalled_scans > 0;
    tile_ms.insert(tile_ms.end(), v->tile_ms().begin(), v->tile_ms().end());
    roi_ms.insert(roi_ms.end(), v->roi_ms().begin(), v->roi_ms().end());
    merge(rep.cache_tiles, v->cache().tiles);
    merge(rep.cache_roi, v->cache().roi);
    merge(rep.cache_manifests, v->cache().manifests);
    for (const auto& [k, n] : v->failure_kinds()) rep.failure_kinds[k] += n;
    rep.per_vehicle.push_back(std::move(r));
  }
  rep.tile_latency = summarize(std::move(tile_ms));
  rep.roi_latency = summarize(std::move(roi_ms));
  rep.origin_ok = !rep.origins.empty();
  for (const auto& oc : rep.origins) {
    rep.origin_ok = rep.origin_ok && oc.ok;
    rep.origin_tiles += oc.tiles;
    rep.origin_roi += oc.roi;
    rep.origin_all += oc.tiles + oc.roi + oc.manifests + oc.other;
  }
  rep.origin_tile_share = rep.tile_requests ? rep.origin_tiles / static_cast<double>(rep.tile_requests) : 0.0;
  rep.origin_roi_share = rep.roi_queries ? rep.origin_roi / static_cast<double>(rep.roi_queries) : 0.0;
  return rep;
}

}  // namespace pl::fleet
