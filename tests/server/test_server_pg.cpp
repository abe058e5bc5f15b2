// The map service on PostgreSQL end to end: pl-map writes a map into a database of a throw-away
// cluster (tests/common/pg_cluster.hpp), pl-server replicas serve it, and a publish through one
// replica reaches the other.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <nlohmann/json.hpp>
#include <set>
#include <thread>
#include <vector>

#include "pl/common/cloud_io.hpp"
#include "pl/schema/http_client.hpp"
#include "pl/schema/store.hpp"
#include "map_fixture.hpp"
#include "pg_cluster.hpp"
#include "server_process.hpp"
#include "test_util.hpp"

using nlohmann::json;
using pl::api::HttpClient;
using pl::test::ServerProcess;
using pl::test::TempDir;

namespace {

std::map<std::string, std::string> bearer(const std::string& token) { return {{"Authorization", "Bearer " + token}}; }

}  // namespace

TEST(ServerOnPostgres, ReplicasServeOneDatabaseAndSeeEachOthersPublishes) {
  pl::test::MapFixture f(pl::test::PgCluster::get().new_database());
  const std::string& db = f.db;
  ServerProcess a(db, f.token_args()), b(db);
  HttpClient ha(a.url()), hb(b.url());
  const std::string roi = "/v1/maps/town/roi?x=10&y=10&radius=30";
  const json ra = json::parse(ha.get(roi).body), rb = json::parse(hb.get(roi).body);
  EXPECT_EQ(ra["version"], 1);
  EXPECT_FALSE(ra["tiles"].empty());
  EXPECT_EQ(ra, rb);  // the same answer from either replica
  // A tile's bytes from replica b are those the SQLite-free store holds, by hash.
  const auto tile = hb.get(ra["tiles"][0]["url"].get<std::string>());
  ASSERT_EQ(tile.status, 200);
  EXPECT_EQ(pl::store::content_hash(tile.body), ra["tiles"][0]["hash"].get<std::string>());

  // Publish through a; b comes to answer with the new version (its map rows live 250 ms; the 30 s
  // wait is a hang guard, not a time bound).
  ASSERT_EQ(ha.request("POST", "/v1/maps/town/versions", "", bearer(pl::test::kUploadToken)).status, 201);
  ASSERT_EQ(ha.request("POST", "/v1/maps/town/versions/2/publish", "", bearer(pl::test::kUploadToken)).status, 200);
  EXPECT_EQ(json::parse(ha.get(roi).body)["version"], 2);
  const auto published = std::chrono::steady_clock::now();
  long long seen = 0;
  while (seen != 2 && std::chrono::steady_clock::now() - published < std::chrono::seconds(30)) {
    seen = json::parse(hb.get(roi).body)["version"].get<long long>();
    if (seen != 2) std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  EXPECT_EQ(seen, 2);
  EXPECT_EQ(json::parse(hb.get("/v1/maps/town").body)["current_version"], 2);
  // Both writes through replica a in the one upload log (by token, not pl-map's own), the store
  // checked whole after.
  auto store = pl::store::Store::open(db, false);
  std::vector<std::string> by_api;
  for (const auto& e : store.upload_log("town"))
    if (e.who.rfind("token ", 0) == 0) by_api.push_back(e.action);
  EXPECT_EQ(by_api, (std::vector<std::string>{"create_version", "publish"}));
  EXPECT_TRUE(store.integrity_ok());
}

// Two uploaders, each through its own replica, publish versions opened from the same current one
// at the same moment, round after round: one gets 200, the other 409 naming what to do; the
// winner is what both replicas serve within a second and the loser's version stays staged
// (invisible); the refusal is in the upload log; the store is sound after.
TEST(ServerOnPostgres, UploadersPublishingAtOnceOneWinsTheOtherGets409) {
  pl::test::MapFixture f(pl::test::PgCluster::get().new_database());
  ServerProcess a(f.db, f.token_args()), b(f.db);
  HttpClient ha(a.url()), hb(b.url());
  HttpClient* via[2] = {&ha, &hb};
  const auto auth = bearer(pl::test::kUploadToken);
  constexpr int kRounds = 4;
  for (int round = 0; round < kRounds; ++round) {
    long long opened[2];
    for (int i = 0; i < 2; ++i) {
      auto r = via[i]->request("POST", "/v1/maps/town/versions", "", auth);
      ASSERT_EQ(r.status, 201) << r.body;
      opened[i] = json::parse(r.body)["version"].get<long long>();
    }
    int status[2] = {0, 0};
    std::string body[2];
    std::atomic<int> ready{0};
    std::vector<std::thread> threads;
    for (int i = 0; i < 2; ++i)
      threads.emplace_back([&, i] {
        HttpClient own(i == 0 ? a.url() : b.url());  // a connection of the thread's own
        ready.fetch_add(1);
        while (ready.load() < 2) std::this_thread::yield();
        auto r = own.request("POST", "/v1/maps/town/versions/" + std::to_string(opened[i]) + "/publish", "", auth);
        status[i] = r.status;
        body[i] = r.body;
      });
    for (auto& t : threads) t.join();
    ASSERT_TRUE((status[0] == 200 && status[1] == 409) || (status[0] == 409 && status[1] == 200))
        << "round " << round << ": " << status[0] << " " << body[0] << " / " << status[1] << " " << body[1];
    const int winner = status[0] == 200 ? 0 : 1, loser = 1 - winner;
    EXPECT_NE(body[loser].find("another upload was published first"), std::string::npos) << body[loser];
    EXPECT_NE(body[loser].find("pl-map push"), std::string::npos) << body[loser];
    // Both replicas come to serve the winner (the wait is a hang guard, not a time bound), and never
    // the loser's version on the way.
    for (HttpClient* h : via) {
      long long current = 0;
      std::set<long long> seen;
      EXPECT_TRUE(pl::test::eventually(
          [&] {
            current = json::parse(h->get("/v1/maps/town/roi?x=10&y=10&radius=30").body)["version"].get<long long>();
            seen.insert(current);
            return current == opened[winner];
          },
          120.0))
          << "round " << round << ": the replica still serves version " << current;
      EXPECT_EQ(seen.count(opened[loser]), 0u) << "round " << round;
      EXPECT_EQ(h->get("/v1/maps/town/versions/" + std::to_string(opened[loser]) + "/tiles").status, 404);
    }
  }
  auto store = pl::store::Store::open(f.db, false);
  int refused = 0, published = 0;
  for (const auto& e : store.upload_log("town")) {
    refused += e.action == "publish_refused";
    published += e.action == "publish" && e.who.rfind("token ", 0) == 0;
  }
  EXPECT_EQ(refused, kRounds);
  EXPECT_EQ(published, kRounds);
  std::vector<std::int64_t> published_now;
  for (const auto& v : store.list_versions("town"))
    if (v.state == pl::store::VersionState::Published) published_now.push_back(v.number);
  EXPECT_EQ(published_now, std::vector<std::int64_t>{*store.find_map("town")->current});
  EXPECT_TRUE(store.integrity_ok());
}
