#include "tile_server.hpp"

#include <chrono>

#include <exception>
#include <utility>

#include "client_text.hpp"
#include "pl/common/error.hpp"
#include "pl/schema/api_rules.hpp"
#include "wire.hpp"

namespace pl::client {

namespace {
api::HttpOptions http_options(const TileClientConfig& cfg, double timeout_s) {
  api::HttpOptions o;
  o.timeout_s = timeout_s;
  o.ca_file = cfg.ca_file;
  o.insecure_http = cfg.insecure_http;
  return o;
}
}  // namespace

TileServer::TileServer(const TileClientConfig& cfg, ClientStatus& status)
    : cfg_(cfg), status_(status), http_(cfg.server, http_options(cfg, cfg.timeout_s)), backoff_(cfg.retry_min_s, cfg.retry_max_s) {
  if (!cfg_.token.empty()) headers_["Authorization"] = "Bearer " + cfg_.token;
}

[[noreturn]] void TileServer::failed(const std::string& message) {
  double wait = backoff_.failed();
  status_.request_failed(message + " (retrying in " + seconds(wait) + ")");
  throw RequestFailed{};
}

[[noreturn]] void TileServer::refused(Refused what, const std::string& message, Backoff* own, bool other_url_next) {
  last_rejected_ = true;
  status_.refused(what, message);
  if (other_url_next) {  // altered on the way, not the server failing: the other URL is asked at once
    if (!own) status_.request_failed(message + " (asking again by another URL now)");
    throw RequestFailed{};
  }
  if (!own) failed(message);
  own->failed();
  throw RequestFailed{};
}

void TileServer::succeeded() {
  backoff_.succeeded();
  status_.request_succeeded();
}

// GET on the kept-alive connection; returns 200 answers, counts and throws on anything else.
// `about` says what was asked ("the manifest of map town"); `hint_404` what a 404 means to fix.
api::HttpResponse TileServer::get(const std::string& target, const std::string& about, const std::function<std::string()>& hint_404) {
  last_rejected_ = false;
  if (backoff_.backing_off()) status_.request_retried();
  api::HttpResponse res;
  try {
    res = http_.get(target, headers_);
  } catch (const std::exception& e) {
    last_status_ = 0;
    failed("cannot reach pl-server for " + about + " (" + e.what() +
           "): is it running and reachable? (the tiles in memory and in the disk cache serve meanwhile)");
  }
  last_status_ = res.status;
  if (res.status == 200) {
    succeeded();
    return res;
  }
  const std::string said = wire::error_text(res.body);
  std::string what = about + ": " + cfg_.server + " answered HTTP " + std::to_string(res.status) + (said.empty() ? "" : " \"" + said + "\"");
  if (res.status == 401) what += ": set TileClientConfig::token to a token with the read role";
  if (res.status == 403) what += ": the token needs the read role";
  if (res.status == 404 && hint_404) what += ": " + hint_404();
  if (res.status >= 500) what += ": the server is failing or shutting down";
  failed(what);
}

std::string TileServer::pinned_hint(long long version) const {
  return "is version " + std::to_string(version) + " of map " + cfg_.map + " published on this server? Pin one that is";
}

// On a 404 for a map: the maps the server has (one more request), so that a typo names its fix.
std::string TileServer::maps_on_server() {
  try {
    const api::HttpResponse res = http_.get("/v1/maps", headers_);
    if (res.status != 200) return "check the map's name";
    const std::vector<std::string> names = wire::parse_map_names(res.body);
    if (names.empty()) return "the server has no maps yet (pl-map push, or pl-map tile into its store)";
    std::string list;
    for (const auto& n : names) list += (list.empty() ? "" : ", ") + n;
    return "the server has " + std::string(names.size() == 1 ? "map " : "maps ") + list;
  } catch (const std::exception&) {
    return "check the map's name";
  }
}

CachedManifest TileServer::manifest(std::optional<long long> pin) {
  std::string about = "the manifest of map " + cfg_.map;
  api::HttpResponse res = get("/v1/maps/" + api::url_encode(cfg_.map), about, [this] { return maps_on_server(); });
  try {
    CachedManifest m = wire::parse_manifest(res.body, cfg_.map, pin);
    status_.extent(wire::parse_manifest_extent(res.body, m.version));
    return m;
  } catch (const wire::WireError& e) {
    failed(about + ": " + e.what() + " (see the manifest in schema/openapi.yaml)");
  }
}

std::pair<signing::SignedManifest, std::string> TileServer::signed_manifest(long long version, const std::vector<std::string>& trusted) {
  const std::string about = "the signed manifest of map " + cfg_.map + " version " + std::to_string(version);
  api::HttpResponse res = get(wire::signed_manifest_target(cfg_.map, version, manifest_refusals_), about, [&] { return pinned_hint(version); });
  try {
    auto verified = wire::verified_manifest(res.body, trusted, cfg_.map, version);
    return {std::move(verified), std::move(res.body)};
  } catch (const wire::WireError& e) {
    ++manifest_refusals_;
    refused(Refused::manifest, about + " refused: " + e.what() + "; not using the version, keeping the tiles in use", nullptr,
            manifest_refusals_ == 1);
  }
}

long long TileServer::current(const std::vector<std::string>& trusted, Backoff* own) {
  const std::string about = "the current version of map " + cfg_.map;
  api::HttpResponse res = get(wire::current_target(cfg_.map, current_refusals_), about,
                              [] { return "does the map exist, with a published version, on a server started with --timestamp-key?"; });
  const std::int64_t now = signing::unix_now();
  try {
    const signing::CurrentVersion c = wire::verified_current(res.body, trusted, cfg_.map, now);
    status_.current_confirmed(c.version, c.expires);
    if (own) own->succeeded();
    return c.version;
  } catch (const wire::WireError& e) {
    ++current_refusals_;
    refused(Refused::current, about + " refused: " + e.what() + "; starting only on the newest version this vehicle has verified", own,
            current_refusals_ == 1);
  }
}

std::vector<CachedTile> TileServer::roi(const RoiQuery& q, long long version, double tile_size) {
  std::string about = "the tiles of map " + cfg_.map + " version " + std::to_string(version) + " around (" + number(q.disc.center.x()) +
                      ", " + number(q.disc.center.y()) + ")";
  std::string target = "/v1/maps/" + api::url_encode(cfg_.map) + "/roi?x=" + number(q.disc.center.x()) + "&y=" + number(q.disc.center.y()) +
                       "&radius=" + number(q.disc.radius) + "&version=" + std::to_string(version);
  if (!q.have.empty()) {
    target += "&have=";
    for (std::size_t i = 0; i < q.have.size(); ++i) target += (i ? "," : "") + q.have[i];
  }
  api::HttpResponse res = get(target, about, [&] { return pinned_hint(version); });
  try {
    return wire::parse_roi(res.body, version, tile_size);
  } catch (const wire::WireError& e) {
    failed(about + ": " + e.what() + " (see the ROI answer in schema/openapi.yaml)");
  }
}

TileServer::Blob TileServer::blob(const CachedTile& t, long long version, bool by_key) {
  std::string about = "tile " + key_name(t.key) + " (" + t.hash + ")";
  const std::string target = by_key ? "/v1/maps/" + api::url_encode(cfg_.map) + "/versions/" + std::to_string(version) + "/tiles/" +
                                          std::to_string(t.key.tx) + "/" + std::to_string(t.key.ty)
                                    : "/v1/blobs/" + t.hash;
  api::HttpResponse res = get(target, about, [&] {
    return "the key rows cached for map " + cfg_.map + " version " + std::to_string(version) +
           " are stale (was the map store rebuilt?); asking the server again";
  });
  // The bytes are checked against the hash before anything else looks at them, then decoded.
  try {
    TileCloud cloud = wire::verified_tile(res.body, t.hash);
    return Blob{std::move(res.body), std::move(cloud)};
  } catch (const wire::WireError& e) {
    refused(Refused::tile, about + " refused: " + e.what() + "; never used" + (by_key ? ", left for a while" : ", asking for it by its key next"),
            nullptr, !by_key);
  } catch (const Error& e) {
    throw UndecodableTile(e.what());
  }
}

std::optional<std::string> fetch_places(const TileClientConfig& cfg, long long version, double timeout_s) {
  const std::string about = "the places of map " + cfg.map + " version " + std::to_string(version);
  std::map<std::string, std::string> headers;
  if (!cfg.token.empty()) headers["Authorization"] = "Bearer " + cfg.token;
  api::HttpResponse res;
  try {
    api::HttpOptions o = http_options(cfg, timeout_s);
    o.max_body_bytes = api::kMaxPlacesBytes;
    api::HttpClient http(cfg.server, o);
    res = http.get("/v1/maps/" + api::url_encode(cfg.map) + "/versions/" + std::to_string(version) + "/places", headers);
  } catch (const std::exception& e) {
    throw Error("cannot reach pl-server for " + about + " within " + seconds(timeout_s) + " (" + e.what() +
                "): is it running and reachable? Ask again with a longer timeout");
  }
  if (res.status == 404) return std::nullopt;
  if (res.status != 200) {
    const std::string said = wire::error_text(res.body);
    std::string what = about + ": " + cfg.server + " answered HTTP " + std::to_string(res.status) + (said.empty() ? "" : " \"" + said + "\"");
    if (res.status == 401) what += ": set TileClientConfig::token to a token with the read role";
    if (res.status == 403) what += ": the token needs the read role";
    if (res.status >= 500) what += ": the server is failing or shutting down";
    throw Error(what);
  }
  try {
    wire::check_places(res.body, res.header("etag"));
  } catch (const wire::WireError& e) {
    throw Error(about + ": " + e.what());
  }
  return std::move(res.body);
}

}  // namespace pl::client
