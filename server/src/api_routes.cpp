// The route table: each method and path to its handler, with its role and body limit.
#include "api_impl.hpp"

namespace pl::server {

// HEAD is GET without the body (the network side drops it); OPTIONS answers 204 with Allow.
ApiResponse Api::Impl::route(const ApiRequest& req, Api& api) {
  Target t = parse_target(req.target);
  const auto& s = t.segments;
  const std::string& m = req.method;
  const bool get = m == "GET" || m == "HEAD";
  auto options = [](const char* allow) {
    ApiResponse r;
    r.status = 204;
    r.content_type.clear();
    r.headers = {{"Allow", allow}};
    return r;
  };
  auto only = [&](bool ok, const std::string& route, const char* allow) {
    if (m == "OPTIONS") return true;
    if (!ok) method_not_allowed(m, route, allow);
    return false;
  };
  if (s.size() == 1 && (s[0] == "healthz" || s[0] == "readyz" || s[0] == "metrics")) {
    const std::string route = "/" + s[0];
    if (only(get, route, kReadOnly)) return options(kReadOnly);
    if (s[0] == "healthz") return text(200, "ok\n", route);
    if (s[0] == "readyz") return api.ready() ? text(200, "ready\n", route) : text(503, "not ready\n", route);
    // The store's size when it answers (-1 while it is out of reach: the rest still renders).
    std::int64_t bytes = -1;
    try {
      bytes = db().database_bytes();
    } catch (...) {
    }
    ApiResponse r = text(200, metrics.render(bytes), route);
    r.content_type = "text/plain; version=0.0.4";
    return r;
  }
  if (!s.empty() && s[0] == "viewer") {  // static files: no token, they hold no map data
    if (only(get, "/viewer/{file}", kReadOnly)) return options(kReadOnly);
    return viewer.file(req);
  }
  if (s.empty() || s[0] != "v1") fail(404, "no such resource: " + req.target);
  if (s.size() == 3 && s[1] == "blobs") {
    if (only(get, "/v1/blobs/{hash}", kReadOnly)) return options(kReadOnly);
    check_reader(req);
    if (!api::is_hash(s[2])) fail(400, "a blob is named by its SHA-256 (64 lowercase hex digits)");
    return blob_response(req, s[2], "/v1/blobs/{hash}");
  }
  if (s.size() < 2 || s[1] != "maps") fail(404, "no such resource: " + req.target);
  if (s.size() == 2) {
    const char* allow = "GET, HEAD, POST, OPTIONS";
    if (only(get || m == "POST", "/v1/maps", allow)) return options(allow);
    return get ? list_maps(req) : create_map(req);
  }
  const std::string& map = s[2];
  if (s.size() == 3) {
    if (only(get, "/v1/maps/{map}", kReadOnly)) return options(kReadOnly);
    return manifest(req, map);
  }
  if (s.size() == 4 && s[3] == "current") {
    if (only(get, "/v1/maps/{map}/current", kReadOnly)) return options(kReadOnly);
    return current(req, map);
  }
  if (s.size() == 4 && s[3] == "roi") {
    if (only(get, "/v1/maps/{map}/roi", kReadOnly)) return options(kReadOnly);
    return roi(req, map, t);
  }
  if (s.size() == 4 && s[3] == "reports") {
    const char* allow = "GET, HEAD, POST, OPTIONS";
    if (only(get || m == "POST", "/v1/maps/{map}/reports", allow)) return options(allow);
    if (get) {
      require_role(req, store::Role::Upload);
      return list_reports(db(), t, map);
    }
    return post_report(db(), req, map, require_role(req, store::Role::Report));
  }
  if (s.size() == 4 && s[3] == "changes") {
    if (only(get, "/v1/maps/{map}/changes", kReadOnly)) return options(kReadOnly);
    check_reader(req);
    return changes(db(), t, map);
  }
  if (s.size() == 4 && s[3] == "update") {
    if (only(m == "POST", "/v1/maps/{map}/update", kPostOnly)) return options(kPostOnly);
    const std::string by = require_role(req, store::Role::Admin);
    return update(db(), req, map, by, [&](std::int64_t number) { publish_update(map, number, by); });
  }
  if (s.size() == 4 && s[3] == "vehicles") {
    if (only(get, "/v1/maps/{map}/vehicles", kReadOnly)) return options(kReadOnly);
    check_reader(req);
    return viewer.vehicles(need_map(map).name);
  }
  if (s.size() == 5 && s[3] == "vehicles") {
    if (only(m == "POST", "/v1/maps/{map}/vehicles/{id}", kPostOnly)) return options(kPostOnly);
    require_role(req, store::Role::Report);
    return viewer.post_vehicle(req, need_map(map).name, s[4]);
  }
  if (s.size() == 4 && s[3] == "events") {
    if (only(get, "/v1/maps/{map}/events", kReadOnly)) return options(kReadOnly);
    check_reader(req);
    return viewer.events(need_map(map).name, m == "HEAD");
  }
  if (s[3] != "versions") fail(404, "no such resource: " + req.target);
  if (s.size() == 4) {
    const char* allow = "GET, HEAD, POST, OPTIONS";
    if (only(get || m == "POST", "/v1/maps/{map}/versions", allow)) return options(allow);
    if (get) {  // the version list (the viewer's): staged ones for upload tokens only
      const bool staged = check_reader(req);
      return Viewer::versions(db(), need_map(map), staged);
    }
    return create_version(req, map);
  }
  if (s.size() == 6 && s[5] == "overview") {
    if (only(get, "/v1/maps/{map}/versions/{v}/overview", kReadOnly)) return options(kReadOnly);
    const bool staged = check_reader(req);
    const auto mi = need_map(map);
    return viewer.overview(db(), req, mi, need_version(mi, parse_version(s[4]), staged));
  }
  if (s.size() == 6 && s[5] == "publish") {
    if (only(m == "POST", "/v1/maps/{map}/versions/{v}/publish", kPostOnly)) return options(kPostOnly);
    return publish(req, map, s[4]);
  }
  if (s.size() == 6 && s[5] == "manifest") {
    if (only(get, "/v1/maps/{map}/versions/{v}/manifest", kReadOnly)) return options(kReadOnly);
    return get_manifest(req, map, s[4]);
  }
  if (s.size() == 6 && s[5] == "places") {
    const char* allow = "GET, HEAD, PUT, DELETE, OPTIONS";
    if (only(get || m == "PUT" || m == "DELETE", "/v1/maps/{map}/versions/{v}/places", allow)) return options(allow);
    if (get) return get_places(req, map, s[4]);
    return m == "PUT" ? put_places(req, map, s[4]) : delete_places(req, map, s[4]);
  }
  if (s.size() == 6 && s[5] == "tiles") {
    if (only(get, "/v1/maps/{map}/versions/{v}/tiles", kReadOnly)) return options(kReadOnly);
    return list_tiles(req, map, s[4]);
  }
  if (s.size() == 8 && s[5] == "tiles") {
    const char* allow = "GET, HEAD, PUT, DELETE, OPTIONS";
    if (only(get || m == "PUT" || m == "DELETE", "/v1/maps/{map}/versions/{v}/tiles/{tx}/{ty}", allow)) return options(allow);
    if (get) return get_tile(req, map, s[4], s[6], s[7]);
    if (m == "PUT") return put_tile(req, map, s[4], s[6], s[7]);
    return delete_tile(req, map, s[4], s[6], s[7]);
  }
  fail(404, "no such resource: " + req.target);
}

ApiResponse Api::Impl::text(int status, std::string body, const std::string& route) {
  ApiResponse r;
  r.status = status;
  r.body = std::move(body);
  r.content_type = "text/plain";
  r.route = route;
  return r;
}

}  // namespace pl::server
