// The map viewer in a real browser: headless Chromium (software WebGL) loads /viewer/ from a real
// pl-server serving a store pl-map made, and the test reads back from the page (window.plViewer)
// what it fetched, decoded and drew: the tiles of the region it shows, exactly those the ROI query
// lists, their points where the map's are, a canvas that is not blank, the tiles of where a mouse
// drag takes the view, the overview when zoomed out, the tiles two versions differ in highlighted
// (and only those), the heat map, and a vehicle posted to the server arriving over the event
// stream; the page's folder is all that is served. Screenshots of the map view and the diff view go to
// $PL_VIEWER_SCREENSHOTS (default: the test's temporary folder) for the docs.
#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <set>

#include "headless_chromium.hpp"
#include "pl/common/tile_codec.hpp"
#include "pl/schema/http_client.hpp"
#include "server_process.hpp"
#include "test_util.hpp"
#include "viewer_fixture.hpp"

using nlohmann::json;
using pl::api::HttpClient;
using pl::test::HeadlessChromium;
using pl::test::ServerProcess;
using pl::test::ViewerMap;

namespace {

// Chromium is a dependency ./pl test installs: missing, the test fails (a skip would hide it).
#define NEED_CHROMIUM()                                                                                                \
  ASSERT_FALSE(HeadlessChromium::find().empty())                                                                       \
      << "chromium is not installed, so the viewer cannot be tested in a browser: apt-get install chromium (it is in " \
         "deploy/test-packages.txt, which ./pl test installs)"

// Where the screenshots go, and the file written.
std::string screenshot(HeadlessChromium& browser, const pl::test::TempDir& tmp, const std::string& name) {
  const char* env = std::getenv("PL_VIEWER_SCREENSHOTS");
  const std::string dir = env && *env ? env : tmp.path();
  const std::string path = dir + "/" + name;
  std::ofstream(path, std::ios::binary) << browser.screenshot_png();
  return path;
}

std::set<std::string> keys_of(const json& tiles) {
  std::set<std::string> out;
  for (const auto& t : tiles) out.insert(std::to_string(t["tx"].get<int>()) + "/" + std::to_string(t["ty"].get<int>()));
  return out;
}

// Loads the viewer at `hash` and waits until it has drawn everything it asked for.
void open_viewer(HeadlessChromium& browser, const std::string& url, const std::string& hash) {
  browser.navigate(url + "/viewer/#" + hash);
  browser.eval(
      "(async () => { for (let i = 0; i < 600 && !window.plViewer; i++) await new Promise(r => setTimeout(r, 50));"
      " await window.plViewer.idle(); return true; })()");
}

// The page's errors and console, for a failure's message.
std::string page_log(HeadlessChromium& browser) {
  std::string out = "page errors: " + browser.eval("JSON.stringify(plViewer.errors)").get<std::string>() + "\nconsole:\n";
  for (const auto& line : browser.console()) out += "  " + line + "\n";
  return out;
}

}  // namespace

TEST(Viewer, ShowsTheTilesOfTheRoiOverviewAndTheDiffOfTwoVersions) {
  NEED_CHROMIUM();
  ViewerMap f;
  ServerProcess server(f.db, f.token_args());
  HttpClient http(server.url());
  pl::test::TempDir tmp;
  HeadlessChromium browser(tmp.path());
  // Version 1, around the middle of the street: part of the map, not all of it.
  open_viewer(browser, server.url(), "map=town&v=1&x=10&y=8&r=20");
  const std::string log = page_log(browser);
  json state = browser.eval(
      "({roi: plViewer.roi, decoded: plViewer.tilesDecoded, shown: plViewer.shown(), stats: plViewer.stats(), errors: plViewer.errors,"
      " canvas: plViewer.canvasStats(), state: plViewer.state, first: plViewer.firstTileMs})");
  ASSERT_TRUE(state["errors"].empty()) << log;
  EXPECT_EQ(state["state"]["version"], 1);

  // Exactly the tiles the ROI query lists for the region the page shows, each decoded once.
  const json roi = state["roi"];  // a copy: state is assigned again below
  ASSERT_FALSE(roi["overview"].get<bool>()) << roi;
  EXPECT_NEAR(roi["radius"].get<double>(), 20.0, 0.5) << roi;  // the region the URL asked for
  const std::string query = roi["queries"][0];  // the page's own ROI query, asked again here
  EXPECT_EQ(query.rfind("/v1/maps/town/roi?", 0), 0u) << query;
  EXPECT_NE(query.find("&version=1"), std::string::npos) << query;
  const json listed = json::parse(http.get(query).body)["tiles"];
  ASSERT_GT(listed.size(), 0u);
  std::set<std::string> hashes;
  for (const auto& t : listed) hashes.insert(t["hash"]);
  EXPECT_LT(listed.size(), json::parse(http.get("/v1/maps/town/versions/1/tiles").body)["tiles"].size());  // a part of the map
  EXPECT_EQ(state["decoded"].get<std::size_t>(), hashes.size()) << log;
  EXPECT_EQ(keys_of(state["shown"]), keys_of(listed));
  std::size_t points = 0;
  for (const auto& t : listed) points += t["points"].get<std::size_t>();
  EXPECT_EQ(state["stats"]["points"].get<std::size_t>(), points);
  EXPECT_GT(state["first"].get<double>(), 0.0);
  // Not blank: the points cover part of the canvas, in more than one colour (height).
  EXPECT_GT(state["canvas"]["fraction"].get<double>(), 0.02) << state["canvas"];
  EXPECT_GT(state["canvas"]["colours"].get<int>(), 3) << state["canvas"];
  screenshot(browser, tmp, "viewer-map.png");

  // Dragged with the mouse 300 pixels to the left, the view moves east: the tiles there are
  // fetched and drawn, those left behind dropped.
  browser.drag(800, 400, 500, 400);
  state = browser.eval("plViewer.idle().then(() => ({roi: plViewer.roi, shown: plViewer.shown(), decoded: plViewer.tilesDecoded}))");
  EXPECT_GT(state["roi"]["x"].get<double>(), roi["x"].get<double>() + 5) << state["roi"];
  EXPECT_NEAR(state["roi"]["y"].get<double>(), roi["y"].get<double>(), 5) << state["roi"];
  const json moved = json::parse(http.get(state["roi"]["queries"][0].get<std::string>()).body)["tiles"];
  EXPECT_EQ(keys_of(state["shown"]), keys_of(moved));
  EXPECT_NE(keys_of(moved), keys_of(listed));
  EXPECT_GT(state["decoded"].get<std::size_t>(), hashes.size());

  // The whole map: the points where the map's are (tile origins added right), to the quantization.
  browser.eval("plViewer.setView(40, 10, 110)");
  state = browser.eval("({roi: plViewer.roi, stats: plViewer.stats()})");
  const json manifest = json::parse(http.get("/v1/maps/town/versions/1/tiles").body);
  ASSERT_EQ(state["roi"]["tiles"][0].get<std::size_t>(), manifest["tiles"].size()) << state;
  // Version 1's box, from its tiles' points as pl-map wrote them: the street cloud's.
  double lo[3] = {1e9, 1e9, 1e9}, hi[3] = {-1e9, -1e9, -1e9};
  for (const auto& p : f.cloud)
    for (int c = 0; c < 3; ++c) lo[c] = std::min(lo[c], p[c]), hi[c] = std::max(hi[c], p[c]);
  for (int c = 0; c < 3; ++c) {
    EXPECT_NEAR(state["stats"]["min"][c].get<double>(), lo[c], pl::TileCodecConfig{}.max_error_m + 0.001) << c;
    EXPECT_NEAR(state["stats"]["max"][c].get<double>(), hi[c], pl::TileCodecConfig{}.max_error_m + 0.001) << c;
  }

  // Intensity instead of height: still drawn.
  state = browser.eval("plViewer.setColour('intensity').then(() => plViewer.canvasStats())");
  EXPECT_GT(state["fraction"].get<double>(), 0.02);
  browser.eval("plViewer.setColour('height')");

  // Zoomed out: the version's overview, one cloud, instead of tiles.
  state = browser.eval("plViewer.setView(40, 10, 900).then(() => ({o: plViewer.overviewShown(), shown: plViewer.shown(), c: plViewer.canvasStats(),"
                       " roi: plViewer.roi}))");
  EXPECT_TRUE(state["o"].get<bool>()) << state;
  EXPECT_TRUE(state["shown"].empty());
  EXPECT_GT(state["c"]["fraction"].get<double>(), 0.001) << state;

  // The diff of versions 1 and 2: the tiles added, removed and changed, by their hashes in the two
  // versions' lists, and only those highlighted.
  const json l1 = json::parse(http.get("/v1/maps/town/versions/1/tiles").body)["tiles"];
  const json l2 = json::parse(http.get("/v1/maps/town/versions/2/tiles").body)["tiles"];
  std::map<std::string, std::string> h1, h2;
  for (const auto& t : l1) h1[std::to_string(t["tx"].get<int>()) + "/" + std::to_string(t["ty"].get<int>())] = t["hash"];
  for (const auto& t : l2) h2[std::to_string(t["tx"].get<int>()) + "/" + std::to_string(t["ty"].get<int>())] = t["hash"];
  std::set<std::string> added, removed, changed;
  for (const auto& [k, h] : h2)
    if (!h1.count(k)) added.insert(k);
    else if (h1[k] != h) changed.insert(k);
  for (const auto& [k, h] : h1)
    if (!h2.count(k)) removed.insert(k);
  ASSERT_EQ(added, (std::set<std::string>{"5/0"}));
  ASSERT_EQ(removed.size(), 3u);  // tiles (-2, -1), (-2, 0), (-2, 1)
  ASSERT_FALSE(changed.empty());
  ASSERT_LT(changed.size() + added.size(), h2.size());  // some tiles are the same
  state = browser.eval("plViewer.setView(40, 10, 110).then(() => plViewer.setMode('diff', 1, 2)).then(() =>"
                       " ({diff: plViewer.diff, highlighted: plViewer.highlighted(), shown: plViewer.shown(), errors: plViewer.errors,"
                       " c: plViewer.canvasStats()}))");
  ASSERT_TRUE(state["errors"].empty()) << page_log(browser);
  auto as_set = [](const json& a) { return std::set<std::string>(a.begin(), a.end()); };
  EXPECT_EQ(as_set(state["diff"]["added"]), added);
  EXPECT_EQ(as_set(state["diff"]["removed"]), removed);
  EXPECT_EQ(as_set(state["diff"]["changed"]), changed);
  std::set<std::string> differ = added;
  differ.insert(removed.begin(), removed.end());
  differ.insert(changed.begin(), changed.end());
  EXPECT_EQ(as_set(state["highlighted"]), differ);
  // Every tile of either version is on screen: the same ones greyed, the others in their colour.
  std::size_t same = 0;
  for (const auto& s : state["shown"]) same += s["kind"] == "same";
  EXPECT_EQ(same, h2.size() - added.size() - changed.size());
  EXPECT_GT(state["c"]["fraction"].get<double>(), 0.02);
  screenshot(browser, tmp, "viewer-diff.png");

  // The page's folder is all the viewer serves (raw: the browser would resolve the dots itself).
  EXPECT_EQ(pl::test::raw_get(server.port(), "/viewer/../CMakeLists.txt").substr(9, 3), "400");
  EXPECT_EQ(pl::test::raw_get(server.port(), "/viewer/%2e%2e/%2e%2e/etc/passwd").substr(9, 3), "400");
  EXPECT_EQ(server.terminate(), 0);
}

TEST(Viewer, ShowsTheVehiclesLiveAndTheChangesHeatMap) {
  NEED_CHROMIUM();
  ViewerMap f;
  ServerProcess server(f.db, f.token_args());
  HttpClient http(server.url());
  const auto bearer = std::map<std::string, std::string>{{"Authorization", "Bearer " + pl::test::kReportToken}};
  // One vehicle before the page opens (the stream's first records), one after.
  ASSERT_EQ(http.request("POST", "/v1/maps/town/vehicles/van-1", R"({"x": -5, "y": 2, "yaw": 0, "health": "ok"})", bearer).status, 200);
  pl::test::TempDir tmp;
  HeadlessChromium browser(tmp.path());
  open_viewer(browser, server.url(), "map=town&x=10&y=8&r=60");
  const std::string wait_for =
      "(async (test) => { for (let i = 0; i < 600; i++) { if (test(plViewer.vehicles)) return plViewer.vehicles;"
      " await new Promise(r => setTimeout(r, 50)); } return plViewer.vehicles; })";
  json v = browser.eval(wait_for + "(v => v['van-1'])");
  ASSERT_TRUE(v.contains("van-1")) << v << page_log(browser);
  EXPECT_EQ(v["van-1"]["health"], "ok");

  ASSERT_EQ(http.request("POST", "/v1/maps/town/vehicles/car-7", R"({"x": 12.5, "y": 6, "z": 0.2, "yaw": 1.57, "health": "ok", "t": 5})", bearer)
                .status,
            200);
  v = browser.eval(wait_for + "(v => v['car-7'])");
  ASSERT_TRUE(v.contains("car-7")) << v << page_log(browser);
  EXPECT_DOUBLE_EQ(v["car-7"]["x"].get<double>(), 12.5);
  EXPECT_DOUBLE_EQ(v["car-7"]["y"].get<double>(), 6.0);
  ASSERT_EQ(http.request("POST", "/v1/maps/town/vehicles/car-7", R"({"x": 14, "y": 6, "health": "degraded"})", bearer).status, 200);
  v = browser.eval(wait_for + "(v => v['car-7'] && v['car-7'].health === 'degraded')");
  EXPECT_EQ(v["car-7"]["health"], "degraded") << v;
  EXPECT_DOUBLE_EQ(v["car-7"]["x"].get<double>(), 14.0);
  EXPECT_TRUE(browser.eval("plViewer.eventsConnected").get<bool>());

  // The heat map of the change reports: none sent yet, so nothing to fill, and no error.
  const json heat = browser.eval("plViewer.setMode('changes').then(() => ({heat: plViewer.heat, errors: plViewer.errors, c: plViewer.canvasStats()}))");
  ASSERT_TRUE(heat["errors"].empty()) << page_log(browser);
  EXPECT_EQ(heat["heat"]["tiles"], 0);
  EXPECT_GT(heat["c"]["fraction"].get<double>(), 0.02);
  // Tiles with agreed voxels: filled over the points, the candidate outlined: more of the canvas
  // drawn, in more colours.
  const json filled = browser.eval(
      "plViewer.showChanges({tiles: [{tx: 0, ty: 0, passes: 3, agreed: 40, candidate: true}, {tx: 1, ty: 0, passes: 2, agreed: 3,"
      " candidate: false}, {tx: -1, ty: 0, passes: 1, agreed: 0, candidate: false}]}).then(() => ({heat: plViewer.heat, c: plViewer.canvasStats()}))");
  EXPECT_EQ(filled["heat"]["tiles"], 3);
  EXPECT_EQ(filled["heat"]["candidates"], 1);
  EXPECT_EQ(filled["heat"]["most"], 40);
  EXPECT_GT(filled["c"]["drawn"].get<double>(), heat["c"]["drawn"].get<double>());
  EXPECT_GT(filled["c"]["colours"].get<int>(), heat["c"]["colours"].get<int>());
  EXPECT_EQ(server.terminate(), 0);
}
