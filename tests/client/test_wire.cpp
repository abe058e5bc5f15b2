// What the vehicle reads from a server it must not trust: the parsers of the tile client's answers
// (client/src/wire.hpp) on hostile values, and the real HttpClient and TileClient against a server
// that sends hostile answers.
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <thread>

#include "http_response.hpp"
#include "pl/schema/http_client.hpp"
#include "pl/client/tile_client.hpp"
#include "pl/common/error.hpp"
#include "pl/common/tile_codec.hpp"
#include "pl/schema/store.hpp"
#include "tile_server.hpp"
#include "wire.hpp"

namespace wire = pl::client::wire;

namespace {

template <typename F>
std::string wire_error(F&& f) {
  try {
    f();
  } catch (const wire::WireError& e) {
    return e.what();
  }
  return "(no WireError)";
}

const std::string kHash = std::string(64, 'a');

// A server on 127.0.0.1 that answers every request on every connection with the same bytes.
class HostileServer {
 public:
  explicit HostileServer(std::string answer) : answer_(std::move(answer)) {
    fd_ = socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    if (bind(fd_, reinterpret_cast<sockaddr*>(&a), sizeof(a)) != 0 || listen(fd_, 16) != 0) throw std::runtime_error("bind");
    socklen_t len = sizeof(a);
    getsockname(fd_, reinterpret_cast<sockaddr*>(&a), &len);
    port_ = ntohs(a.sin_port);
    thread_ = std::thread([this] {
      while (!stop_) {
        int c = accept(fd_, nullptr, nullptr);
        if (c < 0) break;
        char buf[4096];
        if (recv(c, buf, sizeof(buf), 0) > 0) {
          ++requests_;
          send(c, answer_.data(), answer_.size(), MSG_NOSIGNAL);
        }
        close(c);
      }
    });
  }
  ~HostileServer() {
    stop_ = true;
    shutdown(fd_, SHUT_RDWR);
    close(fd_);
    thread_.join();
  }
  std::string url() const { return "http://127.0.0.1:" + std::to_string(port_); }
  int requests() const { return requests_; }

 private:
  std::string answer_;
  int fd_ = -1, port_ = 0;
  std::atomic<bool> stop_{false};
  std::atomic<int> requests_{0};
  std::thread thread_;
};

}  // namespace

TEST(Wire, TheManifestIsCheckedFieldByField) {
  const std::string good = R"({"name":"town","current_version":3,"origin":{"lat":49,"lon":8.4,"alt":110},"tile_size":20,"voxel_size":0.2})";
  auto m = wire::parse_manifest(good, "town", std::nullopt);
  EXPECT_EQ(m.version, 3);
  EXPECT_EQ(m.tile_size, 20);
  EXPECT_EQ(wire::parse_manifest(good, "town", 7).version, 7);
  EXPECT_NE(wire::error_text("x").size(), 0u);
  EXPECT_NE(wire_error([] { wire::parse_manifest("[1,2]", "town", std::nullopt); }).find("not a JSON object"), std::string::npos);
  // A tiny tile size would make every focus disc billions of keys.
  EXPECT_NE(wire_error([] { wire::parse_manifest(R"({"tile_size":1e-6,"origin":{"lat":0,"lon":0},"current_version":1})", "t", std::nullopt); })
                .find("between 1 and 1000 m"),
            std::string::npos);
  EXPECT_NE(wire_error([] { wire::parse_manifest(R"({"tile_size":-1,"origin":{"lat":0,"lon":0},"current_version":1})", "t", std::nullopt); })
                .find("tile_size"),
            std::string::npos);
  // A version that is a float far out of range: refused, never cast (the cast was undefined behaviour).
  EXPECT_NE(wire_error([] { wire::parse_manifest(R"({"tile_size":20,"origin":{"lat":0,"lon":0},"current_version":1e300})", "t", std::nullopt); })
                .find("whole number"),
            std::string::npos);
  EXPECT_NE(wire_error([] { wire::parse_manifest(R"({"tile_size":20,"origin":{"lat":0,"lon":0},"current_version":null})", "t", std::nullopt); })
                .find("no published version"),
            std::string::npos);
}

// The manifest's bounds give the current version's extent; anything else about them gives none (it
// is a hint for messages, never a reason to refuse the map).
TEST(Wire, TheManifestsBoundsAreItsCurrentVersionsExtent) {
  const std::string m = R"({"current_version":3,"bounds":{"min":[-10.5,-4,-1],"max":[90,40.25,8]}})";
  const auto e = wire::parse_manifest_extent(m, 3);
  ASSERT_TRUE(e);
  EXPECT_EQ(e->min_x, -10.5);
  EXPECT_EQ(e->min_y, -4);
  EXPECT_EQ(e->max_x, 90);
  EXPECT_EQ(e->max_y, 40.25);
  EXPECT_EQ(e->distance(0, 0), 0);
  EXPECT_EQ(e->distance(93, 44.25), 5);   // 3 and 4 beyond the corner
  EXPECT_EQ(e->distance(-20.5, 10), 10);  // beyond the left side
  EXPECT_FALSE(wire::parse_manifest_extent(m, 2));  // a pinned version other than the current one
  for (const char* bad : {R"({"current_version":3})", R"({"current_version":3,"bounds":{"min":[0,0,0],"max":[-1,5,0]}})",
                          R"({"current_version":3,"bounds":{"min":[0],"max":[1,1,1]}})", R"({"current_version":3,"bounds":{"min":["a",0],"max":[1,1]}})",
                          R"({"current_version":3,"bounds":{"min":[0,0],"max":[1e999,1]}})", "not json", "[]"})
    EXPECT_FALSE(wire::parse_manifest_extent(bad, 3)) << bad;
}

TEST(Wire, TheListOfMapsGivesTheirNames) {
  EXPECT_EQ(wire::parse_map_names(R"({"maps":[{"name":"town","current_version":1},{"name":"r","current_version":null}]})"),
            (std::vector<std::string>{"town", "r"}));
  EXPECT_TRUE(wire::parse_map_names(R"({"maps":[]})").empty());
  EXPECT_NE(wire_error([] { wire::parse_map_names(R"({"maps":{}})"); }).find("not an array"), std::string::npos);
  EXPECT_NE(wire_error([] { wire::parse_map_names(R"({"maps":[{"name":"../x"}]})"); }).find("not a map name"), std::string::npos);
  EXPECT_NE(wire_error([] { wire::parse_map_names(R"({"map":[]})"); }).find("has no \"maps\""), std::string::npos);
}

TEST(Wire, RoiAnswersWithHostileValuesAreRefused) {
  auto roi = [](const std::string& tiles) { return R"({"version":1,"tile_size":20,"tiles":[)" + tiles + R"(],"drop":[]})"; };
  auto rows = wire::parse_roi(roi(R"({"tx":-3,"ty":4,"hash":")" + kHash + R"(","points":12})"), 1, 20.0);
  ASSERT_EQ(rows.size(), 1u);
  EXPECT_EQ(rows[0].key.tx, -3);
  EXPECT_EQ(rows[0].points, 12);
  EXPECT_NE(wire_error([&] { wire::parse_roi(roi(R"({"tx":1e300,"ty":0,"hash":")" + kHash + "\"}"), 1, 20.0); }).find("tx"), std::string::npos);
  EXPECT_NE(wire_error([&] { wire::parse_roi(roi(R"({"tx":2147483648,"ty":0,"hash":")" + kHash + "\"}"), 1, 20.0); }).find("out of range"),
            std::string::npos);
  EXPECT_NE(wire_error([&] { wire::parse_roi(roi(R"({"tx":0,"ty":0,"hash":"../../etc"})"), 1, 20.0); }).find("valid hash"), std::string::npos);
  EXPECT_NE(wire_error([&] { wire::parse_roi(roi(R"({"tx":0,"ty":0,"hash":")" + kHash + R"(","points":-5})"), 1, 20.0); }).find("points"),
            std::string::npos);
  EXPECT_NE(wire_error([&] { wire::parse_roi(roi(""), 2, 20.0); }).find("version 1"), std::string::npos);
  EXPECT_NE(wire_error([&] { wire::parse_roi(roi(""), 1, 25.0); }).find("tile size"), std::string::npos);
  EXPECT_NE(wire_error([&] { wire::parse_roi(R"({"version":1,"tile_size":20,"tiles":{}})", 1, 20.0); }).find("not a list"),
            std::string::npos);
}

TEST(Wire, ErrorBodiesComeBackAsValidUtf8) {
  EXPECT_EQ(wire::error_text(R"({"error":"no map named \"x\"","status":404})"), "no map named \"x\"");
  const std::string text = wire::error_text("<html>\xff\xfe proxy error</html>");
  EXPECT_EQ(text.find('\xff'), std::string::npos);
  EXPECT_NE(text.find("proxy error"), std::string::npos);
  EXPECT_LE(wire::error_text(std::string(100000, 'x')).size(), 200u);
}

TEST(Wire, TileBytesAreCheckedAgainstTheirHashBeforeTheyAreDecoded) {
  pl::TileCloud c;
  for (int i = 0; i < 10; ++i) c.points.emplace_back(i, 2 * i, 0.5);
  const std::string bytes = pl::encode_tile(c);
  const std::string hash = pl::store::content_hash(bytes);
  EXPECT_EQ(wire::verified_tile(bytes, hash).size(), 10u);
  std::string altered = bytes;
  altered[altered.size() / 2] ^= 0x40;
  const std::string why = wire_error([&] { wire::verified_tile(altered, hash); });
  EXPECT_NE(why.find(pl::store::content_hash(altered)), std::string::npos) << why;
  // Bytes that match their hash but are no tile (a damaged store): a pl::Error, not a WireError.
  const std::string junk = "DRACO junk";
  EXPECT_THROW(wire::verified_tile(junk, pl::store::content_hash(junk)), pl::Error);
}

TEST(Wire, PlacesAreCheckedAgainstTheirEtag) {
  const std::string places("descriptors\0of the map", 22), hash = pl::store::content_hash(places);
  EXPECT_NO_THROW(wire::check_places(places, "\"" + hash + "\""));
  EXPECT_NO_THROW(wire::check_places(places, "W/\"" + hash + "\""));  // weakened by a proxy
  EXPECT_NO_THROW(wire::check_places(places, ""));                     // no ETag: nothing to check against
  EXPECT_NO_THROW(wire::check_places(places, "\"v7\""));                 // an ETag that names no content hash
  std::string altered = places;
  altered[3] ^= 0x20;
  const std::string why = wire_error([&] { wire::check_places(altered, "\"" + hash + "\""); });
  EXPECT_NE(why.find(pl::store::content_hash(altered)), std::string::npos) << why;
  EXPECT_NE(why.find("not " + hash), std::string::npos) << why;
  EXPECT_NE(wire_error([&] { wire::check_places("", ""); }).find("empty places"), std::string::npos);
}

TEST(Wire, PlacesThatDoNotMatchTheirEtagAreRefused) {
  const std::string body = "places a proxy changed";
  HostileServer server("HTTP/1.1 200 OK\r\nContent-Type: application/octet-stream\r\nETag: \"" + kHash +
                       "\"\r\nContent-Length: " + std::to_string(body.size()) + "\r\n\r\n" + body);
  pl::client::TileClientConfig cfg;
  cfg.server = server.url();
  cfg.map = "town";
  try {
    pl::client::fetch_places(cfg, 3, 5.0);
    FAIL() << "accepted places that do not match their ETag";
  } catch (const pl::Error& e) {
    const std::string why = e.what();
    EXPECT_NE(why.find("the places of map town version 3"), std::string::npos) << why;
    EXPECT_NE(why.find(pl::store::content_hash(body)), std::string::npos) << why;
    EXPECT_NE(why.find("not " + kHash), std::string::npos) << why;
  }
  EXPECT_EQ(server.requests(), 1);
}

TEST(Wire, AnAnswerLargerThanTheLimitIsRefusedWithoutHoldingIt) {
  // Declares 2 GiB and sends a little: the client refuses on the header, never allocating it.
  HostileServer server("HTTP/1.1 200 OK\r\nContent-Length: 2147483648\r\n\r\nDRACO");
  pl::api::HttpClient http(server.url(), 5.0);
  try {
    http.get("/v1/blobs/" + kHash);
    FAIL() << "accepted a 2 GiB answer";
  } catch (const pl::Error& e) {
    EXPECT_NE(std::string(e.what()).find("body limit"), std::string::npos) << e.what();
  }
}

TEST(Wire, TheTileClientSurvivesAHostileServerAndSaysWhatIsWrong) {
  // The manifest is JSON whose version cannot be cast; the client backs off and says so.
  HostileServer server(
      "HTTP/1.1 200 OK\r\nContent-Type: application/json\r\nContent-Length: 74\r\n\r\n"
      R"({"tile_size":20,"origin":{"lat":0,"lon":0},"current_version":-1e300,"x":0})");
  pl::client::TileClientConfig cfg;
  cfg.server = server.url();
  cfg.map = "town";
  cfg.timeout_s = 2;
  cfg.retry_min_s = 0.05;
  cfg.retry_max_s = 0.1;
  pl::client::TileClient client(cfg);
  EXPECT_FALSE(client.wait_ready(1.0));
  auto st = client.status();
  EXPECT_FALSE(st.ready);
  EXPECT_GE(st.failures, 1u);
  EXPECT_NE(st.last_error.find("current_version"), std::string::npos) << st.last_error;
  EXPECT_GE(server.requests(), 2);  // it kept trying
}
