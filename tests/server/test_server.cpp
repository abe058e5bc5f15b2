// The map service end to end: pl-map writes a real SQLite store from a PCD, a real pl-server serves it
// on 127.0.0.1, and the tests talk HTTP to it. Here: bad input and its statuses, health, readiness,
// metrics and the access log, and a graceful stop. Reads, uploads, places and tokens have files of
// their own (test_server_*.cpp).
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <unistd.h>

#include <cstdint>
#include <string>
#include <thread>

#include "pl/common/tile_codec.hpp"
#include "pl/schema/http_client.hpp"
#include "pl/schema/store.hpp"
#include "http_helpers.hpp"
#include "map_fixture.hpp"
#include "server_process.hpp"
#include "test_util.hpp"

namespace {

using pl::api::HttpClient;
using pl::test::ServerProcess;
using pl::test::kAdminToken;
using pl::test::kReadToken;
using pl::test::kUploadToken;
using pl::test::MapFixture;
using pl::test::bearer;
using pl::test::expect_error;

TEST(Server, BadInputGetsTheRightStatusAndAJsonError) {
  MapFixture f;
  ServerProcess server(f.db, f.token_args());
  HttpClient http(server.url());
  const auto expect = expect_error;
  expect(http.get("/v1/maps/town/roi?x=abc&y=0&radius=5"), 400, "x must be a number");
  expect(http.get("/v1/maps/town/roi?y=0&radius=5"), 400, "missing query parameter x");
  expect(http.get("/v1/maps/town/versions/zero/tiles/0/0"), 400, "version");
  expect(http.get("/v1/maps/town/versions/1/tiles/0/x"), 400, "tile index");
  expect(http.get("/v1/maps/nowhere"), 404, "no map named");
  expect(http.get("/v1/maps/town/versions/9/tiles/0/0"), 404, "no version 9");
  expect(http.get("/v1/maps/town/versions/1/tiles/300/300"), 404, "no tile 300/300");
  expect(http.get("/v1/nothing"), 404, "no such resource");
  expect(http.request("DELETE", "/v1/maps/town"), 405, "not allowed");
  expect(http.request("POST", "/v1/maps/town/versions"), 401, "upload role");
  expect(http.request("POST", "/v1/maps/town/versions", "", bearer("wrong")), 401, "unknown or revoked token");
  expect(http.request("POST", "/v1/maps/town/versions", "", bearer(kReadToken)), 403, "needs the upload role");
  expect(http.request("POST", "/v1/maps", R"({"name":"x","origin":{"lat":1,"lon":2}})", bearer(kUploadToken)), 403, "admin");
  expect(http.request("POST", "/v1/maps", "{not json", bearer(kAdminToken)), 400, "expected JSON");
  ASSERT_EQ(http.request("POST", "/v1/maps/town/versions", "", bearer(kUploadToken)).status, 201);
  expect(http.request("PUT", "/v1/maps/town/versions/2/tiles/0/0", "this is not draco", bearer(kUploadToken)), 422, "not a valid tile");
  pl::TileCloud off;
  off.points.emplace_back(55.0, 5.0, 0.0);  // belongs to tile 2/0
  expect(http.request("PUT", "/v1/maps/town/versions/2/tiles/0/0", pl::encode_tile(off), bearer(kUploadToken)), 422, "outside tile");
  std::string huge((64u << 20) + 1, 'x');
  auto big = http.request("PUT", "/v1/maps/town/versions/2/tiles/0/0", huge, bearer(kUploadToken));
  EXPECT_EQ(big.status, 413);
  // Admin creates a map; the name is taken the second time.
  std::string make = R"({"name":"depot","origin":{"lat":49.1,"lon":8.5,"alt":100},"tile_size":25,"voxel_size":0.2})";
  HttpClient admin(server.url());
  EXPECT_EQ(admin.request("POST", "/v1/maps", make, bearer(kAdminToken)).status, 201);
  expect(admin.request("POST", "/v1/maps", make, bearer(kAdminToken)), 409, "exists already");
  // Nothing crashed: the server still answers.
  EXPECT_EQ(HttpClient(server.url()).get("/healthz").status, 200);
}

TEST(Server, HealthReadinessMetricsAndAccessLog) {
  MapFixture f;
  ServerProcess server(f.db);
  HttpClient http(server.url());
  EXPECT_EQ(http.get("/healthz").body, "ok\n");
  EXPECT_EQ(http.get("/readyz").status, 200);
  http.get("/v1/maps/town/roi?x=0&y=0&radius=30");
  http.get("/v1/maps/nowhere");
  auto metrics = http.get("/metrics");
  ASSERT_EQ(metrics.status, 200);
  EXPECT_NE(metrics.body.find("pl_requests_total{route=\"/v1/maps/{map}/roi\",status=\"200\"} 1"), std::string::npos) << metrics.body;
  EXPECT_NE(metrics.body.find("pl_requests_total{route=\"/v1/maps/{map}\",status=\"404\"} 1"), std::string::npos) << metrics.body;
  EXPECT_NE(metrics.body.find("pl_request_duration_seconds_bucket{le=\"+Inf\"}"), std::string::npos);
  EXPECT_NE(metrics.body.find("pl_open_connections 1"), std::string::npos);
  EXPECT_NE(metrics.body.find("\npl_requests_in_progress 1\n"), std::string::npos) << metrics.body;  // the /metrics request
  EXPECT_NE(metrics.body.find("pl_database_bytes "), std::string::npos);
  EXPECT_EQ(server.terminate(), 0);
  const std::string& log = server.output();
  EXPECT_NE(log.find("\"GET /v1/maps/town/roi?x=0&y=0&radius=30\" 200"), std::string::npos) << log;
  EXPECT_NE(log.find("\"GET /v1/maps/nowhere\" 404"), std::string::npos) << log;
  EXPECT_NE(log.find("pl-server: stopped"), std::string::npos) << log;
}

TEST(Server, GracefulStopFinishesTheRequestInFlight) {
  MapFixture f;
  ServerProcess server(f.db, f.token_args());
  const auto connected = [&] {
    const int fd = socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_port = htons(static_cast<std::uint16_t>(server.port()));
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    EXPECT_EQ(connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)), 0);
    const timeval hang_guard{120, 0};  // a read that never ends fails the test instead of hanging it
    setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &hang_guard, sizeof hang_guard);
    return fd;
  };
  // A kept-alive connection, answered and now idle.
  const int idle = connected();
  const std::string healthz = "GET /healthz HTTP/1.1\r\nHost: t\r\n\r\n";
  ASSERT_EQ(write(idle, healthz.data(), healthz.size()), static_cast<ssize_t>(healthz.size()));
  char buf[4096];
  ssize_t n = read(idle, buf, sizeof(buf));
  ASSERT_GT(n, 0);
  ASSERT_EQ(std::string(buf, static_cast<std::size_t>(n)).rfind("HTTP/1.1 200", 0), 0u);
  // A request half sent when SIGTERM arrives.
  const int fd = connected();
  std::string body = R"({"note": "in flight"})";
  std::string head = "POST /v1/maps/town/versions HTTP/1.1\r\nHost: t\r\nAuthorization: Bearer " + kUploadToken +
                     "\r\nContent-Length: " + std::to_string(body.size()) + "\r\n\r\n" + body.substr(0, 5);
  ASSERT_EQ(write(fd, head.data(), head.size()), static_cast<ssize_t>(head.size()));
  // SIGTERM once the server has begun that request (its header read): two in progress with /metrics.
  HttpClient metrics(server.url());
  ASSERT_TRUE(pl::test::eventually(
      [&] { return metrics.get("/metrics").body.find("\npl_requests_in_progress 2\n") != std::string::npos; }, 120.0))
      << "the server never began the request (a hang guard, not a time bound)";
  std::thread stopper([&] { EXPECT_EQ(server.terminate(), 0); });
  // The stop lets the idle connection go at once, while the request in flight is still unanswered:
  // an idle connection does not hold the stop up.
  EXPECT_EQ(read(idle, buf, sizeof(buf)), 0) << "the idle connection was not closed by the stop";
  close(idle);
  std::string rest = body.substr(5);
  EXPECT_EQ(write(fd, rest.data(), rest.size()), static_cast<ssize_t>(rest.size()));  // not ASSERT: the stopper is to be joined
  std::string answer;
  while ((n = read(fd, buf, sizeof(buf))) > 0) answer.append(buf, static_cast<std::size_t>(n));
  close(fd);
  stopper.join();
  EXPECT_EQ(answer.rfind("HTTP/1.1 201", 0), 0u) << answer;
  EXPECT_NE(answer.find("Connection: close"), std::string::npos) << answer;
  pl::store::Store store = pl::store::Store::open(f.db, false);
  EXPECT_TRUE(store.find_version("town", 2).has_value());
}

}  // namespace
