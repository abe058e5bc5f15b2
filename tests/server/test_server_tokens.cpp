// Tokens at a real pl-server: reads that need one, uploads limited per token, and tokens rotated
// and revoked while the server runs.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "pl/schema/http_client.hpp"
#include "pl/schema/store.hpp"
#include "http_helpers.hpp"
#include "map_fixture.hpp"
#include "server_process.hpp"
#include "test_util.hpp"

namespace {

using pl::api::HttpClient;
using pl::test::ServerProcess;
using pl::test::TempDir;
using pl::test::kAdminToken;
using pl::test::kReadToken;
using pl::test::kUploadToken;
using pl::test::MapFixture;
using pl::test::bearer;
using pl::test::body_json;

TEST(Server, ReadTokenRequired) {
  MapFixture f;
  std::vector<std::string> args = f.token_args();
  args.push_back("--read-token-required");
  ServerProcess server(f.db, args);
  HttpClient http(server.url());
  EXPECT_EQ(http.get("/v1/maps/town").status, 401);
  EXPECT_EQ(http.get("/v1/maps/town", bearer(kReadToken)).status, 200);
  EXPECT_EQ(http.get("/healthz").status, 200);
}

// Each token's uploads are limited (429 with Retry-After beyond); pl-map push waits as told and
// gets its version through all the same.
TEST(Server, UploadsAreRateLimitedPerTokenAndPushWaitsItOut) {
  MapFixture f;
  TempDir dir;
  const std::string remote = dir / "remote.sqlite";
  pl::store::Store::open(remote, true);
  ServerProcess server(remote, {"--tokens", f.dir / "tokens.txt", "--upload-rate", "4", "--upload-burst", "2"});
  HttpClient http(server.url());
  int limited = 0;
  std::string retry_after, message;
  for (int i = 0; i < 6; ++i) {
    auto r = http.request("POST", "/v1/maps/town/versions", "", bearer(kUploadToken));  // 404: no such map, yet counted
    if (r.status == 429) ++limited, retry_after = r.header("retry-after"), message = r.body;
  }
  EXPECT_GE(limited, 3);
  EXPECT_EQ(retry_after, "1");
  EXPECT_NE(message.find("--upload-rate"), std::string::npos) << message;
  // Another token has its own allowance; reads are not limited.
  EXPECT_NE(http.request("POST", "/v1/maps/town/versions", "", bearer(kAdminToken)).status, 429);
  for (int i = 0; i < 10; ++i) EXPECT_EQ(http.get("/v1/maps").status, 200);
  auto r = pl::test::run(pl::test::tool("pl-map") + " push --db " + f.db + " --map town --version 1 --server " + server.url() +
                         " --token " + kAdminToken + " 2>&1");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(body_json(http.get("/v1/maps/town"))["current_version"], 1);
}

// Rotation as an operator does it, with the server running throughout: a new token made with
// pl-map token-add works at once, the old one revoked with pl-map token-revoke stops at once, and
// the upload log names each upload's token by id.
TEST(Server, TokensAreRotatedAndRevokedWithoutARestart) {
  MapFixture f;
  ServerProcess server(f.db, f.token_args());
  HttpClient http(server.url());
  const std::string pl_map = pl::test::tool("pl-map");
  ASSERT_EQ(http.request("POST", "/v1/maps/town/versions", "", bearer(kUploadToken)).status, 201);
  // The token alone on stdout (what to do with it goes to stderr).
  auto made = pl::test::run("{ " + pl_map + " token-add --db " + f.db + " --role upload --note 'survey car 2' 2>/dev/null; }");
  ASSERT_EQ(made.exit_code, 0) << made.output;
  const std::string fresh = made.output.substr(0, made.output.find('\n'));
  ASSERT_EQ(fresh.size(), 43u) << made.output;
  ASSERT_EQ(http.request("POST", "/v1/maps/town/versions", "", bearer(fresh)).status, 201);
  // The old token's id, from the list (which never shows a token).
  auto list = pl::test::run(pl_map + " token-list --db " + f.db + " 2>&1");
  ASSERT_EQ(list.exit_code, 0) << list.output;
  EXPECT_EQ(list.output.find(kUploadToken), std::string::npos);
  EXPECT_EQ(list.output.find(fresh), std::string::npos);
  auto store = pl::store::Store::open(f.db, false);
  const auto old_id = store.find_token(kUploadToken)->id, fresh_id = store.find_token(fresh)->id;
  auto revoked = pl::test::run(pl_map + " token-revoke --db " + f.db + " --id " + std::to_string(old_id) + " 2>&1");
  ASSERT_EQ(revoked.exit_code, 0) << revoked.output;
  auto refused = http.request("POST", "/v1/maps/town/versions", "", bearer(kUploadToken));
  EXPECT_EQ(refused.status, 401);
  EXPECT_NE(refused.body.find("revoked"), std::string::npos) << refused.body;
  EXPECT_EQ(http.request("POST", "/v1/maps/town/versions", "", bearer(fresh)).status, 201);
  // Revoking twice says so.
  auto again = pl::test::run(pl_map + " token-revoke --db " + f.db + " --id " + std::to_string(old_id) + " 2>&1");
  EXPECT_NE(again.exit_code, 0);
  EXPECT_NE(again.output.find("revoked already"), std::string::npos) << again.output;
  // Who made each version: by token id.
  std::vector<std::string> who;
  for (const auto& e : store.upload_log("town"))
    if (e.action == "create_version") who.push_back(e.who);
  EXPECT_EQ(who, (std::vector<std::string>{"token " + std::to_string(old_id), "token " + std::to_string(fresh_id),
                                           "token " + std::to_string(fresh_id)}));
}

}  // namespace
