// Running the map service as an operator does: every option in a config file (deploy/pl-server.toml
// is read as shipped), the systemd units' command lines, logs as JSON lines with the request id,
// /metrics with build and process figures, /readyz following the store, and PostgreSQL restarting
// under a serving pl-server.
#include <gtest/gtest.h>

#include <chrono>
#include <nlohmann/json.hpp>
#include <regex>
#include <set>
#include <sstream>
#include <thread>

#include "map_fixture.hpp"
#include "pg_cluster.hpp"
#include "pl/common/cloud_io.hpp"
#include "pl/schema/http_client.hpp"
#include "pl/schema/store.hpp"
#include "server_process.hpp"
#include "test_util.hpp"

using nlohmann::json;
using pl::api::HttpClient;
using pl::test::MapFixture;
using pl::test::ServerProcess;
using pl::test::TempDir;

namespace {

std::string source(const std::string& path) { return pl::test::read_file(std::string(PL_SOURCE_DIR) + "/" + path); }

std::string replace_line(std::string text, const std::string& key, const std::string& line) {
  const std::regex re("(^|\n)" + key + " = [^\n]*");
  return std::regex_replace(text, re, "$1" + line, std::regex_constants::format_first_only);
}

std::map<std::string, std::string> bearer(const std::string& token) { return {{"Authorization", "Bearer " + token}}; }

}  // namespace

TEST(Operate, TheShippedConfigFileNamesEveryOptionAndServes) {
  // Every long option of pl-server --help is in deploy/pl-server.toml (set or commented out).
  const std::string toml = source("deploy/pl-server.toml");
  auto help = pl::test::run(pl::test::tool("pl-server") + " --help");
  ASSERT_EQ(help.exit_code, 0);
  std::set<std::string> options;
  const std::regex option("--([a-z][a-z-]+)");
  for (std::sregex_iterator it(help.output.begin(), help.output.end(), option), end; it != end; ++it)
    options.insert((*it)[1]);
  for (const char* not_in_file : {"help", "version", "config"}) options.erase(not_in_file);
  ASSERT_GE(options.size(), 10u);
  for (const auto& o : options)
    EXPECT_TRUE(std::regex_search(toml, std::regex("(^|\n)#? ?" + o + " = "))) << o << " is not in deploy/pl-server.toml";

  // The file as shipped, with this test's store and JSON logs: the server takes every line of it.
  MapFixture f;
  std::string config = replace_line(toml, "db", "db = \"" + f.db + "\"");
  config = replace_line(config, "log-json", "log-json = true");
  config = replace_line(config, "upload-rate", "upload-rate = 1");
  config = replace_line(config, "upload-burst", "upload-burst = 1");
  pl::test::write_file(f.dir / "pl-server.toml", config);
  ServerProcess server(f.db, {"--config", f.dir / "pl-server.toml", "--tokens", f.dir / "tokens.txt"});
  HttpClient http(server.url());
  auto r = http.get("/v1/maps/town");
  ASSERT_EQ(r.status, 200);
  const std::string id = r.header("x-request-id");
  // upload-rate and upload-burst came from the file: the second write at once is limited.
  http.request("POST", "/v1/maps/town/versions", "", bearer(pl::test::kUploadToken));
  EXPECT_EQ(http.request("POST", "/v1/maps/town/versions", "", bearer(pl::test::kUploadToken)).status, 429);

  // Logs as JSON lines: each a whole object; the request's carries its id, status and target.
  EXPECT_EQ(server.terminate(), 0);
  bool found = false;
  std::istringstream lines(server.output());
  for (std::string line; std::getline(lines, line);) {
    if (line.empty() || line[0] != '{') continue;
    const json j = json::parse(line, nullptr, false);
    ASSERT_FALSE(j.is_discarded()) << line;
    ASSERT_TRUE(j.contains("level") && j.contains("msg")) << line;
    if (j.value("request_id", "") == id) {
      found = true;
      EXPECT_EQ(j["status"], 200);
      EXPECT_EQ(j["target"], "/v1/maps/town");
      EXPECT_EQ(j["method"], "GET");
      EXPECT_TRUE(j["time"].get<std::string>().back() == 'Z') << line;
    }
  }
  EXPECT_TRUE(found) << server.output();
}

TEST(Operate, TheSystemdUnitsCommandLinesStartTheServer) {
  MapFixture f;
  for (const std::string unit : {"pl-server.service", "pl-server@.service"}) {
    const std::string text = source("deploy/systemd/" + unit);
    std::smatch m;
    ASSERT_TRUE(std::regex_search(text, m, std::regex("\nExecStart=(\\S+) --config (\\S+)\n"))) << unit;
    EXPECT_EQ(m[1].str(), "/usr/local/bin/pl-server") << unit;  // where cmake --install puts it
    EXPECT_NE(text.find("\nKillSignal=SIGTERM\n"), std::string::npos) << unit;  // pl-server's graceful stop
    // The unit's command line with this build's pl-server and a config file at the unit's name
    // (an instance's %i filled in).
    std::string config_path = m[2].str();
    const auto at = config_path.find("%i");
    if (at != std::string::npos) config_path.replace(at, 2, "a");
    const std::string file = f.dir / config_path.substr(config_path.rfind('/') + 1);
    pl::test::write_file(file, "db = \"" + f.db + "\"\nlisten = \"127.0.0.1:0\"\nquiet = true\n");
    auto run = pl::test::run("timeout --preserve-status -s TERM 3 " + pl::test::tool("pl-server") + " --config " + file);
    // Started, listened, and stopped cleanly at SIGTERM (timeout's): exit 0 and the listening line.
    EXPECT_EQ(run.exit_code, 0) << unit << ": " << run.output;
    EXPECT_NE(run.output.find("listening on http://127.0.0.1:"), std::string::npos) << unit << ": " << run.output;
  }
}

TEST(Operate, MetricsNameTheBuildAndTheProcess) {
  MapFixture f;
  const auto unix_seconds = [] {
    return std::chrono::duration_cast<std::chrono::seconds>(std::chrono::system_clock::now().time_since_epoch()).count();
  };
  const long long before = unix_seconds();
  ServerProcess server(f.db);
  const long long after = unix_seconds();
  HttpClient http(server.url());
  const std::string m = http.get("/metrics").body;
  EXPECT_TRUE(std::regex_search(m, std::regex("\npl_build_info\\{version=\"[0-9]+\\.[0-9]+\\.[0-9]+\",compiler=\"[^\"]+\"\\} 1\n"))) << m;
  std::smatch rss, fds, start;
  ASSERT_TRUE(std::regex_search(m, rss, std::regex("\nprocess_resident_memory_bytes ([0-9]+)\n"))) << m;
  EXPECT_GT(std::stoll(rss[1]), 1 << 20);
  ASSERT_TRUE(std::regex_search(m, fds, std::regex("\nprocess_open_fds ([0-9]+)\n"))) << m;
  EXPECT_GT(std::stoll(fds[1]), 3);
  ASSERT_TRUE(std::regex_search(m, start, std::regex("\nprocess_start_time_seconds ([0-9]+)\n"))) << m;
  // It started while ServerProcess started it (to the second: the metric is whole seconds).
  EXPECT_GE(std::stoll(start[1]), before - 1);
  EXPECT_LE(std::stoll(start[1]), after + 1);
  EXPECT_NE(m.find("\nprocess_cpu_seconds_total "), std::string::npos);
  EXPECT_NE(m.find("\npl_store_reachable 1\n"), std::string::npos);
}

// PostgreSQL restarted under a serving pl-server: /readyz says so while it is down, ROI answers of
// the published version go on from memory, a write is refused with 503 and a clear message (and
// not half done), and once PostgreSQL is back the same write succeeds: nothing lost.
TEST(Operate, APostgresRestartIsRiddenOutAndWritesSucceedWhenRetried) {
  auto& cluster = pl::test::PgCluster::get();
  MapFixture f(cluster.new_database());
  const std::string& db = f.db;
  ServerProcess server(db, f.token_args());
  HttpClient http(server.url());
  const std::string roi = "/v1/maps/town/roi?x=10&y=10&radius=30";
  const std::string before = http.get(roi).body;
  ASSERT_EQ(json::parse(before)["version"], 1);
  ASSERT_EQ(http.get("/readyz").status, 200);

  cluster.pause();
  EXPECT_EQ(http.get("/readyz").status, 503);
  std::this_thread::sleep_for(std::chrono::milliseconds(300));  // past the map row's 250 ms: the store is asked, and is gone
  const auto during = http.get(roi);
  EXPECT_EQ(during.status, 200) << during.body;  // the published version's index and map row, from memory
  EXPECT_EQ(during.body, before);
  const auto refused = http.request("POST", "/v1/maps/town/versions", "", bearer(pl::test::kUploadToken));
  EXPECT_EQ(refused.status, 503) << refused.body;
  EXPECT_NE(refused.body.find("unreachable"), std::string::npos) << refused.body;
  EXPECT_EQ(refused.header("retry-after"), "1");
  // The store's address and the driver's words go to the server's log, not to the client.
  EXPECT_EQ(refused.body.find("127.0.0.1"), std::string::npos) << refused.body;
  EXPECT_NE(server.output().find("the map store is unreachable"), std::string::npos);
  EXPECT_NE(http.get("/metrics").body.find("\npl_store_reachable 0\n"), std::string::npos);

  cluster.resume();
  int ready = 0;
  for (int i = 0; i < 100 && ready != 200; ++i) {
    ready = http.get("/readyz").status;
    if (ready != 200) std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  EXPECT_EQ(ready, 200);
  // Retried as the 503 said (each server thread finds its old connection gone at its first use).
  pl::api::HttpResponse retried;
  for (int i = 0; i < 10; ++i) {
    retried = http.request("POST", "/v1/maps/town/versions", "", bearer(pl::test::kUploadToken));
    if (retried.status != 503) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
  }
  EXPECT_EQ(retried.status, 201) << retried.body;
  auto store = pl::store::Store::open(db, false);
  ASSERT_EQ(store.list_versions("town").size(), 2u);  // the refused write left nothing behind
  EXPECT_TRUE(store.integrity_ok());
}
