#include "api_impl.hpp"

namespace pl::server {

TileUpload check_tile_upload(std::string_view bytes, double tile_size, const TileKey& key) {
  TileCloud cloud;
  try {
    cloud = decode_tile(bytes);
  } catch (const Error& e) {
    throw Error(std::string("the body is not a valid tile: ") + e.what());
  }
  if (cloud.points.empty()) throw Error("the tile has no points");
  TileBounds b = TileGrid(tile_size).bounds_of(key);
  const double slack = 0.01;  // quantization of positions near the tile's edge
  Eigen::Vector3d lo = cloud.points.front(), hi = lo;
  for (const auto& p : cloud.points) {
    if (!(p.x() >= b.min_x - slack && p.x() <= b.max_x + slack && p.y() >= b.min_y - slack && p.y() <= b.max_y + slack))
      throw Error("point (" + std::to_string(p.x()) + ", " + std::to_string(p.y()) + ") lies outside tile " + std::to_string(key.tx) +
                  "/" + std::to_string(key.ty) + " of this map's " + std::to_string(tile_size) + " m grid");
    lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
  }
  TileUpload up;
  up.points = cloud.size();
  for (int c = 0; c < 3; ++c) up.min[c] = lo[c], up.max[c] = hi[c];
  return up;
}

// ---------------------------------------------------------------------------------------------
// The API

Api::Api(ApiConfig cfg, Metrics& metrics) : impl_(std::make_unique<Impl>(std::move(cfg), metrics)) {
  impl_->db();  // fail at start-up, not on the first request, when the store cannot be opened
}

Api::~Api() = default;

// Ready: not draining, and the store answers a query (the schema version: a read of the store
// itself on both engines, not of any map).
bool Api::ready() {
  if (draining_) return false;
  try {
    impl_->db().schema_version();
    return true;
  } catch (...) {
    return false;
  }
}

std::size_t Api::body_limit(const std::string& method, const std::string& target) {
  if (method == "PUT" && target.find("/tiles/") != std::string::npos) return 64u << 20;
  if (method == "PUT") {
    const Target t = parse_target(target);  // as route() reads it
    const auto& s = t.segments;
    if (s.size() == 6 && s[0] == "v1" && s[1] == "maps" && s[3] == "versions" && s[5] == "places") return api::kMaxPlacesBytes;
  }
  if (method == "POST") {
    const Target t = parse_target(target);
    const auto& s = t.segments;
    if (s.size() == 4 && s[0] == "v1" && s[1] == "maps" && s[3] == "reports") return schema::ChangeReportLimits{}.max_bytes;
    return 64u << 10;
  }
  return 0;
}

// The route template of a target, for metrics of requests that failed before reaching a handler.
constexpr std::size_t kGzipMinBytes = 256;

static std::string route_template(const std::string& target) {
  Target t = parse_target(target);
  const auto& s = t.segments;
  if (s.size() == 1 && (s[0] == "healthz" || s[0] == "readyz" || s[0] == "metrics")) return "/" + s[0];
  if (!s.empty() && s[0] == "viewer") return "/viewer/{file}";
  if (s.size() == 5 && s[0] == "v1" && s[1] == "maps" && s[3] == "vehicles") return "/v1/maps/{map}/vehicles/{id}";
  if (s.size() < 2 || s[0] != "v1") return "other";
  if (s[1] == "blobs" && s.size() == 3) return "/v1/blobs/{hash}";
  if (s[1] != "maps") return "other";
  static const char* names[] = {"v1", "maps", "{map}", "", "{v}", "", "{tx}", "{ty}"};
  std::string out;
  for (std::size_t i = 0; i < s.size() && i < 8; ++i) out += "/" + (names[i][0] ? std::string(names[i]) : s[i]);
  return s.size() > 8 ? "other" : out;
}

ApiResponse Api::handle(const ApiRequest& req) {
  ApiResponse r;
  try {
    try {
      r = impl_->route(req, *this);
    } catch (const HttpError& e) {
      r = json_response(e.status, {{"error", e.message}, {"status", e.status}}, route_template(req.target));
      r.headers = e.headers;
      if (e.status == 401)  // RFC 6750: which scheme, and whether a token was sent but refused
        r.headers.emplace_back("WWW-Authenticate", req.authorization.empty() ? "Bearer realm=\"pl-server\""
                                                                             : "Bearer realm=\"pl-server\", error=\"invalid_token\"");
    }
    // The answers that change as maps are published (ApiResponse::revalidate): an HTTP cache in
    // front (deploy/varnish, deploy/nginx) may keep one for a second, then revalidate it by its ETag
    // (weak: a proxy may re-encode the body). An answer to a request with a token is that token's:
    // private.
    const bool get = req.method == "GET" || req.method == "HEAD";
    if (r.status == 200 && get && r.revalidate) {
      const std::string tag = "\"" + (r.etag.empty() ? store::content_hash(r.body).substr(0, 32) : r.etag) + "\"";
      r.headers.emplace_back("ETag", "W/" + tag);
      r.headers.emplace_back("Cache-Control", req.authorization.empty() ? "public, max-age=1" : "private, no-cache");
      if (!req.if_none_match.empty() && (req.if_none_match == "*" || req.if_none_match.find(tag) != std::string::npos)) {
        r.status = 304;
        r.body.clear();
        r.content_type.clear();
        r.headers.emplace_back("Vary", "Accept-Encoding");  // as the 200 it stands for
      }
    }
    // JSON answers: compressed when the client accepts gzip and it pays (a few hundred bytes on).
    if (r.content_type == "application/json" && !r.blob) {
      r.headers.emplace_back("Vary", "Accept-Encoding");
      if (r.body.size() >= kGzipMinBytes && accepts_gzip(req.accept_encoding)) {
        r.body = gzip(r.body);
        r.headers.emplace_back("Content-Encoding", "gzip");
      }
    }
    return r;
  } catch (...) {
    // The store out of reach (its server restarting): 503 with Retry-After, which clients and
    // caches retry; nothing was written (a write's transaction did not commit).
    std::string unreachable;
    try {
      throw;
    } catch (const StoreUnreachable& e) {
      unreachable = e.what();
    } catch (const std::exception& e) {
      if (Impl::store_lost()) unreachable = e.what();
    } catch (...) {
    }
    if (!unreachable.empty()) {
      // The details (the store's address, the driver's words) go to the log, not to the client.
      log_request_problem(impl_->cfg.log_json, "warning", "the map store is unreachable", req, unreachable);
      const bool read = req.method == "GET" || req.method == "HEAD";
      ApiResponse e = json_response(
          503,
          {{"error", std::string("the map store is unreachable just now: retry in a second") +
                         (read ? "" : " (a change whose answer this is was not made, unless the store lost contact while committing it: "
                                      "read back before repeating one that is not idempotent, such as opening a version)")},
           {"status", 503}},
          route_template(req.target));
      e.headers.emplace_back("Retry-After", "1");
      return e;
    }
    // Anything else unexpected (a store failure, a bug, memory): a 500 for this request only,
    // logged with the request id; the server goes on serving.
    std::string what = "unknown exception";
    try {
      throw;
    } catch (const std::exception& e) {
      what = e.what();
    } catch (...) {
    }
    log_request_problem(impl_->cfg.log_json, "error", "internal error", req, what);
    ApiResponse e;
    e.status = 500;
    e.body = "{\"error\":\"internal error: see the server log for request " + printable(req.request_id, 64) + "\",\"status\":500}\n";
    e.route = "other";
    return e;
  }
}

}  // namespace pl::server
