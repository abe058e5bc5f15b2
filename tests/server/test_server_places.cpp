// A version's places at a real pl-server: uploaded while staged, served under their hash, cached
// like tiles once published, copied to a new version, deleted, and logged.
#include <gtest/gtest.h>

#include <random>
#include <string>
#include <vector>

#include "pl/schema/http_client.hpp"
#include "pl/schema/store.hpp"
#include "http_helpers.hpp"
#include "map_fixture.hpp"
#include "server_process.hpp"
#include "test_util.hpp"

namespace {

using nlohmann::json;
using pl::api::HttpClient;
using pl::test::ServerProcess;
using pl::test::kReadToken;
using pl::test::kUploadToken;
using pl::test::MapFixture;
using pl::test::bearer;
using pl::test::body_json;
using pl::test::expect_error;

TEST(Server, PlacesAreUploadedWhileStagedAndServedUnderTheirHash) {
  MapFixture f;
  ServerProcess server(f.db, f.token_args());
  HttpClient http(server.url());
  const auto expect = expect_error;
  const std::string at = "/v1/maps/town/versions/";
  // pl-map tile found no places beside the cloud: version 1 has none.
  expect(http.get(at + "1/places"), 404, "map town version 1 has no places: rebuild it with pl-map build and pl-map tile");
  expect(http.get("/v1/maps/nowhere/versions/1/places"), 404, "no map named");
  expect(http.get(at + "9/places"), 404, "no version 9");
  expect(http.get(at + "zero/places"), 400, "version must be a positive whole number");

  std::mt19937 rng(11);
  std::string first(300000, '\0'), second(1000, '\0');
  for (auto& c : first) c = static_cast<char>(rng());
  for (auto& c : second) c = static_cast<char>(rng());
  const std::string first_hash = pl::store::content_hash(first), second_hash = pl::store::content_hash(second);
  // Uploads need the upload role and a staged version.
  expect(http.request("PUT", at + "1/places", first), 401, "upload role");
  expect(http.request("PUT", at + "1/places", first, bearer(kReadToken)), 403, "needs the upload role");
  expect(http.request("PUT", at + "1/places", first, bearer(kUploadToken)), 409, "version 1 is published");
  ASSERT_EQ(http.request("POST", "/v1/maps/town/versions", "", bearer(kUploadToken)).status, 201);
  expect(http.request("PUT", at + "2/places", "", bearer(kUploadToken)), 422, "the body is empty");
  auto put = http.request("PUT", at + "2/places", first, bearer(kUploadToken));
  ASSERT_EQ(put.status, 200) << put.body;
  EXPECT_EQ(body_json(put), json({{"version", 2}, {"hash", first_hash}, {"bytes", first.size()}}));

  // A staged version's places: uploaders only, and revalidated (they may still change).
  expect(http.get(at + "2/places"), 404, "no version 2");
  auto staged = http.get(at + "2/places", bearer(kUploadToken));
  ASSERT_EQ(staged.status, 200) << staged.body;
  EXPECT_TRUE(staged.body == first);
  EXPECT_EQ(staged.header("content-type"), "application/octet-stream");
  EXPECT_EQ(staged.header("etag"), "\"" + first_hash + "\"");
  EXPECT_EQ(staged.header("cache-control"), "private, no-cache");
  auto same = http.get(at + "2/places", {{"Authorization", "Bearer " + kUploadToken}, {"If-None-Match", staged.header("etag")}});
  EXPECT_EQ(same.status, 304);
  EXPECT_TRUE(same.body.empty());
  ASSERT_EQ(http.request("PUT", at + "2/places", second, bearer(kUploadToken)).status, 200);  // replaced
  auto changed = http.get(at + "2/places", {{"Authorization", "Bearer " + kUploadToken}, {"If-None-Match", staged.header("etag")}});
  ASSERT_EQ(changed.status, 200);
  EXPECT_TRUE(changed.body == second);
  EXPECT_EQ(changed.header("etag"), "\"" + second_hash + "\"");

  // Published: read-only, and cached for good like tiles.
  ASSERT_EQ(http.request("POST", at + "2/publish", "", bearer(kUploadToken)).status, 200);
  expect(http.request("PUT", at + "2/places", first, bearer(kUploadToken)), 409, "version 2 is published");
  for (int i = 0; i < 2; ++i) {  // the second from the server's memory
    auto published = http.get(at + "2/places");
    ASSERT_EQ(published.status, 200) << published.body;
    EXPECT_TRUE(published.body == second);
    EXPECT_EQ(published.header("etag"), "\"" + second_hash + "\"");
    EXPECT_EQ(published.header("cache-control"), "public, max-age=31536000, immutable");
  }
  EXPECT_EQ(http.get(at + "2/places", {{"If-None-Match", "\"" + second_hash + "\""}}).status, 304);
  EXPECT_EQ(http.get(at + "2/places", {{"If-None-Match", "*"}}).status, 304);
  EXPECT_EQ(http.get(at + "2/places", {{"If-None-Match", "\"" + first_hash + "\""}}).status, 200);
  auto head = http.request("HEAD", at + "2/places");
  EXPECT_EQ(head.status, 200);
  EXPECT_EQ(head.header("content-length"), std::to_string(second.size()));
  EXPECT_TRUE(head.body.empty());
  // Places are not tile blobs.
  EXPECT_EQ(http.get("/v1/blobs/" + second_hash).status, 404);

  // A new version starts with a copy of its parent's places.
  ASSERT_EQ(http.request("POST", "/v1/maps/town/versions", "", bearer(kUploadToken)).status, 201);
  auto copied = http.get(at + "3/places", bearer(kUploadToken));
  ASSERT_EQ(copied.status, 200);
  EXPECT_TRUE(copied.body == second);

  // The methods of the resource, and the body limit (64 MiB).
  auto options = http.request("OPTIONS", at + "3/places");
  EXPECT_EQ(options.status, 204);
  EXPECT_EQ(options.header("allow"), "GET, HEAD, PUT, DELETE, OPTIONS");
  auto post = http.request("POST", at + "3/places", "", bearer(kUploadToken));
  expect(post, 405, "not allowed");
  EXPECT_EQ(post.header("allow"), "GET, HEAD, PUT, DELETE, OPTIONS");
  EXPECT_EQ(http.request("PUT", at + "3/places", std::string((64u << 20) + 1, 'p'), bearer(kUploadToken)).status, 413);
  EXPECT_TRUE(http.get(at + "3/places", bearer(kUploadToken)).body == second);
  // An upload of a map without places removes the copy (staged versions only).
  expect(http.request("DELETE", at + "2/places", "", bearer(kUploadToken)), 409, "version 2 is published");
  expect(http.request("DELETE", at + "3/places", "", bearer(kReadToken)), 403, "needs the upload role");
  auto deleted = http.request("DELETE", at + "3/places", "", bearer(kUploadToken));
  EXPECT_EQ(deleted.status, 200) << deleted.body;
  expect(http.get(at + "3/places", bearer(kUploadToken)), 404, "map town version 3 has no places");
  expect(http.request("DELETE", at + "3/places", "", bearer(kUploadToken)), 404, "map town version 3 has no places");
  EXPECT_TRUE(http.get(at + "2/places").body == second);

  auto metrics = http.get("/metrics");
  EXPECT_NE(metrics.body.find("pl_requests_total{route=\"/v1/maps/{map}/versions/{v}/places\",status=\"200\"}"), std::string::npos)
      << metrics.body;
  EXPECT_NE(metrics.body.find("pl_requests_total{route=\"/v1/maps/{map}/versions/{v}/places\",status=\"409\"} 3"), std::string::npos)
      << metrics.body;
  EXPECT_EQ(server.terminate(), 0);
  // Each upload is in the upload log, with the hash and size of what was stored.
  pl::store::Store store = pl::store::Store::open(f.db, false);
  std::vector<std::string> uploads;
  for (const auto& e : store.upload_log("town"))
    if (e.action.find("places") != std::string::npos)
      uploads.push_back(e.action + " " + std::to_string(*e.version) + " " + e.detail + " " + e.who);
  // Each names its token by id (the fixture's upload token is the second the server registered).
  const std::string by = "token " + std::to_string(store.find_token(kUploadToken)->id);
  EXPECT_EQ(uploads, (std::vector<std::string>{"put_places 2 " + first_hash + " 300000 bytes " + by,
                                               "put_places 2 " + second_hash + " 1000 bytes " + by, "delete_places 3  " + by}));
  EXPECT_EQ(store.places("town", 2), second);
  EXPECT_FALSE(store.places("town", 3));
  EXPECT_TRUE(store.integrity_ok());
}

}  // namespace
