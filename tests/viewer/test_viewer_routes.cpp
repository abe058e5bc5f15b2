// pl-server's routes for the map viewer, over HTTP against a real pl-server on a store pl-map made:
// the static files (types, caching, no way out of the folder), a version's overview, the version
// list, and the live vehicles with their Server-Sent Events stream.
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <set>
#include <thread>
#include <tuple>

#include "pl/common/tile_codec.hpp"
#include "pl/schema/http_client.hpp"
#include "pl/schema/store.hpp"
#include "server_process.hpp"
#include "test_util.hpp"
#include "viewer_fixture.hpp"

using nlohmann::json;
using pl::api::HttpClient;
using pl::test::kAdminToken;
using pl::test::kReadToken;
using pl::test::kReportToken;
using pl::test::kUploadToken;
using pl::test::MapFixture;
using pl::test::RawConnection;
using pl::test::ServerProcess;
using pl::test::ViewerMap;

namespace {

std::map<std::string, std::string> bearer(const std::string& token) { return {{"Authorization", "Bearer " + token}}; }

void expect_error(const pl::api::HttpResponse& r, int status, const std::string& words) {
  EXPECT_EQ(r.status, status) << r.body;
  const json j = json::parse(r.body, nullptr, false);
  ASSERT_TRUE(j.is_object()) << r.body;
  EXPECT_NE(j.value("error", "").find(words), std::string::npos) << r.body;
}

// A folder of viewer files, with things it must not serve: a hidden file, and a link out of it.
struct ViewerDir {
  pl::test::TempDir dir;
  ViewerDir() {
    pl::test::write_file(dir / "viewer/index.html", "<!doctype html><title>t</title>");
    pl::test::write_file(dir / "viewer/js/app.mjs", "export const x = 1;\n");
    pl::test::write_file(dir / "viewer/app.js", "console.log(1);\n");
    pl::test::write_file(dir / "viewer/style.css", "body{}\n");
    pl::test::write_file(dir / "viewer/data.json", "{\"a\": 1}\n");
    pl::test::write_file(dir / "viewer/vendor/d.wasm", std::string("\0asm\1\0\0\0", 8));
    pl::test::write_file(dir / "viewer/.hidden", "secret\n");
    pl::test::write_file(dir / "outside.txt", "outside\n");
    std::filesystem::create_symlink(dir / "outside.txt", dir / "viewer/link.txt");
  }
  std::string path() const { return dir / "viewer"; }
};

}  // namespace

TEST(ViewerRoutes, StaticFilesHaveTheirTypesAndCachingAndNothingOutsideTheFolderIsServed) {
  MapFixture f;
  ViewerDir v;
  ServerProcess server(f.db, {"--viewer-dir", v.path()});
  HttpClient http(server.url());

  // The folder's own URL: a redirect to it with its slash (the page's relative URLs need it).
  auto r = http.get("/viewer");
  EXPECT_EQ(r.status, 301);
  EXPECT_EQ(r.header("location"), "/viewer/");
  r = http.get("/viewer/");
  ASSERT_EQ(r.status, 200) << r.body;
  EXPECT_EQ(r.body, "<!doctype html><title>t</title>");
  EXPECT_EQ(r.header("content-type"), "text/html; charset=utf-8");
  EXPECT_EQ(r.header("cache-control"), "no-cache");
  EXPECT_EQ(r.header("x-content-type-options"), "nosniff");
  EXPECT_EQ(r.header("etag"), "\"" + pl::store::content_hash(r.body) + "\"");
  EXPECT_EQ(http.get("/viewer/", {{"If-None-Match", r.header("etag")}}).status, 304);
  EXPECT_EQ(http.get("/viewer/index.html").body, r.body);

  for (const auto& [target, type] : std::vector<std::pair<std::string, std::string>>{
           {"/viewer/js/app.mjs", "text/javascript; charset=utf-8"},
           {"/viewer/app.js", "text/javascript; charset=utf-8"},
           {"/viewer/style.css", "text/css; charset=utf-8"},
           {"/viewer/data.json", "application/json"},
           {"/viewer/vendor/d.wasm", "application/wasm"}}) {
    r = http.get(target);
    EXPECT_EQ(r.status, 200) << target;
    EXPECT_EQ(r.header("content-type"), type) << target;
  }
  EXPECT_EQ(http.get("/viewer/vendor/d.wasm").body, std::string("\0asm\1\0\0\0", 8));
  EXPECT_EQ(http.request("HEAD", "/viewer/app.js").header("content-length"), "16");
  expect_error(http.get("/viewer/missing.js"), 404, "no file missing.js");
  expect_error(http.request("POST", "/viewer/app.js", "x"), 405, "not allowed");
  // A file changed on disk is served changed (a rebuilt viewer shows without a restart).
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  pl::test::write_file(v.path() + "/app.js", "console.log(22);\n");
  EXPECT_EQ(http.get("/viewer/app.js").body, "console.log(22);\n");

  // Out of the folder, however spelt (raw: an HTTP library would resolve the dots itself), hidden
  // files, empty names: refused; a link pointing out of the folder: not found.
  for (const std::string target : {"/viewer/../CMakeLists.txt", "/viewer/%2e%2e/outside.txt", "/viewer/%2E%2E/outside.txt",
                                   "/viewer/..%2foutside.txt", "/viewer/js/../../outside.txt", "/viewer/.hidden", "/viewer/%2ehidden",
                                   "/viewer//index.html", "/viewer/js%2fapp.mjs", "/viewer/index.html%00.js", "/viewer/a%5c..%5cb",
                                   "/viewer/..", "/viewer/./index.html"}) {
    const std::string answer = pl::test::raw_get(server.port(), target);
    EXPECT_EQ(answer.substr(9, 3), "400") << target << "\n" << answer;
    EXPECT_EQ(answer.find("outside\n"), std::string::npos) << target;
    EXPECT_EQ(answer.find("secret"), std::string::npos) << target;
  }
  expect_error(http.get("/viewer/link.txt"), 404, "no file link.txt");
  EXPECT_EQ(server.terminate(), 0);
}

TEST(ViewerRoutes, TheBuildsViewerIsServedByDefaultAndABadViewerDirStopsTheStart) {
  MapFixture f;
  {
    ServerProcess server(f.db);
    EXPECT_NE(server.output().find("map viewer at " + server.url() + "/viewer/"), std::string::npos) << server.output();
    HttpClient http(server.url());
    auto r = http.get("/viewer/");
    ASSERT_EQ(r.status, 200) << r.body << "\n(build the viewer target: the test depends on it)";
    EXPECT_NE(r.body.find("importmap"), std::string::npos);
    r = http.get("/viewer/vendor/draco/draco_decoder.wasm");
    ASSERT_EQ(r.status, 200);
    EXPECT_EQ(r.header("content-type"), "application/wasm");
    EXPECT_EQ(r.body.substr(0, 4), std::string("\0asm", 4));
    for (const char* file : {"/viewer/js/main.mjs", "/viewer/vendor/three/three.module.js", "/viewer/vendor/three/three.core.js",
                             "/viewer/vendor/three/addons/loaders/DRACOLoader.js", "/viewer/vendor/draco/draco_wasm_wrapper.js"}) {
      r = http.get(file);
      EXPECT_EQ(r.status, 200) << file;
      EXPECT_EQ(r.header("content-type"), "text/javascript; charset=utf-8") << file;
    }
    EXPECT_EQ(server.terminate(), 0);
  }
  pl::test::TempDir empty;
  auto r = pl::test::run(pl::test::tool("pl-server") + " --db " + f.db + " --listen 127.0.0.1:0 --viewer-dir " + empty.path());
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("--viewer-dir " + empty.path() + ": no index.html there"), std::string::npos) << r.output;
}

TEST(ViewerRoutes, TheOverviewIsOnePointPerTwoMetreVoxelOfTheVersionAndKeptForGood) {
  MapFixture f;
  ServerProcess server(f.db, f.token_args());
  HttpClient http(server.url());
  const json manifest = json::parse(http.get("/v1/maps/town").body);
  auto r = http.get("/v1/maps/town/versions/1/overview");
  ASSERT_EQ(r.status, 200) << r.body;
  EXPECT_EQ(r.header("content-type"), "application/vnd.google.draco");
  EXPECT_EQ(r.header("etag"), "\"" + pl::store::content_hash(r.body) + "\"");
  EXPECT_EQ(r.header("cache-control"), "public, max-age=31536000, immutable");
  EXPECT_EQ(r.header("x-overview-voxel"), "2");
  const pl::TileCloud overview = pl::decode_tile(r.body);
  EXPECT_EQ(r.header("x-overview-points"), std::to_string(overview.size()));
  EXPECT_EQ(overview.intensity.size(), overview.size());

  // One point per occupied 2 m voxel of the version's (decoded) points, inside their box.
  std::set<std::tuple<long, long, long>> voxels;
  const json tiles = json::parse(http.get("/v1/maps/town/versions/1/tiles").body)["tiles"];
  for (const auto& t : tiles)
    for (const auto& p : pl::decode_tile(http.get("/v1/maps/town/versions/1/tiles/" + std::to_string(t["tx"].get<int>()) + "/" +
                                                   std::to_string(t["ty"].get<int>()))
                                              .body)
                             .points)
      voxels.emplace(std::floor(p.x() / 2), std::floor(p.y() / 2), std::floor(p.z() / 2));
  EXPECT_EQ(overview.size(), voxels.size());
  EXPECT_GT(overview.size(), 100u);
  EXPECT_LT(overview.size(), manifest["points"].get<std::size_t>() / 10);
  const auto& lo = manifest["bounds"]["min"];
  const auto& hi = manifest["bounds"]["max"];
  for (const auto& p : overview.points)
    for (int c = 0; c < 3; ++c) {
      ASSERT_GE(p[c], lo[c].get<double>() - 0.03) << c;  // the overview's quantization: 2 cm
      ASSERT_LE(p[c], hi[c].get<double>() + 0.03) << c;
    }
  // Made once: the same bytes again, 304 by its tag.
  EXPECT_EQ(http.get("/v1/maps/town/versions/1/overview").body, r.body);
  EXPECT_EQ(http.get("/v1/maps/town/versions/1/overview", {{"If-None-Match", r.header("etag")}}).status, 304);

  // A staged version: only for upload tokens, never cached for good.
  ASSERT_EQ(http.request("POST", "/v1/maps/town/versions", "{\"note\": \"staged\"}", bearer(kUploadToken)).status, 201);
  expect_error(http.get("/v1/maps/town/versions/2/overview"), 404, "has no version 2");
  r = http.get("/v1/maps/town/versions/2/overview", bearer(kUploadToken));
  ASSERT_EQ(r.status, 200) << r.body;
  EXPECT_EQ(r.header("cache-control"), "private, no-cache");
  EXPECT_EQ(pl::decode_tile(r.body).size(), overview.size());  // a copy of version 1's tiles
  expect_error(http.get("/v1/maps/town/versions/9/overview"), 404, "has no version 9");
  expect_error(http.get("/v1/maps/town/versions/x/overview"), 400, "version must be");
  expect_error(http.get("/v1/maps/nowhere/versions/1/overview"), 404, "no map named");
  EXPECT_EQ(server.terminate(), 0);
}

TEST(ViewerRoutes, TheVersionListShowsStateDateAndNoteAndStagedOnesToUploadersOnly) {
  ViewerMap f(false);  // version 2 staged
  ServerProcess server(f.db, f.token_args());
  HttpClient http(server.url());
  auto r = http.get("/v1/maps/town/versions");
  ASSERT_EQ(r.status, 200) << r.body;
  json j = json::parse(r.body);
  EXPECT_EQ(j["map"], "town");
  EXPECT_EQ(j["current_version"], 1);
  ASSERT_EQ(j["versions"].size(), 1u);
  const json& v1 = j["versions"][0];
  EXPECT_EQ(v1["version"], 1);
  EXPECT_EQ(v1["state"], "published");
  EXPECT_TRUE(v1["parent"].is_null());
  EXPECT_EQ(v1["created"].get<std::string>().size(), 24u);  // 2026-12-05T19:30:00.000Z
  EXPECT_NE(v1["note"].get<std::string>().find("street.pcd"), std::string::npos);
  EXPECT_GT(v1["tiles"].get<int>(), 8);
  EXPECT_FALSE(v1["signed"].get<bool>());
  EXPECT_FALSE(r.header("etag").empty());  // changes as versions are published: revalidated

  j = json::parse(http.get("/v1/maps/town/versions", bearer(kUploadToken)).body);
  ASSERT_EQ(j["versions"].size(), 2u);
  EXPECT_EQ(j["versions"][1]["state"], "staged");
  EXPECT_EQ(j["versions"][1]["parent"], 1);
  EXPECT_EQ(json::parse(http.get("/v1/maps/town/versions", bearer(kReadToken)).body)["versions"].size(), 1u);
  ASSERT_EQ(http.request("POST", "/v1/maps/town/versions/2/publish", "", bearer(kUploadToken)).status, 200);
  j = json::parse(http.get("/v1/maps/town/versions").body);
  ASSERT_EQ(j["versions"].size(), 2u);
  EXPECT_EQ(j["versions"][0]["state"], "retired");
  EXPECT_EQ(j["current_version"], 2);
  expect_error(http.get("/v1/maps/nowhere/versions"), 404, "no map named");
  EXPECT_EQ(http.request("OPTIONS", "/v1/maps/town/versions").header("allow"), "GET, HEAD, POST, OPTIONS");
  EXPECT_EQ(server.terminate(), 0);
}

TEST(ViewerRoutes, VehiclesNeedTheReportRoleAndValidJsonAndAreBounded) {
  ViewerMap f;
  ServerProcess server(f.db, {"--tokens", f.dir / "tokens.txt", "--vehicles", "2"});
  HttpClient http(server.url());
  const std::string car = R"({"x": 12.5, "y": -3.25, "z": 0.5, "yaw": 1.5, "health": "ok", "t": 1800000000.25})";
  expect_error(http.request("POST", "/v1/maps/town/vehicles/car-1", car), 401, "report role");
  expect_error(http.request("POST", "/v1/maps/town/vehicles/car-1", car, bearer(kReadToken)), 403, "needs the report role");
  auto r = http.request("POST", "/v1/maps/town/vehicles/car-1", car, bearer(kReportToken));
  ASSERT_EQ(r.status, 200) << r.body;
  json j = json::parse(r.body);
  EXPECT_EQ(j["id"], "car-1");
  EXPECT_DOUBLE_EQ(j["x"].get<double>(), 12.5);
  EXPECT_DOUBLE_EQ(j["y"].get<double>(), -3.25);
  EXPECT_DOUBLE_EQ(j["t"].get<double>(), 1800000000.25);
  EXPECT_EQ(j["health"], "ok");
  EXPECT_EQ(r.header("cache-control"), "no-store");
  // An upload token has the report role too (roles include the ones below them).
  EXPECT_EQ(http.request("POST", "/v1/maps/town/vehicles/car-2", R"({"x": 1, "y": 2, "health": "lost"})", bearer(kUploadToken)).status, 200);

  for (const auto& [body, words] : std::vector<std::pair<std::string, std::string>>{
           {"not json", "not a JSON object"},
           {"[1, 2]", "not a JSON object"},
           {R"({"y": 2, "health": "ok"})", "\"x\" is missing"},
           {R"({"x": "1", "y": 2, "health": "ok"})", "\"x\" must be a number"},
           {R"({"x": 1, "y": 2, "z": 1e300, "health": "ok"})", "\"z\" is out of range"},
           {R"({"x": 1, "y": 2})", "\"health\" is missing"},
           {R"({"x": 1, "y": 2, "health": "fine"})", "\"health\" is \"ok\", \"degraded\" or \"lost\""}})
    expect_error(http.request("POST", "/v1/maps/town/vehicles/car-1", body, bearer(kReportToken)), 400, words);
  expect_error(http.request("POST", "/v1/maps/town/vehicles/car%201", car, bearer(kReportToken)), 400, "a vehicle id is");
  expect_error(http.request("POST", "/v1/maps/nowhere/vehicles/car-1", car, bearer(kReportToken)), 404, "no map named");
  expect_error(http.get("/v1/maps/town/vehicles/car-1"), 405, "not allowed");

  // At most --vehicles 2: a third is refused until one goes silent; those known still update.
  r = http.request("POST", "/v1/maps/town/vehicles/car-3", car, bearer(kReportToken));
  expect_error(r, 503, "--vehicles");
  EXPECT_EQ(r.header("retry-after"), "60");
  EXPECT_EQ(http.request("POST", "/v1/maps/town/vehicles/car-2", R"({"x": 3, "y": 4, "health": "degraded"})", bearer(kReportToken)).status,
            200);

  r = http.get("/v1/maps/town/vehicles");
  ASSERT_EQ(r.status, 200) << r.body;
  j = json::parse(r.body);
  EXPECT_EQ(j["timeout_s"], 60);
  ASSERT_EQ(j["vehicles"].size(), 2u);
  EXPECT_EQ(j["vehicles"][0]["id"], "car-1");
  EXPECT_EQ(j["vehicles"][1]["health"], "degraded");
  EXPECT_DOUBLE_EQ(j["vehicles"][1]["x"].get<double>(), 3.0);
  EXPECT_EQ(r.header("cache-control"), "no-store");
  EXPECT_EQ(json::parse(http.get("/v1/maps/town/vehicles").body)["map"], "town");
  EXPECT_NE(http.get("/metrics").body.find("route=\"/v1/maps/{map}/vehicles/{id}\""), std::string::npos);
  EXPECT_EQ(server.terminate(), 0);
}

TEST(ViewerRoutes, TheEventStreamSendsEachUpdateWhileTheServerServesAndEndsCleanlyOnStop) {
  ViewerMap f;
  ServerProcess server(f.db, {"--tokens", f.dir / "tokens.txt", "--event-streams", "2"});
  HttpClient http(server.url());
  ASSERT_EQ(http.request("POST", "/v1/maps/town/vehicles/early", R"({"x": 1, "y": 1, "health": "ok"})", bearer(kReportToken)).status, 200);

  RawConnection a(server.port());
  a.send_text("GET /v1/maps/town/events HTTP/1.1\r\nHost: 127.0.0.1\r\nAccept: text/event-stream\r\n\r\n");
  ASSERT_TRUE(a.read_contains("event: hello\n")) << a.received();
  const std::string header = a.received().substr(0, a.received().find("\r\n\r\n"));
  EXPECT_EQ(a.status(), 200);
  EXPECT_NE(header.find("Content-Type: text/event-stream"), std::string::npos) << header;
  EXPECT_NE(header.find("Cache-Control: no-store"), std::string::npos) << header;
  EXPECT_EQ(header.find("Content-Length"), std::string::npos) << header;  // the body ends with the connection
  EXPECT_NE(header.find("Connection: close"), std::string::npos) << header;
  // The vehicles heard from before the stream opened come first.
  ASSERT_TRUE(a.read_contains("\"id\":\"early\"")) << a.received();

  // While it is open the server serves everything else.
  EXPECT_EQ(http.get("/v1/maps").status, 200);
  ASSERT_EQ(http.request("POST", "/v1/maps/town/vehicles/car-9", R"({"x": 5, "y": 6, "yaw": 0.5, "health": "degraded"})",
                         bearer(kReportToken))
                .status,
            200);
  ASSERT_TRUE(a.read_contains("\"id\":\"car-9\"")) << a.received();
  const std::string& got = a.received();
  const auto at = got.rfind("event: vehicle\ndata: ", got.find("\"id\":\"car-9\""));
  ASSERT_NE(at, std::string::npos) << got;
  const std::string data = got.substr(at + 21, got.find('\n', at + 21) - (at + 21));
  const json event = json::parse(data);
  EXPECT_EQ(event["health"], "degraded");
  EXPECT_DOUBLE_EQ(event["x"].get<double>(), 5.0);

  // --event-streams 2: a third at once is refused; a stream's end frees its place.
  auto b = std::make_unique<RawConnection>(server.port());
  b->send_text("GET /v1/maps/town/events HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n");
  ASSERT_TRUE(b->read_contains("event: hello\n"));
  auto r = http.get("/v1/maps/town/events");
  expect_error(r, 503, "--event-streams");
  b.reset();  // the client leaves
  EXPECT_TRUE(pl::test::eventually([&] {
    RawConnection c(server.port());  // Connection: close: a 503 ends the connection at once
    c.send_text("GET /v1/maps/town/events HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\n\r\n");
    return c.read_contains("event: hello\n", 5);
  }));
  EXPECT_EQ(http.request("HEAD", "/v1/maps/town/events").status, 200);
  expect_error(http.get("/v1/maps/nowhere/events"), 404, "no map named");

  // SIGTERM with a stream open: the server ends it and exits 0.
  EXPECT_EQ(server.terminate(), 0) << server.output();
  EXPECT_TRUE(a.read_to_end(5));
}

TEST(ViewerRoutes, AVehicleSilentForTheTimeoutIsDroppedAndTheStreamSaysSo) {
  ViewerMap f;
  ServerProcess server(f.db, {"--tokens", f.dir / "tokens.txt", "--vehicle-timeout", "1"});
  HttpClient http(server.url());
  RawConnection a(server.port());
  a.send_text("GET /v1/maps/town/events HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n");
  ASSERT_TRUE(a.read_contains("\"timeout_s\":1.0"));
  ASSERT_EQ(http.request("POST", "/v1/maps/town/vehicles/quiet", R"({"x": 1, "y": 1, "health": "ok"})", bearer(kReportToken)).status, 200);
  ASSERT_TRUE(a.read_contains("\"id\":\"quiet\""));
  // Silent vehicles are dropped when the server next looks (a list, a report, a new stream).
  EXPECT_TRUE(pl::test::eventually([&] { return json::parse(http.get("/v1/maps/town/vehicles").body)["vehicles"].empty(); }));
  EXPECT_TRUE(a.read_contains("event: gone\ndata: {\"id\":\"quiet\"}"));
  EXPECT_EQ(server.terminate(), 0);
}
