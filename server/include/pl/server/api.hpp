// The HTTP API of pl-server (schema/openapi.yaml), independent of the network layer: a request in,
// a response out. Thread-safe: each thread uses its own connection to the map store.
#pragma once

#include <atomic>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <string_view>
#include <vector>

#include "pl/common/tile_key.hpp"

namespace pl::signing {
class SigningKey;
}

namespace pl::server {

// The check of an uploaded tile (PUT .../tiles/{tx}/{ty}): the bytes decode (within decode_tile's
// limits), hold at least one point, and every point lies in the key's square of a grid of
// `tile_size` metres (1 cm of slack for quantization). Throws pl::Error saying what is wrong.
struct TileUpload {
  std::size_t points = 0;
  double min[3] = {0, 0, 0}, max[3] = {0, 0, 0};  // the points' box, ENU metres
};
TileUpload check_tile_upload(std::string_view bytes, double tile_size, const TileKey& key);

struct ApiConfig {
  std::string db;
  // Logs as JSON lines (one object a line: time, level, msg, request_id, ...) for a log collector;
  // else the plain lines below.
  bool log_json = false;
  bool read_token_required = false;
  std::size_t blob_cache_bytes = 256u << 20;  // immutable tiles and places kept in memory, by content hash
  // pl-server speaks plain HTTP (TLS ends in a proxy: deploy/nginx): requests that need the report,
  // upload or admin role (writes) are refused unless they come from this machine (the proxy's side),
  // or this says a TLS proxy on another machine forwards them.
  bool plain_uploads = false;
  // Requests that need the report, upload or admin role, per token: this many a second on average, bursts
  // of upload_burst (429 with Retry-After beyond). 0: no limit.
  double upload_rate = 200, upload_burst = 400;
  // The fleet's Ed25519 public keys (32 bytes each; pl-server --fleet-key). When any is given, a
  // publish must carry a signature of the version's manifest by one of them; without, an unsigned
  // publish is taken and a signed one needs only a signature that verifies.
  std::vector<std::string> fleet_keys;
  // The timestamp key (pl-server --timestamp-key, an Ed25519 private key the servers hold): with it,
  // GET /v1/maps/{map}/current answers the map's current version signed with it at each request,
  // expiring timestamp_lifetime_s later (pl/schema/signed_current.hpp). Unset: that route is 404.
  std::shared_ptr<const signing::SigningKey> timestamp_key;
  std::int64_t timestamp_lifetime_s = 300;
  // The map viewer (server/src/viewer.cpp): its static files' folder (empty: default_viewer_dir()),
  // how many Server-Sent Events streams may be open at once (503 beyond), and the live vehicles kept
  // in memory: at most max_vehicles, each dropped vehicle_timeout_s after its last report.
  std::string viewer_dir;
  std::size_t max_event_streams = 64;
  std::size_t max_vehicles = 1000;
  double vehicle_timeout_s = 60;
};

// The viewer's folder when none is given: the installed one beside the binary
// (PREFIX/share/pointlocalization/viewer), else the build tree's (BUILD/viewer).
std::string default_viewer_dir();

class EventStream;  // a Server-Sent Events stream (server/src/viewer.hpp)

struct ApiRequest {
  std::string method;
  std::string target;  // path and query
  std::string body;
  std::string authorization;
  std::string if_none_match;
  std::string accept_encoding;
  std::string content_encoding;  // of the body ("gzip" is taken where a route says so)
  std::string request_id;  // the server's id of the request, for the log of an internal error
  bool from_loopback = true;  // the peer's address is this machine's (Server sets it from the socket)
};

struct ApiResponse {
  int status = 200;
  std::string body;
  std::shared_ptr<const std::string> blob;  // when set, the body: tile or places bytes shared with the cache, not copied
  std::string blob_hash;                     // their content hash
  std::string content_type = "application/json";
  std::vector<std::pair<std::string, std::string>> headers;
  std::string route;  // the route template, for metrics ("/v1/maps/{map}/roi")
  // Set by the handlers of answers that change as maps are published (the map list, a map's
  // manifest, ROI answers, a version's tile list): an HTTP cache in front may keep one for a second,
  // then revalidate it by its weak ETag. `etag` is that tag when the handler knows what determines
  // the body (cheaper than hashing it); empty: the body's SHA-256.
  bool revalidate = false;
  std::string etag;
  // When set (GET /v1/maps/{map}/events), the answer is a Server-Sent Events stream: the network
  // side sends the header, then what the stream queues, until either side ends it.
  std::shared_ptr<EventStream> events;
};

// Prometheus metrics: requests by route and status, latency histogram, bytes served, connections.
// Lock-free counters: a fixed table of the API's routes and the statuses it answers with.
class Metrics {
 public:
  void observe(const std::string& route, int status, double seconds, std::size_t bytes);
  std::atomic<long> open_connections{0};
  std::atomic<long> requests_in_progress{0};  // header read, not yet answered (this one included)
  std::string render(std::int64_t database_bytes) const;

 private:
  static constexpr const char* kRoutes[] = {"/healthz", "/readyz", "/metrics", "/v1/maps", "/v1/maps/{map}", "/v1/maps/{map}/current", "/v1/maps/{map}/roi",
                                            "/v1/maps/{map}/versions", "/v1/maps/{map}/versions/{v}/tiles",
                                            "/v1/maps/{map}/versions/{v}/tiles/{tx}/{ty}", "/v1/maps/{map}/versions/{v}/publish",
                                            "/v1/maps/{map}/versions/{v}/places", "/v1/maps/{map}/versions/{v}/manifest",
                                            "/v1/maps/{map}/reports", "/v1/maps/{map}/changes", "/v1/maps/{map}/update",
                                            "/v1/maps/{map}/versions/{v}/overview", "/v1/maps/{map}/vehicles", "/v1/maps/{map}/vehicles/{id}",
                                            "/v1/maps/{map}/events", "/viewer/{file}", "/v1/blobs/{hash}", "other"};
  static constexpr int kStatuses[] = {200, 201, 204, 304, 400, 401, 403, 404, 405, 409, 413, 422, 429, 431, 500, 503, 0};  // 0: any other
  static constexpr double kBuckets[] = {0.0005, 0.001, 0.0025, 0.005, 0.01, 0.025, 0.05, 0.1, 0.25, 1.0};
  static constexpr std::size_t kNRoutes = sizeof(kRoutes) / sizeof(kRoutes[0]), kNStatuses = sizeof(kStatuses) / sizeof(int),
                               kNBuckets = sizeof(kBuckets) / sizeof(double) + 1;
  std::atomic<std::uint64_t> requests_[kNRoutes][kNStatuses] = {};
  std::atomic<std::uint64_t> buckets_[kNBuckets] = {};
  std::atomic<std::uint64_t> latency_ns_{0}, latency_count_{0}, bytes_{0};
};

class Api {
 public:
  Api(ApiConfig cfg, Metrics& metrics);
  ~Api();
  // Never throws: a failure it did not expect is a 500 (logged to stderr with the request id).
  // HEAD answers as GET (the caller drops the body), OPTIONS with 204 and Allow; 405 carries
  // Allow, 401 WWW-Authenticate; JSON is gzip-compressed when req.accept_encoding allows.
  ApiResponse handle(const ApiRequest& req);
  // Largest body accepted for a route (413 beyond): tiles and places up to 64 MiB, JSON bodies
  // 64 KiB, else 0.
  static std::size_t body_limit(const std::string& method, const std::string& target);
  void set_draining(bool on) { draining_ = on; }
  bool ready();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  std::atomic<bool> draining_{false};
};

}  // namespace pl::server
