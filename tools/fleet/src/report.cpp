// The fleet's figures: latency summaries, cache answers by X-Cache, and the report as JSON (every
// figure, a row per vehicle) and as a few lines for people.
#include "report.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <initializer_list>
#include <nlohmann/json.hpp>
#include <utility>

namespace pl::fleet {

using json = nlohmann::json;

Latency summarize(std::vector<float> v) {
  Latency l;
  l.count = v.size();
  if (v.empty()) return l;
  std::sort(v.begin(), v.end());
  auto at = [&](double q) {  // nearest rank
    std::size_t i = static_cast<std::size_t>(std::ceil(q * static_cast<double>(v.size())));
    return static_cast<double>(v[std::min(v.size() - 1, i == 0 ? 0 : i - 1)]);
  };
  l.p50 = at(0.5);
  l.p90 = at(0.9);
  l.p99 = at(0.99);
  l.max = v.back();
  double sum = 0;
  for (float x : v) sum += x;
  l.mean = sum / static_cast<double>(v.size());
  return l;
}

void tally(CacheCounts& c, const std::string& value) {
  ++c.answers;
  if (value.empty()) return;
  ++c.with_header;
  std::string v = value;
  std::transform(v.begin(), v.end(), v.begin(), [](unsigned char ch) { return static_cast<char>(std::tolower(ch)); });
  ++c.values[v];
  if (v == "hit")
    ++c.hit;
  else if (v == "miss" || v == "expired")
    ++c.miss;
  else if (v == "pass" || v == "bypass")
    ++c.pass;
  else if (v == "stale" || v == "updating")
    ++c.stale;
  else
    ++c.other;
}

void merge(CacheCounts& into, const CacheCounts& c) {
  into.answers += c.answers;
  into.with_header += c.with_header;
  into.hit += c.hit;
  into.miss += c.miss;
  into.pass += c.pass;
  into.stale += c.stale;
  into.other += c.other;
  for (const auto& [k, n] : c.values) into.values[k] += n;
}

namespace {

json latency_json(const Latency& l) {
  return {{"count", l.count}, {"p50_ms", l.p50}, {"p90_ms", l.p90}, {"p99_ms", l.p99}, {"max_ms", l.max}, {"mean_ms", l.mean}};
}

json cache_json(const CacheCounts& c) {
  json j = {{"answers", c.answers}, {"with_header", c.with_header}, {"hit", c.hit},     {"miss", c.miss},
            {"pass", c.pass},       {"stale", c.stale},             {"other", c.other}, {"hit_ratio", c.hit_ratio()}};
  j["values"] = c.values;
  return j;
}

}  // namespace

std::string report_json(const FleetReport& r) {
  json j;
  j["server"] = r.server;
  j["map"] = r.map;
  j["version"] = r.version;
  j["tile_size"] = r.tile_size;
  j["map_tiles"] = r.map_tiles;
  j["extent"] = {r.extent[0], r.extent[1], r.extent[2], r.extent[3]};
  j["vehicles"] = r.vehicles;
  j["duration_s"] = r.duration_s;
  j["fleet_cpu_s"] = r.fleet_cpu_s;
  j["radius_m"] = r.radius_m;
  j["roi_radius_m"] = r.roi_radius_m;
  j["lookahead_s"] = r.lookahead_s;
  j["vehicles_ready"] = r.vehicles_ready;
  j["vehicles_driving"] = r.vehicles_driving;
  j["vehicles_stalled"] = r.vehicles_stalled;
  for (const auto& [k, v] : std::initializer_list<std::pair<const char*, std::size_t>>{
           {"scans", r.scans}, {"stalled_scans", r.stalled_scans}, {"missing_tiles", r.missing_tiles},
           {"tile_requests", r.tile_requests}, {"tiles", r.tiles}, {"tile_bytes", r.tile_bytes},
           {"roi_queries", r.roi_queries}, {"roi_with_have", r.roi_with_have}, {"manifest_requests", r.manifest_requests},
           {"bytes", r.bytes}, {"rejected", r.rejected}, {"failures", r.failures}, {"retries", r.retries}, {"evicted", r.evicted}})
    j[k] = v;
  j["failure_kinds"] = r.failure_kinds;
  j["tile_latency"] = latency_json(r.tile_latency);
  j["roi_latency"] = latency_json(r.roi_latency);
  j["cache"] = {{"tiles", cache_json(r.cache_tiles)}, {"roi", cache_json(r.cache_roi)}, {"manifests", cache_json(r.cache_manifests)}};
  json origins = json::array();
  for (const auto& oc : r.origins)
    origins.push_back({{"url", oc.url}, {"ok", oc.ok}, {"error", oc.error}, {"tiles", oc.tiles}, {"roi", oc.roi},
                       {"manifests", oc.manifests}, {"other", oc.other}, {"errors_5xx", oc.errors_5xx}});
  j["origin"] = {{"replicas", origins},       {"ok", r.origin_ok},
                 {"tiles", r.origin_tiles},    {"roi", r.origin_roi},
                 {"all", r.origin_all},        {"tile_share", r.origin_tile_share},
                 {"roi_share", r.origin_roi_share}};
  json rows = json::array();
  for (const auto& v : r.per_vehicle)
    rows.push_back({{"id", v.id},
                    {"speed", v.speed},
                    {"start_s", v.start_s},
                    {"ready_s", v.ready_s},
                    {"driving_s", v.driving_s},
                    {"distance_m", v.distance_m},
                    {"scans", v.scans},
                    {"stalled_scans", v.stalled_scans},
                    {"missing_tiles", v.missing_tiles},
                    {"tile_requests", v.tile_requests},
                    {"tiles", v.tiles},
                    {"tile_bytes", v.tile_bytes},
                    {"roi_queries", v.roi_queries},
                    {"roi_with_have", v.roi_with_have},
                    {"manifest_requests", v.manifest_requests},
                    {"bytes", v.bytes},
                    {"rejected", v.rejected},
                    {"failures", v.failures},
                    {"retries", v.retries},
                    {"evicted", v.evicted},
                    {"tile_latency", latency_json(v.tile_latency)},
                    {"roi_latency", latency_json(v.roi_latency)}});
  j["per_vehicle"] = rows;
  return j.dump(1) + "\n";
}

std::string report_text(const FleetReport& r) {
  char b[512];
  std::string s;
  auto line = [&](const char* fmt, auto... args) {
    std::snprintf(b, sizeof b, fmt, args...);
    s += b;
  };
  auto pct = [](double a, double n) { return n > 0 ? 100.0 * a / n : 0.0; };
  line("pl-fleet: %d vehicles for %.1f s on map %s version %lld (%zu tiles of %g m) via %s\n", r.vehicles, r.duration_s, r.map.c_str(),
       r.version, r.map_tiles, r.tile_size, r.server.c_str());
  line("  vehicles: %d ready, %d driving, %d stalled at least once; pl-fleet's own CPU: %.1f s (%.0f %% of one core)\n", r.vehicles_ready,
       r.vehicles_driving, r.vehicles_stalled, r.fleet_cpu_s, r.duration_s > 0 ? 100 * r.fleet_cpu_s / r.duration_s : 0.0);
  line("  scans: %zu, with stalls %zu (%.2f %%), missing tiles %zu\n", r.scans, r.stalled_scans, pct(r.stalled_scans, r.scans),
       r.missing_tiles);
  line("  tiles: %zu requests, %zu arrived (%.1f MB), rejected %zu, failures %zu, retries %zu\n", r.tile_requests, r.tiles,
       r.tile_bytes / 1e6, r.rejected, r.failures, r.retries);
  if (!r.failure_kinds.empty()) {
    std::string kinds;
    for (const auto& [k, n] : r.failure_kinds) kinds += (kinds.empty() ? "" : ", ") + k + " " + std::to_string(n);
    line("  failures by kind: %s\n", kinds.c_str());
  }
  line("  ROI queries: %zu (%zu with have=); manifests: %zu; all bodies %.1f MB\n", r.roi_queries, r.roi_with_have, r.manifest_requests,
       r.bytes / 1e6);
  line("  tile latency ms: p50 %.2f  p90 %.2f  p99 %.2f  max %.2f  (%zu)\n", r.tile_latency.p50, r.tile_latency.p90, r.tile_latency.p99,
       r.tile_latency.max, r.tile_latency.count);
  line("  ROI latency ms:  p50 %.2f  p90 %.2f  p99 %.2f  max %.2f  (%zu)\n", r.roi_latency.p50, r.roi_latency.p90, r.roi_latency.p99,
       r.roi_latency.max, r.roi_latency.count);
  auto cache = [&](const char* what, const CacheCounts& c) {
    if (!c.with_header)
      line("  cache %s: no X-Cache header (%zu answers)\n", what, c.answers);
    else
      line("  cache %s: hit %.1f %% of %zu (miss %zu, pass %zu, stale %zu, other %zu)\n", what, 100 * c.hit_ratio(), c.with_header, c.miss,
           c.pass, c.stale, c.other);
  };
  cache("tiles", r.cache_tiles);
  cache("ROI", r.cache_roi);
  if (!r.origins.empty()) {
    line("  origin: %.0f tile requests (%.2f %% of the vehicles'), %.0f ROI (%.2f %%), %.0f in all%s\n", r.origin_tiles,
         100 * r.origin_tile_share, r.origin_roi, 100 * r.origin_roi_share, r.origin_all, r.origin_ok ? "" : " (incomplete: see below)");
    for (const auto& oc : r.origins)
      if (!oc.ok) line("    %s: %s\n", oc.url.c_str(), oc.error.c_str());
  }
  return s;
}

}  // namespace pl::fleet
