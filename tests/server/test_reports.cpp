// The fleet's change reports end to end: a real pl-server on a real SQLite store takes reports
// from vehicles (report role, idempotent per drive, gzip), lists them, aggregates them into change
// candidates and, for an admin, stages and publishes the version they call for; the vehicle's
// spool keeps what the service could not take and sends it later.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <thread>
#include <nlohmann/json.hpp>

#include "pl/client/report_outbox.hpp"
#include "pl/client/status_reporter.hpp"
#include "pl/common/gzip.hpp"
#include "pl/schema/change_report.hpp"
#include "pl/schema/http_client.hpp"
#include "pl/schema/store.hpp"
#include "change_reports.hpp"
#include "map_fixture.hpp"
#include "server_process.hpp"
#include "test_util.hpp"

using nlohmann::json;
using pl::api::HttpClient;
using pl::schema::ChangeReport;
using pl::test::kAdminToken;
using pl::test::kReadToken;
using pl::test::kUploadToken;
using pl::test::MapFixture;
using pl::test::ServerProcess;

namespace {

const std::string kReportToken = "report-4b1e";

std::map<std::string, std::string> bearer(const std::string& token) {
  return {{"Authorization", "Bearer " + token}, {"Content-Type", "application/json"}};
}

void expect_error(const pl::api::HttpResponse& r, int status, const std::string& words) {
  EXPECT_EQ(r.status, status) << r.body;
  const json j = json::parse(r.body, nullptr, false);
  ASSERT_FALSE(j.is_discarded()) << r.body;
  EXPECT_NE(j["error"].get<std::string>().find(words), std::string::npos) << r.body;
}

// One drive past the street (pl-test's map fixture): the pole at (5.1, 5.1) passed through from
// 0.5 m up (it is gone), a box face at y = 10, x 25..28 added (with its sample), tiles seen.
ChangeReport drive(const std::string& vehicle, const std::string& id, double start, std::int64_t version = 1) {
  ChangeReport r = pl::test::drive_report("town", version, vehicle, id, start);
  pl::schema::TileChangeEvidence pole, box, seen;
  pole.key = {0, 0};
  box.key = {1, 0};
  seen.key = {-1, 0};
  for (auto* t : {&pole, &box, &seen}) t->scans = 30;
  for (int z = 1; z < 12; ++z) pole.cells.push_back({10, 10, z, 0, 0, 0, 6});
  for (int x = 50; x < 56; ++x)
    for (int z = 1; z < 4; ++z) box.cells.push_back({x, 20, z, 8, 0, 0, 0});
  for (int x = 2500; x < 2800; x += 20)
    for (int z = 60; z < 200; z += 20) box.points.push_back({x, 1002, z});
  r.tiles = {seen, pole, box};
  return r;
}

struct Service {
  MapFixture f;
  std::unique_ptr<ServerProcess> server;
  Service() {
    pl::test::write_file(f.dir / "tokens.txt", "read " + kReadToken + "\nreport " + kReportToken + "\nupload " + kUploadToken +
                                                   "\nadmin " + kAdminToken + "\n");
    server = std::make_unique<ServerProcess>(f.db, f.token_args());
  }
};

}  // namespace

TEST(Reports, AVehicleReportsEachDriveOnceAndTheServiceSaysWhatItRefuses) {
  Service s;
  HttpClient http(s.server->url());
  const std::string at = "/v1/maps/town/reports";
  const std::string a = pl::schema::change_report_json(drive("vehicle-1", "d1", 1000));
  expect_error(http.request("POST", at, a), 401, "report role");
  expect_error(http.request("POST", at, a, bearer(kReadToken)), 403, "needs the report role");
  auto first = http.request("POST", at, a, bearer(kReportToken));
  ASSERT_EQ(first.status, 201) << first.body;
  EXPECT_EQ(json::parse(first.body)["stored"], true);
  // Sent again (its answer was lost): the same report, taken once.
  auto again = http.request("POST", at, a, bearer(kReportToken));
  ASSERT_EQ(again.status, 200) << again.body;
  EXPECT_EQ(json::parse(again.body)["stored"], false);
  // Other content under that drive's id; another map's report; a version that is not published; not a report.
  auto other = drive("vehicle-1", "d1", 1000);
  other.tiles.pop_back();
  expect_error(http.request("POST", at, pl::schema::change_report_json(other), bearer(kReportToken)), 409, "give each drive its own id");
  auto elsewhere = drive("vehicle-1", "d2", 1000);
  elsewhere.map = "harbour";
  expect_error(http.request("POST", at, pl::schema::change_report_json(elsewhere), bearer(kReportToken)), 422, "POST it to /v1/maps/harbour");
  expect_error(http.request("POST", at, pl::schema::change_report_json(drive("vehicle-1", "d3", 1000, 9)), bearer(kReportToken)), 422,
               "no published version 9");
  expect_error(http.request("POST", at, "{\"format\": \"pl-change-report\"}", bearer(kReportToken)), 422, "change report:");
  expect_error(http.request("POST", "/v1/maps/nowhere/reports", a, bearer(kReportToken)), 422, "not nowhere");
  // gzip, as vehicles send them.
  const std::string b = pl::schema::change_report_json(drive("vehicle-2", "d1", 90000));
  auto gz = bearer(kReportToken);
  gz["Content-Encoding"] = "gzip";
  const std::string packed = pl::gzip(b, 9);
  EXPECT_LT(packed.size() * 2, b.size());
  auto second = http.request("POST", at, packed, gz);
  ASSERT_EQ(second.status, 201) << second.body;
  expect_error(http.request("POST", at, "not gzip at all", gz), 400, "not valid gzip");
  gz["Content-Encoding"] = "br";
  expect_error(http.request("POST", at, b, gz), 415, "plain or gzip");

  // The list is for uploaders: who sent what, against which version.
  expect_error(http.get(at, bearer(kReportToken)), 403, "upload role");
  auto list = http.get(at, bearer(kUploadToken));
  ASSERT_EQ(list.status, 200) << list.body;
  const json reports = json::parse(list.body)["reports"];
  ASSERT_EQ(reports.size(), 2u);
  EXPECT_EQ(reports[0]["vehicle"], "vehicle-1");
  EXPECT_EQ(reports[1]["vehicle"], "vehicle-2");
  EXPECT_EQ(reports[1]["bytes"], b.size()) << "stored as the JSON it inflates to";
  EXPECT_EQ(reports[0]["version"], 1);

  // The store holds them byte for byte.
  auto store = pl::store::Store::open(s.f.db, false);
  const auto stored = store.list_reports("town");
  ASSERT_EQ(stored.size(), 2u);
  EXPECT_EQ(*store.report_body("town", stored[0].id), a);
  EXPECT_EQ(*store.report_body("town", stored[1].id), b);
}

TEST(Reports, AnAdminUpdatesTheMapFromWhatTwoDrivesAgreeOn) {
  Service s;
  HttpClient http(s.server->url());
  const std::string at = "/v1/maps/town/reports";
  ASSERT_EQ(http.request("POST", at, pl::schema::change_report_json(drive("vehicle-1", "d1", 1000)), bearer(kReportToken)).status, 201);
  // One drive: nothing to update.
  auto none = http.request("POST", "/v1/maps/town/update", "", bearer(kAdminToken));
  ASSERT_EQ(none.status, 200) << none.body;
  EXPECT_TRUE(json::parse(none.body)["version"].is_null());
  ASSERT_EQ(http.request("POST", at, pl::schema::change_report_json(drive("vehicle-2", "d1", 90000)), bearer(kReportToken)).status, 201);

  // The heat map's source: per tile, what the passes agree on.
  auto changes = http.get("/v1/maps/town/changes");
  ASSERT_EQ(changes.status, 200) << changes.body;
  const json c = json::parse(changes.body);
  EXPECT_EQ(c["passes"], 2);
  std::size_t candidates = 0;
  for (const auto& t : c["tiles"]) candidates += t["candidate"].get<bool>();
  EXPECT_EQ(candidates, 2u) << changes.body;

  expect_error(http.request("POST", "/v1/maps/town/update", "", bearer(kUploadToken)), 403, "admin role");
  const auto before = pl::store::Store::open(s.f.db, false).list_tiles("town", 1);
  auto up = http.request("POST", "/v1/maps/town/update", "{\"publish\": true}", bearer(kAdminToken));
  ASSERT_EQ(up.status, 201) << up.body;
  const json u = json::parse(up.body);
  EXPECT_EQ(u["version"], 2);
  EXPECT_EQ(u["state"], "published");
  ASSERT_EQ(u["tiles"].size(), 2u);
  EXPECT_GT(u["tiles"][0]["removed"].get<int>(), 10);
  EXPECT_GT(u["tiles"][1]["added"].get<int>(), 50);
  EXPECT_NE(u["tiles"][0]["reason"].get<std::string>().find("vehicle-1/d1 vehicle-2/d1"), std::string::npos);
  EXPECT_EQ(json::parse(http.get("/v1/maps/town").body)["current_version"], 2);
  // Every other tile is the same blob.
  const auto after = pl::store::Store::open(s.f.db, false).list_tiles("town", 2);
  ASSERT_EQ(after.size(), before.size());
  std::size_t same = 0;
  for (std::size_t i = 0; i < after.size(); ++i) same += after[i].hash == before[i].hash;
  EXPECT_EQ(same, before.size() - 2);
  // The reports were against version 1: against version 2 there is nothing to update.
  auto next = http.request("POST", "/v1/maps/town/update", "", bearer(kAdminToken));
  ASSERT_EQ(next.status, 200) << next.body;
  EXPECT_EQ(json::parse(next.body)["passes"], 0);
}

TEST(Reports, TheVehiclesSpoolKeepsWhatTheServiceCouldNotTake) {
  Service s;
  pl::test::TempDir spool;
  pl::client::ReportOutboxConfig cfg;
  cfg.dir = spool / "reports";
  cfg.token = kReportToken;
  // A service that is not there: the reports wait.
  cfg.server = "http://127.0.0.1:" + std::to_string(pl::test::free_port());
  cfg.http.timeout_s = 2;
  {
    pl::client::ReportOutbox box(cfg);
    EXPECT_TRUE(box.put(drive("vehicle-1", "d1", 1000)).empty());
    EXPECT_TRUE(box.put(drive("vehicle-1", "d2", 9000, 9)).empty());  // against a version the service never published
    EXPECT_TRUE(box.put(drive("vehicle-1", "d1", 1000)).empty());     // the same drive again replaces it
    const auto r = box.send();
    EXPECT_EQ(r.sent, 0u);
    EXPECT_EQ(r.waiting, 2u);
    EXPECT_FALSE(r.last_error.empty());
  }
  // Later, the service is reachable: the good one is taken, the other set aside with the answer.
  cfg.server = s.server->url();
  pl::client::ReportOutbox box(cfg);
  ASSERT_EQ(box.waiting().size(), 2u);
  const auto r = box.send();
  EXPECT_EQ(r.sent, 1u);
  EXPECT_EQ(r.refused, 1u);
  EXPECT_EQ(r.waiting, 0u);
  EXPECT_TRUE(box.waiting().empty());
  std::size_t aside = 0;
  for (const auto& e : std::filesystem::directory_iterator(cfg.dir + "/refused")) {
    ++aside;
    if (e.path().extension() == ".answer") {
      EXPECT_NE(pl::test::read_file(e.path().string()).find("422"), std::string::npos);
    }
  }
  EXPECT_EQ(aside, 2u);
  // Sent twice (the answer lost): the service holds it already.
  box.put(drive("vehicle-1", "d1", 1000));
  const auto twice = box.send();
  EXPECT_EQ(twice.already, 1u);
  EXPECT_EQ(pl::store::Store::open(s.f.db, false).list_reports("town").size(), 1u);

  // The spool's bound: the oldest go first.
  pl::client::ReportOutboxConfig small = cfg;
  small.dir = spool / "small";
  small.server.clear();
  small.max_bytes = 64 << 10;
  pl::client::ReportOutbox tight(small);
  std::vector<std::string> dropped;
  for (int i = 0; i < 200 && dropped.empty(); ++i) dropped = tight.put(drive("vehicle-1", "x" + std::to_string(i), 1000 + i));
  ASSERT_EQ(dropped.size(), 1u);
  EXPECT_NE(dropped[0].find("+town+vehicle-1+x0.json.gz"), std::string::npos) << dropped[0];
  EXPECT_LE(tight.waiting_bytes(), small.max_bytes);
}

TEST(Reports, AVehicleTellsTheServiceWhereItIsAndHowItIs) {
  Service s;
  pl::client::StatusReporterConfig cfg;
  cfg.server = s.server->url();
  cfg.token = kReportToken;
  cfg.map = "town";
  cfg.vehicle = "van-7";
  cfg.every_s = 0.05;
  {
    pl::client::StatusReporter status(cfg);
    Eigen::Isometry3d base = Eigen::Isometry3d::Identity();
    base.translation() = Eigen::Vector3d(12.5, -3.0, 0.2);
    base.linear() = Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    status.update(base, pl::client::Health::Degraded, 1800000000.5);
  }  // stopping sends what is left
  HttpClient http(s.server->url());
  const auto list = http.get("/v1/maps/town/vehicles");
  ASSERT_EQ(list.status, 200) << list.body;
  const json v = json::parse(list.body)["vehicles"];
  ASSERT_EQ(v.size(), 1u) << list.body;
  EXPECT_EQ(v[0]["id"], "van-7");
  EXPECT_EQ(v[0]["health"], "degraded");
  EXPECT_NEAR(v[0]["x"].get<double>(), 12.5, 1e-9);
  EXPECT_NEAR(v[0]["y"].get<double>(), -3.0, 1e-9);
  EXPECT_NEAR(v[0]["yaw"].get<double>(), M_PI / 2, 1e-9);

  // A token without the role: counted and said, the localization never waits for it.
  cfg.token = kReadToken;
  pl::client::StatusReporter refused(cfg);
  refused.update(Eigen::Isometry3d::Identity(), pl::client::Health::Ok, 1.0);
  for (int i = 0; i < 200 && refused.stats().failed == 0; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(20));
  EXPECT_EQ(refused.stats().sent, 0u);
  EXPECT_GE(refused.stats().failed, 1u);
  EXPECT_NE(refused.stats().last_error.find("403"), std::string::npos) << refused.stats().last_error;
  cfg.vehicle = "no spaces";
  EXPECT_THROW(pl::client::StatusReporter bad(cfg), pl::Error);
}
