// The map service on PostgreSQL end to end: pl-map writes a map into a database of a throw-away
// cluster (tests/common/pg_cluster.hpp), pl-server replicas serve it, and a publish through one
// replica reaches the other.
#include <gtest/gtest.h>

#include <chrono>
#include <nlohmann/json.hpp>
#include <thread>

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

  // Publish through a; b answers with the new version within a second (its map rows live 250 ms).
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
