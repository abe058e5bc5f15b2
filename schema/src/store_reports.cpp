// The map store's change reports (schema/005_change_reports.sql): the JSON a vehicle sent about
// one drive on a map version, kept as it came, one per (map, vehicle, drive). All values reach SQL
// through bound parameters.
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "pl/common/error.hpp"
#include "pl/schema/detail/sqlite.hpp"
#include "pl/schema/store.hpp"
#include "report_row.hpp"
#include "store_internal.hpp"

namespace pl::store {

using namespace detail;

namespace {

// report_row.hpp's columns, then `received` and whether the version exists (the foreign key keeps
// it so; a damaged file may hold a report of a version that is gone). Append the WHERE.
constexpr const char* kReportColumns =
    "SELECT r.id, r.version, r.vehicle, r.drive, r.start_s, r.end_s, r.hash, r.size, r.who, r.received, "
    "EXISTS (SELECT 1 FROM versions AS v WHERE v.map_id = r.map_id AND v.number = r.version) "
    "FROM change_reports AS r ";

Store::ReportInfo read_report(const Stmt& st, const std::string& map) {
  Row row(st, "change_reports");
  Store::ReportInfo r = report_row(row, 0);
  r.map = map;
  r.received = read_timestamp(row, 9, "received");
  row.require(10, "map " + map + " has a change report of version " + num(r.version) + " but no such version");
  return r;
}

}  // namespace

Store::ReportPut SqliteStore::put_report(const std::string& map, std::int64_t version, const std::string& vehicle,
                                         const std::string& drive, double start, double end, std::string_view body,
                                         const std::string& hash, const std::string& who) {
  const Db db = conn();
  WriteScope tx(db);
  const std::int64_t map_id = require_map(db, map);
  require_version(db, map, map_id, version);  // in any state: vehicles localize against published ones
  // The write lock is held from here to the commit: a second put of the drive finds this one's row.
  Stmt(db,
       "INSERT INTO change_reports (map_id, version, vehicle, drive, start_s, end_s, hash, body, size, who) "
       "VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10) ON CONFLICT (map_id, vehicle, drive) DO NOTHING")
      .bind_int64(1, map_id)
      .bind_int64(2, version)
      .bind_text(3, vehicle)
      .bind_text(4, drive)
      .bind_double(5, start)
      .bind_double(6, end)
      .bind_text(7, hash)
      .bind_blob_static(8, body)
      .bind_int64(9, static_cast<std::int64_t>(body.size()))
      .bind_text(10, who)
      .run();
  Store::ReportPut out = Store::ReportPut::Stored;
  if (sqlite3_changes(db.get()) == 0) {
    // The drive is stored already: the same report sent again, or other bytes for it (kept out).
    Stmt st(db, "SELECT hash FROM change_reports WHERE map_id = ?1 AND vehicle = ?2 AND drive = ?3");
    st.bind_int64(1, map_id).bind_text(2, vehicle).bind_text(3, drive);
    if (!st.step())
      damaged(db, "change_reports: its unique key holds a report of vehicle " + vehicle + " drive " + drive +
                      " that the table does not");
    out = Row(st, "change_reports").hash(0, "hash") == hash ? Store::ReportPut::AlreadyStored : Store::ReportPut::Conflict;
  }
  tx.commit();
  return out;
}

std::vector<Store::ReportInfo> SqliteStore::list_reports(const std::string& map, std::optional<std::int64_t> version) const {
  const Db db = conn();
  std::vector<Store::ReportInfo> out;
  auto map_id = find_map_id(db, map);
  if (!map_id) return out;
  if (version) {
    Stmt st(db, (std::string(kReportColumns) + "WHERE r.map_id = ?1 AND r.version = ?2 ORDER BY r.id").c_str());
    st.bind_int64(1, *map_id).bind_int64(2, *version);
    while (st.step()) out.push_back(read_report(st, map));
  } else {
    Stmt st(db, (std::string(kReportColumns) + "WHERE r.map_id = ?1 ORDER BY r.id").c_str());
    st.bind_int64(1, *map_id);
    while (st.step()) out.push_back(read_report(st, map));
  }
  return out;
}

std::optional<std::string> SqliteStore::report_body(const std::string& map, std::int64_t id) const {
  const Db db = conn();
  auto map_id = find_map_id(db, map);
  if (!map_id) return std::nullopt;
  Stmt st(db, "SELECT hash, body, size FROM change_reports WHERE map_id = ?1 AND id = ?2");
  st.bind_int64(1, *map_id).bind_int64(2, id);
  if (!st.step()) return std::nullopt;
  Row row(st, "change_reports");
  const std::string hash = row.hash(0, "hash");
  std::string body = row.blob(1, "body");
  if (row.integer(2, "size", 1) != static_cast<std::int64_t>(body.size()))
    row.bad("size", "is not the length of change_reports.body");
  // As for tile blobs: bytes that changed on disk are caught here, and never handed out.
  if (content_hash(body) != hash) row.bad("body", "of change report " + num(id) + " does not match its content hash");
  return body;
}

std::int64_t SqliteStore::delete_reports(const std::string& map, const std::string& received_before) {
  const Db db = conn();
  WriteScope tx(db);
  const std::int64_t map_id = require_map(db, map);
  // Timestamps of one fixed shape sort as text in time order.
  Stmt(db, "DELETE FROM change_reports WHERE map_id = ?1 AND received < ?2")
      .bind_int64(1, map_id)
      .bind_text(2, received_before)
      .run();
  const std::int64_t n = sqlite3_changes(db.get());
  tx.commit();
  return n;
}

}  // namespace pl::store
