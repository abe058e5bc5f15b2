// pl-fleet's vehicles against a real pl-server on 127.0.0.1 serving a map pl-map made here: what
// they fetch is the store's bytes, what they count is what the server counts, and what a stopped
// server or an altering proxy does to them shows in stalls, failures and refusals. No figure of
// time is asserted: the machine may be busy.
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <functional>
#include <map>
#include <mutex>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <vector>

#include "pl/common/cloud_io.hpp"
#include "pl/common/error.hpp"
#include "error_of.hpp"
#include "pl/fleet/fleet.hpp"
#include "pl/schema/http_client.hpp"
#include "pl/schema/signed_current.hpp"
#include "pl/schema/signed_manifest.hpp"
#include "pl/schema/store.hpp"
#include "server_process.hpp"
#include "test_util.hpp"

using pl::fleet::FleetOptions;
using pl::fleet::FleetReport;
using pl::fleet::run_fleet;
using pl::test::ServerProcess;
using pl::test::TempDir;

namespace {

// A 300 m x 300 m block of gently rolling ground with a pole in every 20 m tile (so that no two
// tiles hold the same bytes), tiled by pl-map as map "town" version 1 and, signed with a fleet key
// made here, as map "signed" version 1.
struct FleetMap {
  TempDir dir;
  std::string db = dir / "maps.sqlite";
  FleetMap() {
    pl::Points3d pts;
    for (double x = 0.5; x < 300; x += 2.0)
      for (double y = 0.5; y < 300; y += 2.0) pts.emplace_back(x, y, 0.3 * std::sin(0.05 * x) + 0.2 * std::cos(0.07 * y) + 1e-4 * x * y);
    for (int tx = 0; tx < 15; ++tx)
      for (int ty = 0; ty < 15; ++ty)
        for (double z = 0.3; z < 4.0; z += 0.4) pts.emplace_back(tx * 20 + 3.1 + 0.37 * ((tx * 7 + ty * 3) % 11), ty * 20 + 5.1 + 0.29 * ((tx * 5 + ty) % 13), z);
    pl::write_pcd(dir / "ground.pcd", pts, std::vector<float>(pts.size(), 0.5f), pl::GeoPoint{49.0, 8.4, 110.0});
    run("key-gen --out " + (dir / "fleet"));
    for (const std::string map : {"town", "signed"}) {
      run("tile --cloud " + (dir / "ground.pcd") + " --db " + db + " --map " + map + " --voxel 0.5");
      run("publish --db " + db + " --map " + map + " --version 1" + (map == "signed" ? " --signing-key " + (dir / "fleet.key") : ""));
    }
  }
  static void run(const std::string& args) {
    auto r = pl::test::run(pl::test::tool("pl-map") + " " + args);
    if (r.exit_code != 0) throw std::runtime_error(r.output);
  }
  std::map<pl::TileKey, std::string> hashes(const std::string& map) const {
    std::map<pl::TileKey, std::string> out;
    for (const auto& t : pl::store::Store::open(db, false).list_tiles(map, 1)) out[t.key] = t.hash;
    return out;
  }
};

FleetMap& fleet_map() {
  static FleetMap m;
  return m;
}

FleetOptions options(const std::string& url, int vehicles, double seconds) {
  FleetOptions o;
  o.server = url;
  o.map = "town";
  o.vehicles = vehicles;
  o.duration_s = seconds;
  o.ramp_s = 0.5;
  o.block_m = 60;
  o.retry_min_s = 0.05;
  o.retry_max_s = 0.3;
  o.record_fetches = true;
  return o;
}

// A relay for GET requests on 127.0.0.1: each one goes on to `upstream` over a kept-alive
// connection of its own, and its answer's body through `alter` (target, body) before it comes
// back, with the header line `header` (target) returns, if any. Records the targets.
class Relay {
 public:
  using Alter = std::function<void(const std::string& target, std::string& body)>;
  using Header = std::function<std::string(const std::string& target)>;
  Relay(std::string upstream, Alter alter, Header header = nullptr)
      : upstream_(std::move(upstream)), alter_(std::move(alter)), header_(std::move(header)) {
    fd_ = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    socklen_t len = sizeof a;
    if (::bind(fd_, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0 || ::listen(fd_, 128) != 0 ||
        ::getsockname(fd_, reinterpret_cast<sockaddr*>(&a), &len) != 0)
      throw std::runtime_error("relay: cannot listen on 127.0.0.1");
    url_ = "http://127.0.0.1:" + std::to_string(ntohs(a.sin_port));
    accepter_ = std::thread([this] {
      for (int c; (c = ::accept(fd_, nullptr, nullptr)) >= 0;) {
        std::lock_guard<std::mutex> lock(mu_);
        conns_.push_back(c);
        workers_.emplace_back([this, c] { serve(c); });
      }
    });
  }
  ~Relay() {
    ::shutdown(fd_, SHUT_RDWR);
    ::close(fd_);
    accepter_.join();
    std::lock_guard<std::mutex> lock(mu_);
    for (int c : conns_) ::shutdown(c, SHUT_RDWR);
    for (auto& t : workers_) t.join();
    for (int c : conns_) ::close(c);
  }
  const std::string& url() const { return url_; }
  std::vector<std::string> targets() const {
    std::lock_guard<std::mutex> lock(mu_);
    return targets_;
  }

 private:
  void serve(int c) {
    pl::api::HttpClient up(upstream_);
    std::string in;
    char chunk[8192];
    for (;;) {
      std::size_t end;
      while ((end = in.find("\r\n\r\n")) == std::string::npos) {
        const ssize_t n = ::recv(c, chunk, sizeof chunk, 0);
        if (n <= 0) return;
        in.append(chunk, static_cast<std::size_t>(n));
      }
      const std::string head = in.substr(0, end);
      in.erase(0, end + 4);
      const auto from = head.find(' ') + 1;
      const std::string target = head.substr(from, head.find(' ', from) - from);
      pl::api::HttpResponse res;
      try {
        res = up.get(target);
      } catch (const std::exception&) {
        return;
      }
      {
        std::lock_guard<std::mutex> lock(mu_);
        targets_.push_back(target);
      }
      if (alter_) alter_(target, res.body);
      const std::string extra = header_ ? header_(target) : "";
      std::string out = "HTTP/1.1 " + std::to_string(res.status) + " X\r\nContent-Length: " + std::to_string(res.body.size()) + "\r\n" +
                        (extra.empty() ? "" : extra + "\r\n") + "\r\n" + res.body;
      for (std::size_t sent = 0; sent < out.size();) {
        const ssize_t n = ::send(c, out.data() + sent, out.size() - sent, MSG_NOSIGNAL);
        if (n <= 0) return;
        sent += static_cast<std::size_t>(n);
      }
    }
  }

  std::string upstream_, url_;
  Alter alter_;
  Header header_;
  int fd_ = -1;
  std::thread accepter_;
  mutable std::mutex mu_;
  std::vector<int> conns_;
  std::vector<std::thread> workers_;
  std::vector<std::string> targets_;
};

}  // namespace

TEST(Fleet, VehiclesFetchTheStoresBytesAndTheOriginCountsWhatTheySent) {
  FleetMap& f = fleet_map();
  ServerProcess server(f.db);
  FleetOptions o = options(server.url(), 20, 4.0);
  o.origin_metrics = {server.url() + "/metrics"};
  const FleetReport r = run_fleet(o);
  const auto truth = f.hashes("town");

  EXPECT_EQ(r.map_tiles, truth.size());
  EXPECT_EQ(r.vehicles_ready, 20);
  EXPECT_EQ(r.vehicles_driving, 20);
  EXPECT_EQ(r.failures, 0u);
  EXPECT_EQ(r.rejected, 0u);
  ASSERT_EQ(r.per_vehicle.size(), 20u);
  std::size_t bytes = 0, tiles = 0;
  for (const auto& v : r.per_vehicle) {
    SCOPED_TRACE("vehicle " + std::to_string(v.id));
    EXPECT_GT(v.scans, 0u);
    EXPECT_GE(v.speed, 10.0);
    EXPECT_LE(v.speed, 25.0);
    EXPECT_GT(v.distance_m, 0.0);
    ASSERT_GT(v.tiles, 0u);
    EXPECT_EQ(v.fetched.size(), v.tiles);
    std::size_t vb = 0;
    for (const auto& t : v.fetched) {
      ASSERT_TRUE(truth.count(t.key)) << t.key.tx << "/" << t.key.ty;
      EXPECT_EQ(t.hash, truth.at(t.key));  // the SHA-256 of the bytes that arrived
      vb += t.bytes;
    }
    EXPECT_EQ(vb, v.tile_bytes);
    // The first ROI query knows no tile; every later one names those it knows.
    EXPECT_GE(v.roi_queries, 1u);
    EXPECT_EQ(v.roi_with_have, v.roi_queries - 1);
    EXPECT_EQ(v.manifest_requests, 1u);
    EXPECT_EQ(v.tile_latency.count, v.tile_requests);
    EXPECT_EQ(v.roi_latency.count, v.roi_queries);
    bytes += v.tile_bytes;
    tiles += v.tiles;
  }
  EXPECT_EQ(bytes, r.tile_bytes);
  EXPECT_EQ(tiles, r.tiles);
  EXPECT_EQ(r.tiles, r.tile_requests);  // nothing failed, so every request brought its tile
  // No cache in between: the origin saw exactly the vehicles' requests, and no X-Cache header.
  ASSERT_EQ(r.origins.size(), 1u);
  EXPECT_TRUE(r.origin_ok) << r.origins[0].error;
  EXPECT_EQ(r.origins[0].tiles, static_cast<double>(r.tile_requests));
  EXPECT_EQ(r.origins[0].roi, static_cast<double>(r.roi_queries));
  EXPECT_EQ(r.origins[0].manifests, static_cast<double>(r.manifest_requests));
  EXPECT_DOUBLE_EQ(r.origin_tile_share, 1.0);
  EXPECT_EQ(r.cache_tiles.answers, r.tile_requests);
  EXPECT_EQ(r.cache_tiles.with_header, 0u);

  // The JSON holds the same figures and a row per vehicle.
  const auto j = nlohmann::json::parse(pl::fleet::report_json(r));
  EXPECT_EQ(j["tile_requests"].get<std::size_t>(), r.tile_requests);
  EXPECT_EQ(j["per_vehicle"].size(), 20u);
  EXPECT_EQ(j["origin"]["tiles"].get<double>(), r.origin_tiles);
}

TEST(Fleet, CacheHeadersAreCountedByKind) {
  FleetMap& f = fleet_map();
  ServerProcess server(f.db);
  // A stand-in for the cache tier: tiles "hit" (nginx's spelling), ROI answers "miss" (Varnish's),
  // manifests without the header.
  Relay relay(server.url(), nullptr, [](const std::string& target) -> std::string {
    if (target.rfind("/v1/blobs/", 0) == 0) return "X-Cache: HIT";
    if (target.find("/roi?") != std::string::npos) return "X-Cache: miss";
    return "";
  });
  FleetOptions o = options(relay.url(), 5, 2.0);
  o.origin_metrics = {server.url()};  // (no path: /metrics)
  const FleetReport r = run_fleet(o);
  ASSERT_GT(r.tile_requests, 0u);
  EXPECT_EQ(r.cache_tiles.answers, r.tile_requests);
  EXPECT_EQ(r.cache_tiles.with_header, r.tile_requests);
  EXPECT_EQ(r.cache_tiles.hit, r.tile_requests);
  EXPECT_DOUBLE_EQ(r.cache_tiles.hit_ratio(), 1.0);
  EXPECT_EQ(r.cache_tiles.values.at("hit"), r.tile_requests);
  EXPECT_EQ(r.cache_roi.miss, r.roi_queries);
  EXPECT_DOUBLE_EQ(r.cache_roi.hit_ratio(), 0.0);
  EXPECT_EQ(r.cache_manifests.answers, 5u);
  EXPECT_EQ(r.cache_manifests.with_header, 0u);
  // The relay asks the origin for every request: the origin's count is the vehicles'.
  EXPECT_TRUE(r.origin_ok);
  EXPECT_EQ(r.origin_tiles, static_cast<double>(r.tile_requests));
}

TEST(Fleet, SameSeedSameFleet) {
  FleetMap& f = fleet_map();
  ServerProcess server(f.db);
  FleetOptions o = options(server.url(), 5, 0.3);
  const FleetReport a = run_fleet(o), b = run_fleet(o);
  o.seed = 2;
  const FleetReport c = run_fleet(o);
  for (int i = 0; i < 5; ++i) {
    EXPECT_EQ(a.per_vehicle[i].speed, b.per_vehicle[i].speed);
    EXPECT_EQ(a.per_vehicle[i].start_s, b.per_vehicle[i].start_s);
    EXPECT_NE(a.per_vehicle[i].speed, c.per_vehicle[i].speed);
  }
}

TEST(Fleet, AStoppedServerStallsTheVehiclesWhichRecoverWhenItIsBack) {
  FleetMap& f = fleet_map();
  auto server = std::make_unique<ServerProcess>(f.db);
  const int port = server->port();
  FleetOptions o = options(server->url(), 10, 6.0);
  o.ramp_s = 0.2;
  o.start_wait_s = 0.3;  // drive off without the start tiles, counting stalls
  o.radius_m = 40;       // few tiles a vehicle, so that all come soon after the server is back, even
  o.roi_radius_m = 30;   // in a sanitizer build
  std::atomic<bool> started{false};
  FleetReport r;
  std::thread fleet([&] { r = run_fleet(o, [&](const pl::fleet::FleetProgress&) { started = true; }); });
  ASSERT_TRUE(pl::test::eventually([&] { return started.load(); }));
  server->kill9();
  std::this_thread::sleep_for(std::chrono::milliseconds(1500));
  server = std::make_unique<ServerProcess>(f.db, std::vector<std::string>{}, std::vector<std::pair<std::string, std::string>>{},
                                           "127.0.0.1:" + std::to_string(port));
  fleet.join();
  EXPECT_GT(r.failures, 0u);
  EXPECT_GT(r.retries, 0u);
  EXPECT_GT(r.stalled_scans, 0u);
  EXPECT_EQ(r.vehicles_ready, 10);
  for (const auto& v : r.per_vehicle) {
    SCOPED_TRACE("vehicle " + std::to_string(v.id));
    EXPECT_GT(v.tiles, 0u);                    // back: the tiles came
    EXPECT_LT(v.stalled_scans, v.scans);       // and some scans had all they needed
  }
}

namespace {
// The tile in the middle of the town map with one byte of its answers flipped by a relay before a
// real server: at its content-hash URL only, or at its key's URL too. 20 vehicles drive over it.
struct AlteredTile {
  explicit AlteredTile(bool by_key_too)
      : f(fleet_map()),
        server(f.db),
        hash(f.hashes("town").at(victim)),
        relay(server.url(), [this, by_key_too](const std::string& target, std::string& body) {
          if ((target == "/v1/blobs/" + hash || (by_key_too && target == by_key)) && !body.empty()) body[body.size() / 2] ^= 0x20;
        }) {}
  FleetOptions fleet_options() {
    FleetOptions o = options(relay.url(), 20, 4.0);
    o.block_m = 50;
    return o;
  }
  const pl::TileKey victim{7, 7};
  const std::string by_key = "/v1/maps/town/versions/1/tiles/7/7";
  FleetMap& f;
  ServerProcess server;
  const std::string hash;
  Relay relay;
};
}  // namespace

TEST(Fleet, AnAlteredTileIsRefusedAndNeverCountedPresent) {
  AlteredTile a(true);  // altered by both its URLs
  const FleetReport r = run_fleet(a.fleet_options());
  EXPECT_GT(r.rejected, 0u);
  EXPECT_EQ(r.failures, r.rejected);  // nothing else went wrong
  std::size_t asked_by_key = 0;
  for (const auto& t : a.relay.targets()) asked_by_key += t == a.by_key;
  EXPECT_GT(asked_by_key, 0u);  // refused by hash, asked for by key next (another cache entry)
  for (const auto& v : r.per_vehicle)
    for (const auto& t : v.fetched) EXPECT_FALSE(t.key == a.victim) << "vehicle " << v.id << " took the altered tile";
  // Vehicles that came near it stalled for it.
  EXPECT_GT(r.stalled_scans, 0u);
  EXPECT_GT(r.missing_tiles, 0u);
}

// Altered only at its content-hash URL (one poisoned cache entry): each vehicle refuses it once and
// asks by the key at once, with no backoff (the server is not failing), and takes the good bytes.
TEST(Fleet, ATileAlteredAtOneUrlIsTakenByTheOtherAtOnce) {
  AlteredTile a(false);
  FleetOptions o = a.fleet_options();
  o.retry_min_s = 5;  // a backoff would show: no vehicle could ask again within the run
  o.retry_max_s = 5;
  const FleetReport r = run_fleet(o);
  ASSERT_GT(r.rejected, 0u);
  EXPECT_EQ(r.failures, r.rejected);
  EXPECT_EQ(r.retries, 0u);  // no request waited for a backoff
  for (const auto& v : r.per_vehicle) {
    if (v.rejected == 0) continue;
    SCOPED_TRACE("vehicle " + std::to_string(v.id));
    bool took = false;
    for (const auto& t : v.fetched) took |= t.key == a.victim && t.hash == a.hash;
    EXPECT_TRUE(took);  // refused by hash, then took the good bytes by key
  }
}

namespace {
// A fleet that refused what it was served: no vehicle started, the refusals counted, no tile asked for.
void expect_nothing_used(const FleetReport& r) {
  EXPECT_EQ(r.vehicles_ready, 0);
  EXPECT_GT(r.rejected, 0u);
  EXPECT_EQ(r.tile_requests, 0u);
}
}  // namespace

TEST(Fleet, SignedVersionsAreUsedOnlyOnceTheirManifestVerifies) {
  FleetMap& f = fleet_map();
  ServerProcess server(f.db);
  FleetOptions o = options(server.url(), 5, 2.0);
  o.map = "signed";
  o.fleet_keys = f.dir / "fleet.pub";
  const FleetReport good = run_fleet(o);
  EXPECT_EQ(good.vehicles_ready, 5);
  EXPECT_EQ(good.rejected, 0u);
  EXPECT_EQ(good.roi_queries, 0u);  // the signed manifest names every tile: nothing to ask about
  EXPECT_GT(good.tiles, 0u);
  const auto truth = f.hashes("signed");
  for (const auto& v : good.per_vehicle)
    for (const auto& t : v.fetched) EXPECT_EQ(t.hash, truth.at(t.key));

  // One poisoned cache entry (the plain URL's): each vehicle refuses it once, then takes the
  // version by another URL (?refused=1), as the tile client does.
  {
    Relay poisoned(server.url(), [](const std::string& target, std::string& body) {
      if (target == "/v1/maps/signed/versions/1/manifest") body[body.size() / 2] ^= 1;
    });
    o.server = poisoned.url();
    const FleetReport once = run_fleet(o);
    EXPECT_EQ(once.vehicles_ready, o.vehicles);
    EXPECT_EQ(once.rejected, static_cast<std::size_t>(o.vehicles));
    EXPECT_GT(once.tiles, 0u);
  }
  // The signed manifest altered on the way, whatever the URL: refused, no version used, no tile fetched.
  Relay relay(server.url(), [](const std::string& target, std::string& body) {
    if (target.rfind("/v1/maps/signed/versions/1/manifest", 0) == 0) {
      // The first tile's hash: "tx ty HASH points" on the line after "tiles N".
      const auto line = body.find('\n', body.find("\ntiles ") + 1) + 1;
      const auto h = body.find(' ', body.find(' ', line) + 1) + 1;
      body[h] = body[h] == 'a' ? 'b' : 'a';
    }
  });
  o.server = relay.url();
  o.start_wait_s = 0.3;
  const FleetReport bad = run_fleet(o);
  expect_nothing_used(bad);
  EXPECT_GT(bad.stalled_scans, 0u);
}

// HTTPS as vehicles speak it: a CA made here (openssl), deploy/nginx/pointlocalization.conf
// terminating TLS in a real nginx on loopback in front of the pl-server.
TEST(Fleet, HttpsThroughTheTlsSite) {
  ASSERT_TRUE(access("/usr/sbin/nginx", X_OK) == 0 && pl::test::run("command -v openssl").exit_code == 0)
      << "needs nginx and openssl: apt-get install nginx-light openssl (./pl test installs them)";
  FleetMap& f = fleet_map();
  ServerProcess server(f.db);
  TempDir d;
  auto must = [](const std::string& cmd) {
    const auto r = pl::test::run(cmd);
    ASSERT_EQ(r.exit_code, 0) << cmd << "\n" << r.output;
  };
  must("cd " + d.path() + " && openssl req -x509 -newkey ec -pkeyopt ec_paramgen_curve:P-256 -nodes -days 2 -subj '/CN=fleet CA'"
       " -addext basicConstraints=critical,CA:TRUE -addext keyUsage=critical,keyCertSign,cRLSign -keyout ca.key -out ca.pem"
       " && openssl req -newkey ec -pkeyopt ec_paramgen_curve:P-256 -nodes -subj /CN=localhost -keyout srv.key -out srv.csr"
       " && printf 'subjectAltName=DNS:localhost\\nextendedKeyUsage=serverAuth\\n' >ext"
       " && openssl x509 -req -days 2 -in srv.csr -CA ca.pem -CAkey ca.key -CAcreateserial -extfile ext -out srv.pem");
  const int port = pl::test::free_port();
  std::string site = pl::test::read_file(std::string(PL_SOURCE_DIR) + "/deploy/nginx/pointlocalization.conf");
  for (const auto& [from, to] : std::vector<std::pair<std::string, std::string>>{
           {"@LISTEN@", "127.0.0.1:" + std::to_string(port)}, {"@CERT@", d / "srv.pem"}, {"@KEY@", d / "srv.key"},
           {"@ORIGINS@", "server 127.0.0.1:" + std::to_string(server.port()) + ";"}})
    for (std::size_t at; (at = site.find(from)) != std::string::npos;) site.replace(at, from.size(), to);
  pl::test::write_file(d / "site.conf", site);
  must("mkdir -p " + (d / "tmp") + " && chmod 777 " + (d / "tmp") + " && chmod 755 " + d.path());
  pl::test::write_file(d / "nginx.conf", "daemon off;\nworker_processes 1;\npid " + (d / "nginx.pid") + ";\nerror_log " + (d / "error.log") +
                                             ";\nevents { worker_connections 256; }\nhttp {\n  access_log off;\n  client_body_temp_path " +
                                             (d / "tmp/body") + ";\n  proxy_temp_path " + (d / "tmp/proxy") + ";\n  include " +
                                             (d / "site.conf") + ";\n}\n");
  const pid_t nginx = fork();
  if (nginx == 0) {
    execl("/usr/sbin/nginx", "nginx", "-p", d.path().c_str(), "-c", (d / "nginx.conf").c_str(), static_cast<char*>(nullptr));
    _exit(127);
  }
  struct Reap {
    pid_t pid;
    ~Reap() {
      kill(pid, SIGTERM);
      waitpid(pid, nullptr, 0);
    }
  } reap{nginx};
  ASSERT_TRUE(pl::test::eventually([&] {
    try {
      pl::api::HttpOptions ho;
      ho.ca_file = d / "ca.pem";
      return pl::api::HttpClient("https://localhost:" + std::to_string(port), ho).get("/healthz").status == 200;
    } catch (const std::exception&) {
      return false;
    }
  })) << pl::test::read_file(d / "error.log");

  FleetOptions o = options("https://localhost:" + std::to_string(port), 5, 2.0);
  o.ca_file = d / "ca.pem";
  o.origin_metrics = {server.url()};
  const FleetReport r = run_fleet(o);
  EXPECT_EQ(r.vehicles_ready, 5);
  EXPECT_EQ(r.failures, 0u);
  EXPECT_GT(r.tiles, 0u);
  EXPECT_EQ(r.origin_tiles, static_cast<double>(r.tile_requests));
  const auto truth = f.hashes("town");
  for (const auto& v : r.per_vehicle)
    for (const auto& t : v.fetched) EXPECT_EQ(t.hash, truth.at(t.key));
  // Without the fleet's CA the certificate is not trusted: nothing is asked.
  o.ca_file.clear();
  try {
    run_fleet(o);
    ADD_FAILURE() << "a certificate of an unknown CA was trusted";
  } catch (const pl::Error& e) {
    EXPECT_NE(std::string(e.what()).find("not trusted"), std::string::npos) << e.what();
  }
}

TEST(Fleet, CommandLine) {
  FleetMap& f = fleet_map();
  const std::string fleet = pl::test::tool("pl-fleet");
  auto r = pl::test::run(fleet + " --server ftp://127.0.0.1:1 --map town");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.output.find("pl-fleet: error: fleet: server ftp://127.0.0.1:1: write http://HOST:PORT or https://HOST:PORT"), std::string::npos) << r.output;
  r = pl::test::run(fleet + " --server http://127.0.0.1:1 --map town --speed-min 30 --speed-max 20");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.output.find("speed_max 20 is below speed_min 30"), std::string::npos) << r.output;
  r = pl::test::run(fleet + " --server http://127.0.0.1:1 --map town --vehicles 0");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.output.find("--vehicles"), std::string::npos) << r.output;
  r = pl::test::run(fleet + " --server http://127.0.0.1:" + std::to_string(pl::test::free_port()) + " --map town");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.output.find("is pl-server (or the cache) running there?"), std::string::npos) << r.output;

  ServerProcess server(f.db);
  TempDir out;
  r = pl::test::run(fleet + " --server " + server.url() + " --map town --vehicles 3 --duration 1 --json " + (out / "f.json") +
                    " --origin-metrics " + server.url() + "/metrics");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("pl-fleet: 3 vehicles"), std::string::npos) << r.output;
  const auto j = nlohmann::json::parse(pl::test::read_file(out / "f.json"));
  EXPECT_EQ(j["vehicles"].get<int>(), 3);
  EXPECT_EQ(j["per_vehicle"].size(), 3u);
  EXPECT_TRUE(j["origin"]["ok"].get<bool>());
}

// With the map service's timestamp key: each vehicle takes the version a fresh signed statement
// names (GET /v1/maps/{map}/current), as the tile client does; a statement held back past its
// expiry is refused and no version is used (a vehicle without a disk cache has none to fall back on).
TEST(Fleet, WithTimestampKeysTheVersionIsTheOneAFreshStatementNames) {
  FleetMap& f = fleet_map();
  TempDir d;
  const auto key = pl::signing::SigningKey::generate();
  key.save(d / "timestamp.key");
  pl::signing::save_public_key(key.public_key(), d / "timestamp.pub");
  ServerProcess server(f.db, {"--timestamp-key", d / "timestamp.key"});
  std::atomic<int> statements{0};
  Relay counting(server.url(), [&](const std::string& target, std::string&) { statements += target == "/v1/maps/signed/current"; });
  FleetOptions o = options(counting.url(), 5, 2.0);
  o.map = "signed";
  o.fleet_keys = f.dir / "fleet.pub";
  o.timestamp_keys = d / "timestamp.pub";
  const FleetReport good = run_fleet(o);
  EXPECT_EQ(good.vehicles_ready, 5);
  EXPECT_EQ(good.rejected, 0u);
  EXPECT_EQ(statements.load(), 5);  // one a vehicle, and no JSON manifest asked instead
  EXPECT_GT(good.tiles, 0u);

  const auto now = pl::signing::unix_now();
  const std::string expired = pl::signing::sign_current({"signed", 1, now - 4000, now - 3600}, key);
  Relay holding(server.url(), [&](const std::string& target, std::string& body) {
    if (target.rfind("/v1/maps/signed/current", 0) == 0) body = expired;
  });
  o.server = holding.url();
  o.start_wait_s = 0.3;
  expect_nothing_used(run_fleet(o));

  o.fleet_keys.clear();
  EXPECT_NE(pl::test::error_of([&] { run_fleet(o); }).find("--timestamp-keys needs --fleet-keys"), std::string::npos);
}
