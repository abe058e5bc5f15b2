// pl-server against what an attacker, a proxy or a careless client sends: each class of finding of
// the fuzzing issue against the real pl-server process (and the server still answering /healthz
// after it), HTTP as proxies and clients expect it, and a storm of random and malformed requests.
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>
#include <zlib.h>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>
#include <thread>

#include "map_fixture.hpp"
#include "pl/schema/http_client.hpp"
#include "pl/common/text.hpp"
#include "pl/common/tile_codec.hpp"
#include "pl/schema/store.hpp"
#include "server_process.hpp"
#include "test_util.hpp"

using nlohmann::json;
using pl::api::HttpClient;
using pl::test::MapFixture;
using pl::test::ServerProcess;

namespace {

// Sends bytes on a fresh connection to 127.0.0.1 (or ::1), half-closes when asked, and reads until
// the server closes or `timeout_s` passes. Returns what came back; *timed_out says whether the
// server neither answered in full nor closed in time.
std::string exchange(int port, const std::string& bytes, bool half_close, double timeout_s = 10.0, bool* timed_out = nullptr,
                     bool ipv6 = false) {
  int fd = socket(ipv6 ? AF_INET6 : AF_INET, SOCK_STREAM, 0);
  if (fd < 0) throw std::runtime_error("socket");
  int rc;
  if (ipv6) {
    sockaddr_in6 a{};
    a.sin6_family = AF_INET6;
    a.sin6_port = htons(static_cast<uint16_t>(port));
    a.sin6_addr = in6addr_loopback;
    rc = connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof(a));
  } else {
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_port = htons(static_cast<uint16_t>(port));
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    rc = connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof(a));
  }
  if (rc != 0) {
    close(fd);
    throw std::runtime_error("connect failed");
  }
  std::size_t sent = 0;
  while (sent < bytes.size()) {
    ssize_t n = send(fd, bytes.data() + sent, bytes.size() - sent, MSG_NOSIGNAL);
    if (n <= 0) break;  // the server may close early (a 431 before the rest arrives): fine
    sent += static_cast<std::size_t>(n);
  }
  if (half_close) shutdown(fd, SHUT_WR);
  std::string out;
  auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  bool expired = true;
  while (std::chrono::steady_clock::now() < deadline) {
    pollfd p{fd, POLLIN, 0};
    if (poll(&p, 1, 100) <= 0) continue;
    char buf[16384];
    ssize_t n = recv(fd, buf, sizeof(buf), 0);
    if (n <= 0) {
      expired = false;
      break;
    }
    out.append(buf, static_cast<std::size_t>(n));
  }
  close(fd);
  if (timed_out) *timed_out = expired;
  return out;
}

// The status and header block of the first response in `raw`.
int status_of(const std::string& raw) { return raw.rfind("HTTP/1.1 ", 0) == 0 ? std::atoi(raw.c_str() + 9) : 0; }
std::string header_of(const std::string& raw, const std::string& name) {
  std::string head = raw.substr(0, raw.find("\r\n\r\n"));
  std::string lower = head;
  for (auto& c : lower) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  std::string key = "\r\n" + name + ":";
  for (auto& c : key) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  auto at = lower.find(key);
  if (at == std::string::npos) return {};
  auto start = at + key.size(), end = head.find("\r\n", start);
  std::string v = head.substr(start, end == std::string::npos ? std::string::npos : end - start);
  while (!v.empty() && v.front() == ' ') v.erase(0, 1);
  return v;
}
std::string body_of(const std::string& raw) {
  auto at = raw.find("\r\n\r\n");
  return at == std::string::npos ? std::string() : raw.substr(at + 4);
}

void expect_healthy(ServerProcess& server) {
  ASSERT_TRUE(server.alive()) << server.output();
  HttpClient http(server.url(), 5.0);
  auto r = http.get("/healthz");
  EXPECT_EQ(r.status, 200);
  EXPECT_EQ(r.body, "ok\n");
}

std::string gunzip(const std::string& in) {
  z_stream z{};
  EXPECT_EQ(inflateInit2(&z, 15 + 16), Z_OK);
  std::string out(1 << 20, '\0');
  z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(in.data()));
  z.avail_in = static_cast<uInt>(in.size());
  z.next_out = reinterpret_cast<Bytef*>(out.data());
  z.avail_out = static_cast<uInt>(out.size());
  int rc = inflate(&z, Z_FINISH);
  out.resize(out.size() - z.avail_out);
  inflateEnd(&z);
  EXPECT_EQ(rc, Z_STREAM_END);
  return out;
}

std::string read_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

}  // namespace

// Class 1: anything echoed into JSON. The request that killed the server: invalid UTF-8 in the
// target, raw and percent-encoded, in every route that names what it did not find.
TEST(ServerHardening, InvalidUtf8InTheRequestIsAnsweredWithValidJsonAndTheServerGoesOn) {
  MapFixture f;
  ServerProcess server(f.db, f.token_args());
  for (const std::string target : {"/v1/maps/\xff\xfe", "/v1/maps/%FF%FE", "/v1/maps/town/versions/\xc3\x28/tiles",
                                   "/v1/maps/town/roi?x=\xff&y=1&radius=2", "/\xed\xa0\x80"}) {
    std::string raw = exchange(server.port(), "GET " + target + " HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n", false);
    ASSERT_NE(status_of(raw), 0) << "no answer to " << pl::printable(target);
    EXPECT_GE(status_of(raw), 400);
    json j = json::parse(body_of(raw));  // throws on invalid UTF-8: what crashed the server
    EXPECT_TRUE(j["error"].is_string());
  }
  // Invalid UTF-8 in a JSON body the server parses and quotes in its error.
  HttpClient http(server.url());
  auto r = http.request("POST", "/v1/maps", "{\"name\": \"\xff\xfe\"}", {{"Authorization", "Bearer " + pl::test::kAdminToken}});
  EXPECT_EQ(r.status, 400);
  EXPECT_TRUE(json::accept(r.body)) << r.body;
  expect_healthy(server);
}

// Class 1, the rest of it: a failure nobody expected (here the store loses a table under the
// running server) is a 500 for that request, logged with its request id, and the server goes on.
TEST(ServerHardening, AnUnexpectedFailureIsA500WithARequestIdAndTheServerGoesOn) {
  MapFixture f;
  ServerProcess server(f.db, f.token_args());
  // Damage the store under the running server, as an operator's mistake would: drop a table.
  auto r = pl::test::run("python3 -c \"import sqlite3; c = sqlite3.connect('" + f.db +
                         "'); c.execute('PRAGMA foreign_keys=OFF'); c.execute('DROP TABLE tiles'); c.commit()\"");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  std::string raw = exchange(server.port(), "GET /v1/maps/town/versions/1/tiles HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n", false);
  EXPECT_EQ(status_of(raw), 500) << raw;
  std::string id = header_of(raw, "X-Request-Id");
  ASSERT_FALSE(id.empty());
  EXPECT_NE(body_of(raw).find(id), std::string::npos) << raw;
  EXPECT_TRUE(json::accept(body_of(raw))) << raw;
  expect_healthy(server);
  EXPECT_NE(server.output().find("request " + id), std::string::npos) << server.output();
}

// Class 2: Draco streams that ask for gigabytes. Every bomb the fuzzers and the attacker found,
// uploaded as a tile: refused with 422, the server's peak memory stays small, and it goes on.
TEST(ServerHardening, DracoMemoryBombsAreRefusedWithoutTheMemory) {
  MapFixture f;
  // ASan's quarantine holds freed memory for a while: keep it small so that the peak says what
  // the server allocated.
  ServerProcess server(f.db, f.token_args(), {{"ASAN_OPTIONS", "quarantine_size_mb=16:detect_leaks=0"}});
  HttpClient http(server.url(), 60.0);
  auto auth = std::map<std::string, std::string>{{"Authorization", "Bearer " + pl::test::kUploadToken}};
  auto v = http.request("POST", "/v1/maps/town/versions", "", auth);
  ASSERT_EQ(v.status, 201) << v.body;
  const std::string version = std::to_string(json::parse(v.body)["version"].get<int>());
  int bombs = 0;
  for (const auto& e : std::filesystem::directory_iterator(std::string(PL_SOURCE_DIR) + "/tests/fuzz/regressions/tile")) {
    auto r = http.request("PUT", "/v1/maps/town/versions/" + version + "/tiles/0/0", read_bytes(e.path().string()), auth);
    EXPECT_EQ(r.status, 422) << e.path() << ": " << r.body;
    ++bombs;
  }
  EXPECT_GE(bombs, 5);
  long peak_kb = server.status_kb("VmHWM");
  EXPECT_GT(peak_kb, 0);
  EXPECT_LT(peak_kb, 1024 * 1024) << "the server's peak memory passed 1 GiB";
  expect_healthy(server);
}

// HTTP as proxies and clients expect it.
TEST(ServerHardening, HttpAsProxiesAndClientsExpectIt) {
  MapFixture f;
  ServerProcess server(f.db, f.token_args(), {}, "localhost:0");
  auto ask = [&](const std::string& request) { return exchange(server.port(), request, false); };
  // 405 carries Allow; PATCH /healthz is not 200.
  std::string r = ask("PATCH /healthz HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n");
  EXPECT_EQ(status_of(r), 405);
  EXPECT_EQ(header_of(r, "Allow"), "GET, HEAD, OPTIONS");
  r = ask("DELETE /v1/maps/town HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n");
  EXPECT_EQ(status_of(r), 405);
  EXPECT_EQ(header_of(r, "Allow"), "GET, HEAD, OPTIONS");
  r = ask("OPTIONS /v1/maps/town/versions/1/tiles/0/0 HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n");
  EXPECT_EQ(status_of(r), 204);
  EXPECT_EQ(header_of(r, "Allow"), "GET, HEAD, PUT, DELETE, OPTIONS");
  r = ask("OPTIONS /v1/maps/town/versions/1/places HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n");
  EXPECT_EQ(status_of(r), 204);
  EXPECT_EQ(header_of(r, "Allow"), "GET, HEAD, PUT, DELETE, OPTIONS");
  // 401 carries WWW-Authenticate: Bearer (and says when a token was refused).
  r = ask("POST /v1/maps/town/versions HTTP/1.1\r\nHost: x\r\nContent-Length: 0\r\nConnection: close\r\n\r\n");
  EXPECT_EQ(status_of(r), 401);
  EXPECT_EQ(header_of(r, "WWW-Authenticate").rfind("Bearer", 0), 0u) << r;
  r = ask("POST /v1/maps/town/versions HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer wrong\r\nContent-Length: 0\r\nConnection: close\r\n\r\n");
  EXPECT_EQ(status_of(r), 401);
  EXPECT_NE(header_of(r, "WWW-Authenticate").find("invalid_token"), std::string::npos) << r;
  // Every response has Date, errors and tiles included.
  for (const std::string target : {"/healthz", "/v1/maps/town", "/v1/maps/nope", "/v1/maps/town/versions/1/tiles/0/0"}) {
    r = ask("GET " + target + " HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n");
    EXPECT_NE(status_of(r), 0);
    EXPECT_NE(header_of(r, "Date").find(" GMT"), std::string::npos) << target << ": " << r.substr(0, 300);
  }
  // HEAD works on every GET resource: the GET's status and Content-Length, no body.
  for (const std::string target : {"/healthz", "/readyz", "/metrics", "/v1/maps", "/v1/maps/town", "/v1/maps/town/roi?x=0&y=0&radius=30",
                                   "/v1/maps/town/versions/1/tiles", "/v1/maps/town/versions/1/tiles/0/0"}) {
    std::string get = ask("GET " + target + " HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n");
    std::string head = ask("HEAD " + target + " HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n");
    EXPECT_EQ(status_of(head), status_of(get)) << target;
    EXPECT_EQ(status_of(head), 200) << target;
    if (target != "/metrics") {  // (the metrics count the GET itself)
      EXPECT_EQ(header_of(head, "Content-Length"), std::to_string(body_of(get).size())) << target;
    }
    EXPECT_EQ(body_of(head), "") << target;
  }
  // JSON answers are gzip-compressed when the client accepts it, and only then.
  std::string plain = ask("GET /v1/maps/town/roi?x=0&y=0&radius=60 HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n");
  std::string zipped =
      ask("GET /v1/maps/town/roi?x=0&y=0&radius=60 HTTP/1.1\r\nHost: x\r\nAccept-Encoding: br, gzip;q=0.8\r\nConnection: close\r\n\r\n");
  std::string refused =
      ask("GET /v1/maps/town/roi?x=0&y=0&radius=60 HTTP/1.1\r\nHost: x\r\nAccept-Encoding: gzip;q=0, br\r\nConnection: close\r\n\r\n");
  EXPECT_EQ(header_of(plain, "Content-Encoding"), "");
  EXPECT_EQ(header_of(refused, "Content-Encoding"), "");
  ASSERT_EQ(header_of(zipped, "Content-Encoding"), "gzip") << zipped.substr(0, 400);
  EXPECT_EQ(header_of(zipped, "Vary"), "Accept-Encoding");
  EXPECT_LT(body_of(zipped).size(), body_of(plain).size());
  EXPECT_EQ(gunzip(body_of(zipped)), body_of(plain));
  // --listen took a host name: it listens on 127.0.0.1 (what localhost resolves to here).
  EXPECT_NE(server.output().find("listening on http://localhost:"), std::string::npos) << server.output();
}

TEST(ServerHardening, ListensOnIpv6) {
  int probe = socket(AF_INET6, SOCK_STREAM, 0);
  sockaddr_in6 a{};
  a.sin6_family = AF_INET6;
  a.sin6_addr = in6addr_loopback;
  bool have_v6 = probe >= 0 && bind(probe, reinterpret_cast<sockaddr*>(&a), sizeof(a)) == 0;
  if (probe >= 0) close(probe);
  if (!have_v6) GTEST_SKIP() << "this machine has no IPv6 loopback";
  MapFixture f;
  ServerProcess server(f.db, f.token_args(), {}, "[::1]:0");
  EXPECT_NE(server.output().find("listening on http://[::1]:"), std::string::npos) << server.output();
  std::string r = exchange(server.port(), "GET /healthz HTTP/1.1\r\nHost: [::1]\r\nConnection: close\r\n\r\n", false, 10.0, nullptr, true);
  EXPECT_EQ(status_of(r), 200) << r;
  EXPECT_EQ(body_of(r), "ok\n");
  // The HTTP client takes the address in brackets, as URLs write it.
  HttpClient http("http://[::1]:" + std::to_string(server.port()));
  EXPECT_EQ(http.get("/healthz").status, 200);
  // A bare IPv6 address without brackets is refused with the syntax to use.
  auto bad = pl::test::run(pl::test::tool("pl-server") + " --db " + f.db + " --listen ::1:0");
  EXPECT_NE(bad.exit_code, 0);
  EXPECT_NE(bad.output.find("[::1]:8080"), std::string::npos) << bad.output;
}

// 10,000 random and malformed requests: every one answered or closed (none left hanging), the
// server alive and answering, and its memory flat between the first 2,000 and the last.
TEST(ServerHardening, TenThousandRandomAndMalformedRequests) {
  MapFixture f;
  // A small ASan quarantine, so that freed memory does not read as growth.
  ServerProcess server(f.db, f.token_args(), {{"ASAN_OPTIONS", "quarantine_size_mb=8:detect_leaks=0"}});
  const std::string hash = [&] {
    HttpClient http(server.url());
    return json::parse(http.get("/v1/maps/town/roi?x=0&y=0&radius=10").body)["tiles"][0]["hash"].get<std::string>();
  }();
  const std::vector<std::string> methods = {"GET", "HEAD", "PUT", "POST", "DELETE", "OPTIONS", "PATCH", "TRACE", "CONNECT", "G\x01T", ""};
  const std::vector<std::string> targets = {
      "/healthz", "/readyz", "/metrics", "/v1/maps", "/v1/maps/town", "/v1/maps/town/roi?x=0&y=0&radius=50",
      "/v1/maps/town/roi?x=1e308&y=-1e308&radius=5000", "/v1/maps/town/roi?x=nan&y=0&radius=1", "/v1/maps/town/roi?have=" + hash,
      "/v1/maps/town/versions/1/tiles", "/v1/maps/town/versions/1/tiles/0/0", "/v1/maps/town/versions/99999999999999999999/tiles/0/0",
      "/v1/maps/town/versions/1/tiles/2147483648/-2147483649", "/v1/blobs/" + hash, "/v1/blobs/" + std::string(64, 'g'),
      "/v1/maps/%", "/v1/maps/%G0", "/v1/maps/town/versions/1/publish", "/v1/maps/town/versions/1/places",
      "/../../etc/passwd", "*", "http://evil/v1/maps",
      "/v1/maps/" + std::string(3000, 'a'), "/v1//maps///town", "/v1/maps/town/roi?x=1&x=2&&&=&y", "/\xff\xfe\xfd"};
  const std::vector<std::string> headers = {
      "Authorization: Bearer " + pl::test::kUploadToken, "Authorization: Bearer \xff", "Authorization: Basic Zm9vOmJhcg==",
      "Accept-Encoding: gzip", "Accept-Encoding: gzip;q=0.0001, *;q=0", "If-None-Match: \"" + hash + "\"", "If-None-Match: *",
      "Content-Length: 5", "Content-Length: -1", "Content-Length: 99999999999999999999", "Content-Length: 1, 2",
      "Transfer-Encoding: chunked", "Transfer-Encoding: gzip, chunked", "Expect: 100-continue", "Connection: keep-alive",
      "X: " + std::string(9000, 'x'), "Bad Header: x", ": empty", "Host:", "X-Request-Id: \r\n injected"};
  std::atomic<long> answered{0}, closed{0}, hung{0};
  long rss_early = 0;
  std::atomic<long> done{0};
  auto worker = [&](int seed, int count) {
    std::mt19937 rng(seed);
    auto pick = [&](const auto& v) { return v[std::uniform_int_distribution<std::size_t>(0, v.size() - 1)(rng)]; };
    auto random_bytes = [&](std::size_t n) {
      std::string s(n, '\0');
      for (auto& c : s) c = static_cast<char>(rng());
      return s;
    };
    for (int i = 0; i < count; ++i) {
      std::string req;
      switch (rng() % 6) {
        case 0:  // bytes
          req = random_bytes(rng() % 600);
          break;
        case 1: {  // a request line with random bytes in the target
          req = pick(methods) + " /v1/maps/" + random_bytes(rng() % 40) + " HTTP/1.1\r\nHost: x\r\n\r\n";
          break;
        }
        case 2: {  // a plausible request with a mix of odd headers and a random body
          std::string body = random_bytes(rng() % 300);
          req = pick(methods) + " " + pick(targets) + " HTTP/1.1\r\nHost: 127.0.0.1\r\n";
          for (int h = static_cast<int>(rng() % 4); h > 0; --h) req += pick(headers) + "\r\n";
          if (rng() % 2) req += "Content-Length: " + std::to_string(body.size()) + "\r\n";
          req += "\r\n" + body;
          break;
        }
        case 3: {  // a valid request, then the bytes of it mutated
          req = "GET " + pick(targets) + " HTTP/1.1\r\nHost: x\r\nAccept-Encoding: gzip\r\n\r\n";
          for (int m = 1 + static_cast<int>(rng() % 4); m > 0; --m) req[rng() % req.size()] = static_cast<char>(rng());
          break;
        }
        case 4: {  // pipelined requests, the last one cut short
          for (int k = 1 + static_cast<int>(rng() % 4); k > 0; --k) req += "GET " + pick(targets) + " HTTP/1.1\r\nHost: x\r\n\r\n";
          req += "PUT /v1/maps/town/versions/1/tiles/0/0 HTTP/1.1\r\nContent-Length: 1000\r\n\r\nDRACO";
          break;
        }
        default: {  // a chunked body with broken framing
          req = "POST /v1/maps HTTP/1.1\r\nHost: x\r\nTransfer-Encoding: chunked\r\nAuthorization: Bearer " + pl::test::kAdminToken +
                "\r\n\r\n" + pick(std::vector<std::string>{"ffffffffffffffff\r\n", "5\r\nabc", "3;ext=\xff\r\nabc\r\n0\r\n\r\n", "zz\r\n"});
          break;
        }
      }
      bool timed_out = false;
      std::string out = exchange(server.port(), req, true, 15.0, &timed_out);
      if (timed_out)
        ++hung;
      else if (status_of(out) != 0)
        ++answered;
      else
        ++closed;
      if (++done == 2000) rss_early = server.status_kb("VmRSS");
    }
  };
  std::vector<std::thread> pool;
  for (int t = 0; t < 4; ++t) pool.emplace_back(worker, 1000 + t, 2500);
  for (auto& t : pool) t.join();
  long rss_late = server.status_kb("VmRSS");
  EXPECT_EQ(answered + closed + hung, 10000);
  EXPECT_EQ(hung, 0) << "requests neither answered nor closed within 15 s";
  EXPECT_GT(answered, 5000);
  std::printf("10000 requests: %ld answered, %ld closed without an answer; server RSS %ld kB after 2000, %ld kB after 10000\n",
              answered.load(), closed.load(), rss_early, rss_late);
  EXPECT_GT(rss_early, 0);
  EXPECT_LT(rss_late - rss_early, 64 * 1024) << "memory grew by more than 64 MiB over 8000 requests";
  expect_healthy(server);
}

// Clients that hang up while their tiles are being sent (a vehicle losing its cellular link; wrk at
// the end of every run): the write fails for that connection only. Tile bodies go out with
// sendfile(2), which raised SIGPIPE and ended the whole server until the server ignored it.
TEST(ServerHardening, ClientsHangingUpMidAnswerDoNotStopTheServer) {
  MapFixture f;
  {
    // A tile of 8 MB (the server sends stored bytes as they are): more than one sendfile call's worth.
    auto store = pl::store::Store::open(f.db, false);
    auto v = store.create_version("town", std::nullopt, "a large tile");
    std::string big(8u << 20, '\0');
    std::mt19937 rng(7);
    for (auto& c : big) c = static_cast<char>(rng());
    store.put_tile("town", v.number, pl::TileKey{100, 100}, big, 1, 2000, 2000, 0, 2001, 2001, 1);
    store.publish("town", v.number);
  }
  ServerProcess server(f.db);
  const std::string request = "GET /v1/maps/town/versions/2/tiles/100/100 HTTP/1.1\r\nHost: x\r\n\r\n";
  for (int round = 0; round < 20; ++round) {
    int fd = socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_port = htons(static_cast<std::uint16_t>(server.port()));
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    ASSERT_EQ(connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof(a)), 0);
    ASSERT_EQ(send(fd, request.data(), request.size(), MSG_NOSIGNAL), static_cast<ssize_t>(request.size()));
    if (round % 2) {
      char first;
      recv(fd, &first, 1, 0);  // the answer has begun
    }
    // Closed unread: this side resets the connection at the answer's next bytes, and the server's
    // write after that fails.
    close(fd);
    ASSERT_TRUE(server.alive()) << "round " << round << ": " << server.output();
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  expect_healthy(server);
}

// Answers go out with one sendmsg(2) of header and body when the socket takes them, and the rest
// asynchronously when it does not. A client that pipelines 42 requests (about 6 MB of answers, more
// than the server's socket buffer), reads nothing for a while, then reads slowly through a small
// receive buffer gets every byte of each answer in order, on the one kept-alive connection: tiles
// sent from memory (60 KB) and with sendfile(2) (1 MB), a HEAD answer with the length and no body,
// and a JSON answer.
TEST(ServerHardening, AnswersLargerThanTheSocketTakesArriveWholeOnAKeptAliveConnection) {
  MapFixture f;
  std::string mid(60u << 10, '\0'), big(1u << 20, '\0');
  {
    auto store = pl::store::Store::open(f.db, false);
    auto v = store.create_version("town", std::nullopt, "tiles of 60 KB and 1 MB");
    std::mt19937 rng(11);
    for (auto& c : mid) c = static_cast<char>(rng());
    for (auto& c : big) c = static_cast<char>(rng());
    store.put_tile("town", v.number, pl::TileKey{100, 100}, mid, 1, 2000, 2000, 0, 2001, 2001, 1);
    store.put_tile("town", v.number, pl::TileKey{101, 100}, big, 1, 2020, 2000, 0, 2021, 2001, 1);
    store.publish("town", v.number);
  }
  ServerProcess server(f.db);
  int fd = socket(AF_INET, SOCK_STREAM, 0);
  ASSERT_GE(fd, 0);
  int small = 4096;  // the kernel doubles it
  ASSERT_EQ(setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &small, sizeof(small)), 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(static_cast<std::uint16_t>(server.port()));
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  ASSERT_EQ(connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof(a)), 0);
  struct Asked {
    std::string method, target;
    const std::string* expect;  // the body expected (nullptr: checked apart)
  };
  std::vector<Asked> asked;
  // The large tiles first: they fill the server's socket buffer (4 MB at most here), so that the
  // answers from memory after them meet a full one.
  for (int i = 0; i < 4; ++i) asked.push_back({"GET", "/v1/maps/town/versions/2/tiles/101/100", &big});
  for (int i = 0; i < 36; ++i) asked.push_back({"GET", "/v1/maps/town/versions/2/tiles/100/100", &mid});
  asked.push_back({"HEAD", "/v1/maps/town/versions/2/tiles/100/100", nullptr});
  asked.push_back({"GET", "/v1/maps/town", nullptr});
  std::string requests;
  for (const auto& q : asked) requests += q.method + " " + q.target + " HTTP/1.1\r\nHost: x\r\n\r\n";
  ASSERT_EQ(send(fd, requests.data(), requests.size(), MSG_NOSIGNAL), static_cast<ssize_t>(requests.size()));
  std::this_thread::sleep_for(std::chrono::milliseconds(300));  // the server meets a full socket
  std::string in;
  std::size_t at = 0;  // where the next answer starts in `in`
  auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  for (std::size_t k = 0; k < asked.size(); ++k) {
    std::string head;
    std::size_t need = std::string::npos;
    while (need == std::string::npos || in.size() < need) {
      if (need == std::string::npos) {
        auto end = in.find("\r\n\r\n", at);
        if (end != std::string::npos) {
          head = in.substr(at, end + 4 - at);
          need = end + 4 + (asked[k].method == "HEAD" ? 0 : std::stoul(header_of(head, "Content-Length")));
          continue;
        }
      }
      ASSERT_LT(std::chrono::steady_clock::now(), deadline) << "answer " << k << ": " << in.size() - at << " bytes after 60 s";
      pollfd p{fd, POLLIN, 0};
      if (poll(&p, 1, 100) <= 0) continue;
      char buf[16384];
      ssize_t n = recv(fd, buf, sizeof(buf), 0);
      ASSERT_GT(n, 0) << "answer " << k << ": the server closed the connection";
      in.append(buf, static_cast<std::size_t>(n));
    }
    const std::string body = in.substr(at + head.size(), need - at - head.size());
    at = need;
    ASSERT_EQ(status_of(head), 200) << "answer " << k << ": " << head;
    if (asked[k].expect) {
      EXPECT_TRUE(body == *asked[k].expect) << "answer " << k << ": " << body.size() << " bytes, not the tile's";
    } else if (asked[k].method == "HEAD") {
      EXPECT_EQ(header_of(head, "Content-Length"), std::to_string(mid.size()));
    } else {
      EXPECT_EQ(json::parse(body).value("name", ""), "town") << body;
    }
  }
  // Nothing beyond the last answer.
  pollfd p{fd, POLLIN, 0};
  if (poll(&p, 1, 200) > 0) {
    char c;
    EXPECT_LE(recv(fd, &c, 1, MSG_DONTWAIT), 0) << "bytes beyond the last answer";
  }
  EXPECT_EQ(in.size(), at);
  close(fd);
  expect_healthy(server);
}
