// The map store's change reports: stored once per drive and read back exactly, refused arguments,
// deleted by time and never changed, damage on disk, and report tokens.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <optional>
#include <string>
#include <utility>

#include "pl/common/error.hpp"
#include "pl/schema/store.hpp"
#include "error_of.hpp"
#include "store_fixture.hpp"

namespace {

using pl::store::Role;
using pl::store::Store;
using pl::test::contains;
using pl::test::error_of;
using pl::test::is_utc_iso8601;
using pl::test::kOrigin;
using pl::test::StoreTest;

// A report's bytes as the vehicle sent them: JSON here, but the store keeps any bytes, NULs included.
std::string report_json(const std::string& drive, int cells, char tail = '}') {
  std::string out = R"({"format":"pl-change-report","drive":")" + drive + R"(","tiles":[)";
  for (int i = 0; i < cells; ++i) out += (i ? "," : "") + std::to_string(i * 7919 % 1000);
  return out + "]" + std::string("\0", 1) + tail;
}

TEST_P(StoreTest, AChangeReportIsStoredOncePerDriveAndReadBackExactly) {
  Store s = Store::open(path);
  s.create_map("m", kOrigin, 10, 0.2);
  s.create_version("m", std::nullopt, "");
  s.publish("m", 1);
  s.create_version("m", std::nullopt, "");  // 2, staged
  const std::string a = report_json("d-1", 3000), b = report_json("d-1", 3000, ']');
  ASSERT_EQ(a.size(), b.size());
  using Put = Store::ReportPut;
  EXPECT_EQ(s.put_report("m", 1, "car-7", "2024-05-01:d-1", 1714550000.25, 1714553600.5, a, "token 3"), Put::Stored);
  auto list = s.list_reports("m");
  ASSERT_EQ(list.size(), 1u);
  const Store::ReportInfo r = list[0];
  EXPECT_GT(r.id, 0);
  EXPECT_EQ(r.map, "m");
  EXPECT_EQ(r.version, 1);
  EXPECT_EQ(r.vehicle, "car-7");
  EXPECT_EQ(r.drive, "2024-05-01:d-1");
  EXPECT_EQ(r.start, 1714550000.25);  // exactly
  EXPECT_EQ(r.end, 1714553600.5);
  EXPECT_EQ(r.hash, pl::store::content_hash(a));
  EXPECT_EQ(r.bytes, static_cast<std::int64_t>(a.size()));
  EXPECT_TRUE(is_utc_iso8601(r.received)) << r.received;
  EXPECT_EQ(r.who, "token 3");
  EXPECT_EQ(s.report_body("m", r.id), a);  // byte for byte, the NUL included

  // The same drive sent again: the same report, nothing written (not even a new time).
  EXPECT_EQ(s.put_report("m", 1, "car-7", "2024-05-01:d-1", 1714550000.25, 1714553600.5, a, "token 3"), Put::AlreadyStored);
  // Other bytes for that drive: a conflict, and the first report stays.
  EXPECT_EQ(s.put_report("m", 1, "car-7", "2024-05-01:d-1", 1714550000.25, 1714553600.5, b, "token 4"), Put::Conflict);
  EXPECT_EQ(s.put_report("m", 2, "car-7", "2024-05-01:d-1", 1, 2, b, "token 4"), Put::Conflict);  // whatever version
  EXPECT_EQ(count("change_reports"), 1);
  list = s.list_reports("m");
  ASSERT_EQ(list.size(), 1u);
  EXPECT_EQ(list[0].received, r.received);
  EXPECT_EQ(list[0].who, "token 3");
  EXPECT_EQ(s.report_body("m", r.id), a);

  // The key is (map, vehicle, drive): another vehicle's drive of the same name is another report,
  // and so is a report against a staged version.
  EXPECT_EQ(s.put_report("m", 1, "car-8", "2024-05-01:d-1", 10, 20, b, "token 4"), Put::Stored);
  EXPECT_EQ(s.put_report("m", 2, "car-7", "d-2", 30, 30, "{}", "token 3"), Put::Stored);
  EXPECT_EQ(s.put_report("m", 1, "Az09_.:-", std::string(128, 'x'), -5, 5, "x", "who"), Put::Stored);
  list = s.list_reports("m");
  ASSERT_EQ(list.size(), 4u);
  for (std::size_t i = 1; i < list.size(); ++i) EXPECT_LT(list[i - 1].id, list[i].id);  // the order received
  EXPECT_EQ(list[1].vehicle, "car-8");
  EXPECT_EQ(s.report_body("m", list[1].id), b);
  EXPECT_EQ(list[2].version, 2);
  EXPECT_EQ(list[2].start, list[2].end);
  EXPECT_EQ(list[3].drive, std::string(128, 'x'));

  // By version.
  const auto v1 = s.list_reports("m", 1), v2 = s.list_reports("m", 2);
  ASSERT_EQ(v1.size(), 3u);
  EXPECT_EQ(v1[0].id, list[0].id);
  EXPECT_EQ(v1[1].id, list[1].id);
  EXPECT_EQ(v1[2].id, list[3].id);
  ASSERT_EQ(v2.size(), 1u);
  EXPECT_EQ(v2[0].drive, "d-2");
  EXPECT_TRUE(s.list_reports("m", 3).empty());

  // Unknown maps and ids read as nothing.
  s.create_map("n", kOrigin, 10, 0.2);
  EXPECT_TRUE(s.list_reports("n").empty());
  EXPECT_TRUE(s.list_reports("nope").empty());
  EXPECT_TRUE(s.list_reports("bad name").empty());
  EXPECT_FALSE(s.report_body("n", r.id));  // another map's report
  EXPECT_FALSE(s.report_body("nope", r.id));
  EXPECT_FALSE(s.report_body("m", list.back().id + 1000));
  EXPECT_EQ(count("blobs"), 0);  // reports are not tile blobs
  EXPECT_TRUE(s.integrity_ok());

  // Another connection sees them (a server replica).
  Store other = Store::open(path, false);
  EXPECT_EQ(other.list_reports("m").size(), 4u);
  EXPECT_EQ(other.report_body("m", r.id), a);
}

TEST_P(StoreTest, ChangeReportsRefuseUnknownMapsVersionsAndBadArguments) {
  Store s = Store::open(path);
  s.create_map("m", kOrigin, 10, 0.2);
  s.create_version("m", std::nullopt, "");
  const std::string body = report_json("d", 10);
  auto put = [&](const std::string& map, std::int64_t version, const std::string& vehicle, const std::string& drive,
                 double start, double end, const std::string& bytes, const std::string& who) {
    return error_of([&] { s.put_report(map, version, vehicle, drive, start, end, bytes, who); });
  };
  std::string msg = put("ghost", 1, "car", "d", 0, 1, body, "t");
  EXPECT_TRUE(contains(msg, path + ": unknown map ghost")) << msg;
  msg = put("m", 7, "car", "d", 0, 1, body, "t");
  EXPECT_TRUE(contains(msg, path + ": map m has no version 7")) << msg;
  msg = put("bad name", 1, "car", "d", 0, 1, body, "t");
  EXPECT_TRUE(contains(msg, "invalid map name")) << msg;
  for (const std::string& bad : {std::string(), std::string(129, 'v'), std::string("car 7"), std::string("car/7"),
                                 std::string("car\n"), std::string("nul\0x", 5), std::string("m\xc3\xbcller")}) {
    msg = put("m", 1, bad, "d", 0, 1, body, "t");
    EXPECT_TRUE(contains(msg, path + ": map m version 1: change report: the vehicle id must be 1 to 128 of")) << msg;
    msg = put("m", 1, "car", bad, 0, 1, body, "t");
    EXPECT_TRUE(contains(msg, "the drive id must be 1 to 128 of")) << msg;
  }
  for (auto [start, end] : {std::pair<double, double>{2, 1}, {NAN, 1}, {0, NAN}, {-INFINITY, 0}, {0, INFINITY}}) {
    msg = put("m", 1, "car", "d", start, end, body, "t");
    EXPECT_TRUE(contains(msg, "change report of vehicle car drive d: the drive's span must be finite")) << msg;
  }
  msg = put("m", 1, "car", "d", 0, 1, "", "t");
  EXPECT_TRUE(contains(msg, "empty report")) << msg;
  msg = put("m", 1, "car", "d", 0, 1, std::string((std::size_t{32} << 20) + 1, 'x'), "t");
  EXPECT_TRUE(contains(msg, "more than the store's limit of 32 MiB")) << msg;
  msg = put("m", 1, "car", "d", 0, 1, body, "");
  EXPECT_TRUE(contains(msg, "empty sender")) << msg;
  EXPECT_EQ(count("change_reports"), 0);  // nothing written by any of them

  // Inside a Transaction, a refused put undoes only itself.
  {
    Store::Transaction tx(s);
    EXPECT_EQ(s.put_report("m", 1, "car", "d-1", 0, 1, body, "t"), Store::ReportPut::Stored);
    EXPECT_THROW(s.put_report("m", 9, "car", "d-2", 0, 1, body, "t"), pl::Error);
    EXPECT_EQ(s.put_report("m", 1, "car", "d-1", 0, 1, body, "t"), Store::ReportPut::AlreadyStored);
    tx.commit();
  }
  EXPECT_EQ(s.list_reports("m").size(), 1u);

  // The schema refuses what the store does: other writers too.
  const std::string hash = pl::store::content_hash("x");
  auto insert = [&](const std::string& vehicle, const std::string& drive, const std::string& span, const std::string& h,
                    const std::string& bytes, const std::string& size, const std::string& who) {
    return raw_exec("INSERT INTO change_reports (map_id, version, vehicle, drive, start_s, end_s, hash, body, size, who) "
                    "VALUES (1, 1, " + vehicle + ", " + drive + ", " + span + ", " + h + ", " + bytes + ", " + size + ", " +
                    who + ")");
  };
  const std::string x = bytes_literal("78");
  EXPECT_EQ(insert("'car'", "'raw'", "0, 1", "'" + hash + "'", x, "1", "'t'"), "");
  EXPECT_NE(insert("'car'", "'raw'", "0, 1", "'" + hash + "'", x, "1", "'t'"), "");  // the same drive again
  EXPECT_NE(insert("'car 7'", "'r2'", "0, 1", "'" + hash + "'", x, "1", "'t'"), "");
  EXPECT_NE(insert("'car'", "''", "0, 1", "'" + hash + "'", x, "1", "'t'"), "");
  EXPECT_NE(insert("'car'", "'r3'", "2, 1", "'" + hash + "'", x, "1", "'t'"), "");
  EXPECT_NE(insert("'car'", "'r4'", "0, 1", "'XYZ'", x, "1", "'t'"), "");
  EXPECT_NE(insert("'car'", "'r5'", "0, 1", "'" + hash + "'", x, "2", "'t'"), "");
  EXPECT_NE(insert("'car'", "'r6'", "0, 1", "'" + hash + "'", bytes_literal(""), "0", "'t'"), "");
  EXPECT_NE(insert("'car'", "'r7'", "0, 1", "'" + hash + "'", x, "1", "''"), "");
  EXPECT_NE(raw_exec("INSERT INTO change_reports (map_id, version, vehicle, drive, start_s, end_s, hash, body, size, who) "
                     "VALUES (1, 5, 'car', 'r8', 0, 1, '" + hash + "', " + x + ", 1, 't')"),
            "");  // no version 5
  EXPECT_EQ(count("change_reports"), 2);
}

TEST_P(StoreTest, ChangeReportsAreDeletedByTimeAndNeverChanged) {
  Store s = Store::open(path);
  for (const char* map : {"m", "n"}) {
    s.create_map(map, kOrigin, 10, 0.2);
    s.create_version(map, std::nullopt, "");
  }
  s.put_report("m", 1, "car", "early", 0, 1, "{}", "t");
  s.put_report("n", 1, "car", "early", 0, 1, "{}", "t");
  const std::string early = s.list_reports("m").at(0).received;
  std::string late;
  // The next millisecond at least: times are kept to the millisecond.
  for (int i = 0; i < 1000 && (late.empty() || late <= early); ++i) {
    usleep(2000);
    s.put_report("m", 1, "car", "late-" + std::to_string(i), 0, 1, "{}", "t");
    late = s.list_reports("m").back().received;
  }
  ASSERT_LT(early, late);
  const std::int64_t reports = static_cast<std::int64_t>(s.list_reports("m").size());

  EXPECT_EQ(s.delete_reports("m", "2000-01-01T00:00:00.000Z"), 0);
  EXPECT_EQ(s.delete_reports("m", early), 0);  // before it, not at it
  // Every report received before the last one: the first and any made in the same millisecond as it.
  const std::int64_t before_late = s.delete_reports("m", late);
  EXPECT_GE(before_late, 1);
  EXPECT_EQ(static_cast<std::int64_t>(s.list_reports("m").size()), reports - before_late);
  EXPECT_EQ(s.list_reports("m").back().received, late);
  EXPECT_EQ(s.list_reports("n").size(), 1u);  // another map's reports stay
  EXPECT_EQ(s.delete_reports("m", "9999-12-31T23:59:59.999Z"), reports - before_late);
  EXPECT_TRUE(s.list_reports("m").empty());
  EXPECT_EQ(s.list_reports("n").size(), 1u);
  // A drive retention forgot may be reported again.
  EXPECT_EQ(s.put_report("m", 1, "car", "early", 0, 1, "{}", "t"), Store::ReportPut::Stored);

  std::string msg = error_of([&] { s.delete_reports("ghost", late); });
  EXPECT_TRUE(contains(msg, path + ": unknown map ghost")) << msg;
  for (const std::string& bad :
       {std::string("yesterday"), std::string("2024-05-01T10:11:12Z"), std::string("2024-05-01 10:11:12.345"),
        std::string("2024-02-30T00:00:00.000Z"), std::string("2023-02-29T00:00:00.000Z"), std::string("2024-13-01T00:00:00.000Z"),
        std::string("2024-05-01T24:00:00.000Z"), std::string("0000-01-01T00:00:00.000Z"), std::string()}) {
    msg = error_of([&] { s.delete_reports("m", bad); });
    EXPECT_TRUE(contains(msg, "YYYY-MM-DDTHH:MM:SS.sssZ")) << "[" << bad << "] " << msg;
  }
  EXPECT_EQ(s.delete_reports("m", "2024-02-29T23:59:59.999Z"), 0);  // a leap day
  EXPECT_EQ(s.list_reports("m").size(), 1u);

  // Reports never change: the schema refuses every other writer's update too. Deleting is retention.
  msg = raw_exec("UPDATE change_reports SET who = 'mallory'");
  EXPECT_TRUE(contains(msg, "change reports never change")) << msg;
  EXPECT_TRUE(contains(raw_exec("UPDATE change_reports SET version = version"), "never change"));
  EXPECT_EQ(raw_scalar("SELECT count(*) FROM change_reports WHERE who = 'mallory'"), 0);
  EXPECT_EQ(raw_exec("DELETE FROM change_reports WHERE vehicle = 'car'"), "");
  EXPECT_EQ(count("change_reports"), 0);
}

TEST_P(StoreTest, AChangeReportAlteredOnDiskIsDamage) {
  {
    Store s = Store::open(path);
    s.create_map("m", kOrigin, 10, 0.2);
    s.create_version("m", std::nullopt, "");
    s.put_report("m", 1, "car", "d", 0, 1, report_json("d", 500), "t");
    EXPECT_TRUE(s.integrity_ok());
  }
  ASSERT_EQ(pl::test::zero_report_bodies(GetParam(), path), "");
  Store s = Store::open(path, false);
  const auto list = s.list_reports("m");  // the row itself still reads
  ASSERT_EQ(list.size(), 1u);
  const std::string msg = error_of([&] { s.report_body("m", list[0].id); });
  EXPECT_TRUE(contains(msg, path + ": the map store is damaged (change_reports.body of change report " +
                                std::to_string(list[0].id) + " does not match its content hash)"))
      << msg;
  EXPECT_TRUE(contains(msg, "restore it from a backup, or rebuild it with pl-map")) << msg;
  EXPECT_FALSE(s.integrity_ok());
}

TEST_P(StoreTest, AReportTokenRoundTrips) {
  const std::string car = pl::store::random_token();
  std::int64_t id = 0;
  {
    Store s = Store::open(path);
    s.add_token(pl::store::random_token(), Role::Read, "viewer");
    id = s.add_token(car, Role::Report, "car 7");
    EXPECT_EQ(s.check_token(car), Role::Report);
  }
  EXPECT_EQ(raw_scalar("SELECT count(*) FROM tokens WHERE role = 'report'"), 1);
  Store s = Store::open(path, false);
  const auto found = s.find_token(car);
  ASSERT_TRUE(found);
  EXPECT_EQ(found->id, id);
  EXPECT_EQ(found->role, Role::Report);
  EXPECT_EQ(found->note, "car 7");
  const auto list = s.list_tokens();
  ASSERT_EQ(list.size(), 2u);
  EXPECT_EQ(list[1].role, Role::Report);
  EXPECT_TRUE(s.revoke_token(id));
  EXPECT_FALSE(s.check_token(car));
  EXPECT_NE(raw_exec("INSERT INTO tokens (hash, role) VALUES ('" + pl::store::content_hash("x") + "', 'vehicle')"), "");
}

}  // namespace
