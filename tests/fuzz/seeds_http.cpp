// Seeds of the api and http fuzz targets: the requests the product's own clients send (pl-map push,
// the tile client, an operator with curl), against the store of api_env.hpp.
#include <cstdio>
#include <string>
#include <vector>

#include "api_env.hpp"
#include "pl/schema/signed_current.hpp"
#include "pl/schema/signed_manifest.hpp"
#include "pl/schema/store.hpp"
#include "seeds.hpp"

namespace {

struct Req {
  std::string name, method, target, auth, if_none_match, accept_encoding, body;
};

std::vector<Req> requests() {
  const std::string h00 = pl::store::content_hash(pl::fuzz::town_tile(0, 0));
  const std::string h10 = pl::store::content_hash(pl::fuzz::town_tile(1, 0));
  const std::string hp = pl::store::content_hash(pl::fuzz::kTownPlaces);
  return {
      {"list-maps", "GET", "/v1/maps", "", "", "", ""},
      {"manifest-gzip", "GET", "/v1/maps/town", "", "", "gzip, deflate", ""},
      {"roi-have", "GET", "/v1/maps/town/roi?x=10&y=10.5&radius=50&have=" + h00 + "," + h10, "@read", "", "gzip;q=1.0, identity;q=0.5", ""},
      {"roi-staged", "GET", "/v1/maps/town/roi?x=-5&y=30&radius=120&version=2", "@upload", "", "", ""},
      {"tiles-list", "GET", "/v1/maps/town/versions/1/tiles", "", "", "*", ""},
      {"tile-etag", "GET", "/v1/maps/town/versions/1/tiles/0/0", "", "\"" + h00 + "\"", "", ""},
      {"tile-head", "HEAD", "/v1/maps/town/versions/1/tiles/-1/2", "", "", "", ""},
      {"blob", "GET", "/v1/blobs/" + h10, "", "", "", ""},
      {"places", "GET", "/v1/maps/town/versions/1/places", "", "", "", ""},
      {"places-etag", "GET", "/v1/maps/town/versions/1/places", "", "\"" + hp + "\"", "", ""},
      {"places-staged-head", "HEAD", "/v1/maps/town/versions/2/places", "@upload", "", "", ""},
      {"put-places", "PUT", "/v1/maps/town/versions/2/places", "@upload", "", "", "new places of version 2"},
      {"delete-places", "DELETE", "/v1/maps/town/versions/2/places", "@upload", "", "", ""},
      {"create-map", "POST", "/v1/maps", "@admin", "", "",
       R"({"name": "harbour", "origin": {"lat": 53.54, "lon": 9.98, "alt": 4.5}, "tile_size": 25, "voxel_size": 0.25})"},
      {"create-version", "POST", "/v1/maps/town/versions", "@upload", "", "", R"({"note": "second drive"})"},
      {"put-tile", "PUT", "/v1/maps/town/versions/2/tiles/1/1", "@upload", "", "", pl::fuzz::town_tile(1, 1)},
      {"put-tile-wrong-key", "PUT", "/v1/maps/town/versions/2/tiles/3/1", "@upload", "", "", pl::fuzz::town_tile(1, 1)},
      {"delete-tile", "DELETE", "/v1/maps/town/versions/2/tiles/0/0", "@upload", "", "", ""},
      {"publish", "POST", "/v1/maps/town/versions/2/publish", "@upload", "", "", ""},
      {"publish-signed", "POST", "/v1/maps/town/versions/2/publish", "@upload", "", "",
       R"({"public_key": ")" + std::string(43, 'A') + R"(=", "signature": ")" + std::string(86, 'B') + R"(=="})"},
      {"manifest-text", "GET", "/v1/maps/town/versions/1/manifest", "", "", "", ""},
      {"manifest-staged", "GET", "/v1/maps/town/versions/2/manifest", "@upload", "", "", ""},
      {"metrics", "GET", "/metrics", "", "", "", ""},
      {"healthz", "GET", "/healthz", "", "", "", ""},
      {"readyz-head", "HEAD", "/readyz", "", "", "", ""},
      {"options", "OPTIONS", "/v1/maps/town/versions/2/tiles/0/0", "", "", "", ""},
      {"patch-healthz", "PATCH", "/healthz", "", "", "", ""},
      {"bad-token", "GET", "/v1/maps", "Bearer nope", "", "", ""},
      {"encoded-name", "GET", "/v1/maps/to%77n?x=1", "", "", "", ""},
      // The map viewer's routes (server/src/viewer.cpp).
      {"versions-list", "GET", "/v1/maps/town/versions", "", "", "gzip", ""},
      {"versions-staged", "GET", "/v1/maps/town/versions", "@upload", "", "", ""},
      {"overview", "GET", "/v1/maps/town/versions/1/overview", "", "", "", ""},
      {"overview-staged", "GET", "/v1/maps/town/versions/2/overview", "@upload", "", "", ""},
      {"vehicle-post", "POST", "/v1/maps/town/vehicles/car-1", "@upload", "", "",
       R"({"x": 12.5, "y": -3.25, "z": 0.5, "yaw": 1.5, "health": "degraded", "t": 1800000000.25})"},
      {"vehicles", "GET", "/v1/maps/town/vehicles", "@read", "", "", ""},
      {"events", "GET", "/v1/maps/town/events", "", "", "", ""},
      {"viewer-index", "GET", "/viewer/", "", "", "", ""},
      {"viewer-redirect", "GET", "/viewer?map=town", "", "", "", ""},
      {"viewer-traversal", "GET", "/viewer/js/%2e%2e/..%2f..%2findex.html", "", "", "", ""},
  };
}

void api_seeds(const pl::fuzz::PutSeed& put) {
  for (const auto& r : requests())
    put(r.name, r.method + "\n" + r.target + "\n" + r.auth + "\n" + r.if_none_match + "\n" + r.accept_encoding + "\n" + r.body);
}

std::string raw(const Req& r, bool close) {
  std::string auth = r.auth == "@read" ? pl::fuzz::kReadToken : r.auth == "@upload" ? pl::fuzz::kUploadToken
                                                             : r.auth == "@admin" ? pl::fuzz::kAdminToken : r.auth;
  std::string s = r.method + " " + r.target + " HTTP/1.1\r\nHost: 127.0.0.1:8080\r\nUser-Agent: pointlocalization\r\n";
  if (!auth.empty()) s += "Authorization: " + (auth.rfind("Bearer ", 0) == 0 ? auth : "Bearer " + auth) + "\r\n";
  if (!r.if_none_match.empty()) s += "If-None-Match: " + r.if_none_match + "\r\n";
  if (!r.accept_encoding.empty()) s += "Accept-Encoding: " + r.accept_encoding + "\r\n";
  if (!r.body.empty() || r.method == "POST" || r.method == "PUT") s += "Content-Length: " + std::to_string(r.body.size()) + "\r\n";
  if (close) s += "Connection: close\r\n";
  return s + "\r\n" + r.body;
}

void http_seeds(const pl::fuzz::PutSeed& put) {
  auto all = requests();
  for (const auto& r : all) put(r.name, raw(r, false));
  put("pipelined", raw(all[1], false) + raw(all[2], false) + raw(all[5], true));
  put("chunked-post", "POST /v1/maps/town/versions HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer " + std::string(pl::fuzz::kUploadToken) +
                          "\r\nTransfer-Encoding: chunked\r\n\r\n5\r\n{\"not\r\n9\r\ne\": \"x\"}\r\n0\r\n\r\n");
  put("http10", "GET /v1/maps/town HTTP/1.0\r\n\r\n");
}

// The tile client's inputs, as the real API answers them (first byte: which parser, see
// fuzz_client_answers.cpp).
void client_answer_seeds(const pl::fuzz::PutSeed& put) {
  auto answer = [](const std::string& method, const std::string& target) {
    pl::server::ApiRequest req;
    req.method = method;
    req.target = target;
    req.request_id = "seed";
    return pl::fuzz::handle_checked(req);
  };
  const std::string manifest = answer("GET", "/v1/maps/town").body;
  const auto roi = answer("GET", "/v1/maps/town/roi?x=10&y=10&radius=60");
  const auto missing = answer("GET", "/v1/maps/nowhere");
  put("manifest", std::string(1, '\0') + manifest);
  put("manifest-pinned", std::string(1, '\1') + manifest);
  put("roi", std::string(1, '\2') + roi.body);
  put("error-404", std::string(1, '\3') + missing.body);
  put("tile", std::string(1, '\4') + pl::fuzz::town_tile(1, 0));
  const auto places = answer("GET", "/v1/maps/town/versions/1/places");
  std::string etag;
  for (const auto& [k, v] : places.headers)
    if (k == "ETag") etag = v;
  put("places", std::string(1, '\6') + etag + "\n" + *places.blob);
  auto http = [](int status, const std::string& reason, const std::string& body, bool chunked) {
    std::string s = "HTTP/1.1 " + std::to_string(status) + " " + reason + "\r\nServer: pl-server\r\nContent-Type: application/json\r\n";
    if (!chunked) return s + "Content-Length: " + std::to_string(body.size()) + "\r\n\r\n" + body;
    char size[16];
    std::snprintf(size, sizeof(size), "%zx", body.size());
    return s + "Transfer-Encoding: chunked\r\n\r\n" + size + "\r\n" + body + "\r\n0\r\n\r\n";
  };
  put("http-roi", std::string(1, '\5') + http(200, "OK", roi.body, false));
  put("http-manifest-chunked", std::string(1, '\5') + http(200, "OK", manifest, true));
  put("http-404", std::string(1, '\5') + http(404, "Not Found", missing.body, false));
  // Version 1's manifest as pl-server answers it, signed with the seeds' fleet key (the published
  // version of api_env.hpp is not signed: signed here as pl-map publish --signing-key would).
  const auto text = answer("GET", "/v1/maps/town/versions/1/manifest");
  const std::string body = text.blob ? *text.blob : text.body;
  const auto key = pl::signing::SigningKey::from_seed(pl::fuzz::kFleetSeed);
  put("signed-manifest", std::string(1, '\7') + body + pl::signing::signature_line(key.public_key(), key.sign(body)));
  put("manifest-text", std::string(1, '\10') + body);
  // A current-version statement valid at the target's clock, signed with the fleet key.
  const std::string current = pl::signing::sign_current({"town", 1, 1'800'000'000 - 10, 1'800'000'000 + 290}, key);
  put("signed-current", std::string(1, '\11') + current);
  put("current-text", std::string(1, '\12') + current.substr(0, current.find("signature ")));
}

const bool registered = pl::fuzz::register_seeds("api", api_seeds) && pl::fuzz::register_seeds("http", http_seeds) &&
                        pl::fuzz::register_seeds("client_answers", client_answer_seeds);

}  // namespace
