// HTTPS as a fleet runs it: a CA made here, deploy/nginx/pointlocalization.conf terminating TLS in
// a real nginx on loopback in front of a real pl-server, and the real HTTP and tile clients talking
// to it, trusting only that CA. Also: plain HTTP refused where it would cross a network, and
// uploads over plain HTTP refused from other machines.
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <nlohmann/json.hpp>
#include <thread>

#include "pl/client/tile_client.hpp"
#include "pl/common/error.hpp"
#include "pl/schema/http_client.hpp"
#include "pl/schema/store.hpp"
#include "pl/server/api.hpp"
#include "map_fixture.hpp"
#include "server_process.hpp"
#include "test_util.hpp"

using nlohmann::json;
using pl::api::HttpClient;
using pl::api::HttpOptions;
using pl::test::MapFixture;
using pl::test::ServerProcess;
using pl::test::TempDir;

namespace {

std::string sh_quote(const std::string& s) { return "'" + s + "'"; }

void must_run(const std::string& cmd) {
  auto r = pl::test::run(cmd + " 2>&1");
  if (r.exit_code != 0) throw std::runtime_error(cmd + " failed: " + r.output);
}

// A CA (key and self-signed certificate) in DIR/NAME.key and DIR/NAME.pem, and a server
// certificate it signs for `dns_name` only (DIR/NAME-server.pem, .key). With the openssl tool.
struct Pki {
  std::string ca, server_cert, server_key;
};
Pki make_pki(const std::string& dir, const std::string& name, const std::string& dns_name) {
  if (pl::test::run("command -v openssl").exit_code != 0)
    throw std::runtime_error("the openssl tool is missing: apt-get install openssl (./pl test installs it)");
  Pki p{dir + "/" + name + ".pem", dir + "/" + name + "-server.pem", dir + "/" + name + "-server.key"};
  const std::string ca_key = dir + "/" + name + ".key", csr = dir + "/" + name + ".csr", ext = dir + "/" + name + ".ext";
  must_run("openssl req -x509 -newkey ec -pkeyopt ec_paramgen_curve:P-256 -nodes -days 2 -subj '/CN=" + name + " fleet CA'" +
           " -addext basicConstraints=critical,CA:TRUE -addext keyUsage=critical,keyCertSign,cRLSign -keyout " + sh_quote(ca_key) +
           " -out " + sh_quote(p.ca));
  must_run("openssl req -newkey ec -pkeyopt ec_paramgen_curve:P-256 -nodes -subj '/CN=" + dns_name + "' -keyout " +
           sh_quote(p.server_key) + " -out " + sh_quote(csr));
  pl::test::write_file(ext, "subjectAltName=DNS:" + dns_name +
                                "\nbasicConstraints=CA:FALSE\nkeyUsage=digitalSignature\nextendedKeyUsage=serverAuth\n");
  must_run("openssl x509 -req -days 2 -in " + sh_quote(csr) + " -CA " + sh_quote(p.ca) + " -CAkey " + sh_quote(ca_key) +
           " -CAcreateserial -extfile " + sh_quote(ext) + " -out " + sh_quote(p.server_cert));
  return p;
}

bool port_open(int port) {
  int fd = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(static_cast<std::uint16_t>(port));
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  const bool ok = connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof(a)) == 0;
  close(fd);
  return ok;
}

// nginx in the foreground with deploy/nginx/pointlocalization.conf filled in, on a free loopback port.
class Nginx {
 public:
  Nginx(const std::string& dir, const Pki& pki, int origin_port) : dir_(dir), port_(pl::test::free_port()) {
    const std::string nginx = "/usr/sbin/nginx";
    if (access(nginx.c_str(), X_OK) != 0)
      throw std::runtime_error(nginx + " is missing: apt-get install nginx-light (./pl test installs it)");
    std::string site = pl::test::read_file(std::string(PL_SOURCE_DIR) + "/deploy/nginx/pointlocalization.conf");
    auto fill = [&](const std::string& name, const std::string& value) {
      for (auto at = site.find(name); at != std::string::npos; at = site.find(name)) site.replace(at, name.size(), value);
    };
    fill("@LISTEN@", "127.0.0.1:" + std::to_string(port_));
    fill("@CERT@", pki.server_cert);
    fill("@KEY@", pki.server_key);
    fill("@ORIGINS@", "server 127.0.0.1:" + std::to_string(origin_port) + ";");
    pl::test::write_file(dir_ + "/site.conf", site);
    mkdir((dir_ + "/tmp").c_str(), 0777);
    chmod((dir_ + "/tmp").c_str(), 0777);  // nginx's workers run as nobody when it starts as root
    pl::test::write_file(dir_ + "/nginx.conf",
                         "daemon off;\nworker_processes 1;\npid " + dir_ + "/nginx.pid;\nerror_log " + dir_ +
                             "/error.log;\nevents { worker_connections 256; }\nhttp {\n  access_log off;\n"
                             "  client_body_temp_path " + dir_ + "/tmp/body;\n  proxy_temp_path " + dir_ + "/tmp/proxy;\n"
                             "  include " + dir_ + "/site.conf;\n}\n");
    must_run(nginx + " -t -q -p " + sh_quote(dir_) + " -c " + sh_quote(dir_ + "/nginx.conf"));
    pid_ = fork();
    if (pid_ == 0) {
      execl(nginx.c_str(), nginx.c_str(), "-p", dir_.c_str(), "-c", (dir_ + "/nginx.conf").c_str(), static_cast<char*>(nullptr));
      _exit(127);
    }
    for (int i = 0; i < 100 && !port_open(port_); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(50));
    if (!port_open(port_)) throw std::runtime_error("nginx did not start: " + pl::test::read_file(dir_ + "/error.log"));
  }
  ~Nginx() {
    kill(pid_, SIGTERM);
    waitpid(pid_, nullptr, 0);
  }
  int port() const { return port_; }

 private:
  std::string dir_;
  int port_;
  pid_t pid_ = -1;
};

std::string message_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const std::exception& e) {
    return e.what();
  }
  return "";
}

bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

// The map service behind TLS, and a second CA that signed nothing of it.
struct TlsFixture {
  MapFixture map;
  TempDir dir;
  Pki fleet = make_pki(dir.path(), "fleet", "localhost");
  Pki other = make_pki(dir.path(), "other", "localhost");
  ServerProcess server{map.db, map.token_args()};
  Nginx nginx{dir.path(), fleet, server.port()};

  std::string https(const std::string& host = "localhost") const { return "https://" + host + ":" + std::to_string(nginx.port()); }
  HttpOptions trusting(const Pki& p) const {
    HttpOptions o;
    o.ca_file = p.ca;
    return o;
  }
};

}  // namespace

TEST(Tls, TheFleetsCaReachesTheMapServiceForReadsAndUploads) {
  TlsFixture f;
  HttpClient http(f.https(), f.trusting(f.fleet));
  EXPECT_TRUE(http.tls());
  auto manifest = http.get("/v1/maps/town");
  ASSERT_EQ(manifest.status, 200) << manifest.body;
  EXPECT_EQ(json::parse(manifest.body)["current_version"], 1);
  // Through the proxy, pl-server sees this machine: an upload over HTTPS is taken.
  auto opened = http.request("POST", "/v1/maps/town/versions", "", {{"Authorization", "Bearer " + pl::test::kUploadToken}});
  EXPECT_EQ(opened.status, 201) << opened.body;
  // The connection is kept alive across requests (one handshake).
  EXPECT_EQ(http.get("/healthz").status, 200);
}

TEST(Tls, ACertificateFromAnotherCaOrForAnotherNameIsRefused) {
  TlsFixture f;
  const std::string other_ca = message_of([&] { HttpClient(f.https(), f.trusting(f.other)).get("/healthz"); });
  EXPECT_TRUE(contains(other_ca, "not trusted")) << other_ca;
  EXPECT_TRUE(contains(other_ca, "--ca-file")) << other_ca;
  // The certificate names localhost only: 127.0.0.1 is another name, refused though the CA signed it.
  const std::string other_name = message_of([&] { HttpClient(f.https("127.0.0.1"), f.trusting(f.fleet)).get("/healthz"); });
  EXPECT_TRUE(contains(other_name, "not trusted")) << other_name;
  // No CA file: the system's CAs, which did not sign the fleet's certificate.
  const std::string system = message_of([&] { HttpClient(f.https(), HttpOptions{}).get("/healthz"); });
  EXPECT_TRUE(contains(system, "not trusted")) << system;
  // A CA file that is not there is named at once.
  HttpOptions missing;
  missing.ca_file = f.dir.path() + "/none.pem";
  const std::string no_file = message_of([&] { HttpClient(f.https(), missing); });
  EXPECT_TRUE(contains(no_file, "none.pem")) << no_file;
}

TEST(Tls, TheTileClientLocalizesOverHttpsWithTheFleetsCa) {
  TlsFixture f;
  pl::client::TileClientConfig c;
  c.server = f.https();
  c.map = "town";
  c.ca_file = f.fleet.ca;
  c.radius_m = 30;
  pl::client::TileClient client(c);
  ASSERT_TRUE(client.wait_ready(20.0)) << client.status().last_error;
  EXPECT_EQ(client.status().version, 1);
  // The street fixture's tiles lie along the x axis from the origin.
  EXPECT_TRUE(client.wait_for(Eigen::Vector2d(10, 0), 10, 20.0)) << client.status().last_error;

  // The same client trusting another CA never gets the map.
  c.ca_file = f.other.ca;
  pl::client::TileClient stranger(c);
  EXPECT_FALSE(stranger.wait_ready(2.0));
  EXPECT_TRUE(contains(stranger.status().last_error, "not trusted")) << stranger.status().last_error;
}

TEST(Tls, PlainHttpIsRefusedWhereItWouldCrossANetwork) {
  // Nothing is sent: the refusal comes before any connection.
  const std::string remote = message_of([] { HttpClient("http://192.0.2.7:8080"); });
  EXPECT_TRUE(contains(remote, "--insecure-http")) << remote;
  EXPECT_TRUE(contains(remote, "https://")) << remote;
  HttpOptions insecure;
  insecure.insecure_http = true;
  EXPECT_EQ(message_of([&] { HttpClient("http://192.0.2.7:8080", insecure); }), "");
  // This machine: nothing crosses a network.
  for (const char* local : {"http://127.0.0.1:1", "http://127.8.9.10:1", "http://localhost:1", "http://[::1]:1"})
    EXPECT_EQ(message_of([&] { HttpClient{local}; }), "") << local;
  EXPECT_TRUE(contains(message_of([] { HttpClient("ftp://example.org"); }), "expected https://"));
  // pl-map push says the same (its token would cross in clear), naming its flag.
  MapFixture map;
  const std::string push = pl::test::tool("pl-map") + " push --db " + map.db + " --map town --version 1 --token t --server http://192.0.2.7:8080";
  auto r = pl::test::run(push + " 2>&1");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_TRUE(contains(r.output, "--insecure-http")) << r.output;
}

TEST(Tls, UploadsOverPlainHttpFromAnotherMachineAreRefused) {
  MapFixture map;
  pl::server::Metrics metrics;
  pl::server::ApiConfig cfg;
  cfg.db = map.db;
  {
    // Register the fixture's tokens the way pl-server --tokens does.
    auto store = pl::store::Store::open(map.db, false);
    store.add_token(pl::test::kUploadToken, pl::store::Role::Upload, "test");
  }
  pl::server::ApiRequest req;
  req.method = "POST";
  req.target = "/v1/maps/town/versions";
  req.authorization = "Bearer " + pl::test::kUploadToken;
  req.from_loopback = false;
  {
    pl::server::Api api(cfg, metrics);
    auto r = api.handle(req);
    EXPECT_EQ(r.status, 403) << r.body;
    EXPECT_TRUE(contains(r.body, "--plain-uploads")) << r.body;
    // Reads from anywhere are fine.
    pl::server::ApiRequest read;
    read.method = "GET";
    read.target = "/v1/maps/town";
    read.from_loopback = false;
    EXPECT_EQ(api.handle(read).status, 200);
    // From this machine (the TLS proxy's side) the upload is taken.
    req.from_loopback = true;
    EXPECT_EQ(api.handle(req).status, 201);
  }
  cfg.plain_uploads = true;  // a TLS proxy on another machine forwards them
  pl::server::Api api(cfg, metrics);
  req.from_loopback = false;
  EXPECT_EQ(api.handle(req).status, 201);
}
