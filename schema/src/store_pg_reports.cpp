// The map store over PostgreSQL: change reports (schema/pg/005_change_reports.sql), the JSON a
// vehicle sent about one drive on a map version, kept as it came, one per (map, vehicle, drive).
// How transactions and concurrency work: store_pg.hpp. All values reach SQL as parameters of
// prepared statements.
#include <iterator>

#include "pl/common/error.hpp"
#include "pl/schema/api_rules.hpp"
#include "report_row.hpp"
#include "store_pg.hpp"

namespace pl::store::detail {

// report_row.hpp's columns, then `received` and whether the version exists (the foreign key keeps
// it so; a database edited with its constraints off may hold a report of a version that is gone).
#define PL_PG_REPORT_COLUMNS                                                                             \
  "SELECT r.id, r.version, r.vehicle, r.drive, r.start_s, r.end_s, r.hash, r.size, r.who, "              \
  PL_PG_TIMESTAMP("r.received") ", "                                                                     \
  "EXISTS (SELECT 1 FROM versions AS v WHERE v.map_id = r.map_id AND v.number = r.version) "             \
  "FROM change_reports AS r WHERE r.map_id = (SELECT id FROM maps WHERE name = $1) "

const PgStatement kPgReportStatements[] = {
    // No row lock on the map (writers of tiles take it, store_pg.hpp): a vehicle's report does not
    // wait for an upload of the map to commit. Maps and versions are never deleted.
    {"report_map", "SELECT id FROM maps WHERE name = $1"},
    // Of two puts of one drive at once, the second waits on the unique key for the first to commit
    // and then inserts nothing.
    {"report_insert",
     "INSERT INTO change_reports (map_id, version, vehicle, drive, start_s, end_s, hash, body, size, who) "
     "VALUES ($1, $2, $3, $4, $5::float8, $6::float8, $7, $8, $9, $10) ON CONFLICT (map_id, vehicle, drive) DO NOTHING "
     "RETURNING id"},
    {"report_hash", "SELECT hash FROM change_reports WHERE map_id = $1 AND vehicle = $2 AND drive = $3"},
    {"reports_list", PL_PG_REPORT_COLUMNS "ORDER BY r.id"},
    {"reports_list_version", PL_PG_REPORT_COLUMNS "AND r.version = $2 ORDER BY r.id"},
    {"report_body",
     "SELECT hash, body, size FROM change_reports WHERE map_id = (SELECT id FROM maps WHERE name = $1) AND id = $2"},
    {"reports_delete", "DELETE FROM change_reports WHERE map_id = $1 AND received < $2::timestamptz"},
};
const std::size_t kPgReportStatementCount = std::size(kPgReportStatements);

namespace {

Store::ReportInfo read_report(const PgStore& store, const pqxx::row& r, const std::string& map) {
  PgRow row(store, r, "change_reports");
  Store::ReportInfo out = report_row(row, 0);
  out.map = map;
  out.received = row.timestamp(9, "received");
  row.require(10, "map " + map + " has a change report of version " + pg_num(out.version) + " but no such version");
  return out;
}

}  // namespace

Store::ReportPut PgStore::put_report(const std::string& map, std::int64_t version, const std::string& vehicle,
                                     const std::string& drive, double start, double end, std::string_view body,
                                     const std::string& hash, const std::string& who) {
  require_text(who, "change report's sender (who)");
  const pqxx::binarystring data(body.data(), body.size());
  return atomically([&](Work& w) {
    const pqxx::result m = w.exec_prepared("report_map", map);
    if (m.empty()) throw Error(name_ + ": unknown map " + map);
    const std::int64_t map_id = PgRow(*this, m[0], "maps").integer(0, "id");
    require_version(w, map, map_id, version);  // in any state: vehicles localize against published ones
    // The drive stored already: the same report sent again, or other bytes for it (kept out). A
    // row that retention deletes between the insert and the look-up makes us insert again.
    for (int attempt = 0;; ++attempt) {
      if (!w.exec_prepared("report_insert", map_id, version, vehicle, drive, pg_double(start), pg_double(end), hash, data,
                           static_cast<std::int64_t>(body.size()), who)
               .empty())
        return Store::ReportPut::Stored;
      const pqxx::result r = w.exec_prepared("report_hash", map_id, vehicle, drive);
      if (!r.empty())
        return PgRow(*this, r[0], "change_reports").hash(0, "hash") == hash ? Store::ReportPut::AlreadyStored
                                                                            : Store::ReportPut::Conflict;
      if (attempt == 3)
        throw Error(name_ + ": map " + map + " version " + pg_num(version) + ": the change report of vehicle " + vehicle +
                    " drive " + drive + " kept vanishing while it was written (deleted by retention?); send it again");
    }
  });
}

std::vector<Store::ReportInfo> PgStore::list_reports(const std::string& map, std::optional<std::int64_t> version) const {
  if (!api::valid_map_name(map)) return {};
  return one_statement([&](Work& w) {
    const pqxx::result r =
        version ? w.exec_prepared("reports_list_version", map, *version) : w.exec_prepared("reports_list", map);
    std::vector<Store::ReportInfo> out;
    out.reserve(r.size());
    for (const auto& row : r) out.push_back(read_report(*this, row, map));
    return out;
  });
}

std::optional<std::string> PgStore::report_body(const std::string& map, std::int64_t id) const {
  if (!api::valid_map_name(map)) return std::nullopt;
  return one_statement([&](Work& w) -> std::optional<std::string> {
    const pqxx::result r = w.exec_prepared("report_body", map, id);
    if (r.empty()) return std::nullopt;
    PgRow row(*this, r[0], "change_reports");
    const std::string hash = row.hash(0, "hash");
    std::string body = row.bytes(1, "body");
    if (row.integer(2, "size", 1) != static_cast<std::int64_t>(body.size()))
      row.bad("size", "is not the length of change_reports.body");
    // As for tile blobs: bytes edited behind the store's back are caught here and never handed out.
    if (content_hash(body) != hash) row.bad("body", "of change report " + pg_num(id) + " does not match its content hash");
    return body;
  });
}

std::int64_t PgStore::delete_reports(const std::string& map, const std::string& received_before) {
  if (!api::valid_map_name(map)) throw Error(name_ + ": unknown map " + map);
  return atomically([&](Work& w) {
    const pqxx::result m = w.exec_prepared("report_map", map);
    if (m.empty()) throw Error(name_ + ": unknown map " + map);
    const std::int64_t map_id = PgRow(*this, m[0], "maps").integer(0, "id");
    return static_cast<std::int64_t>(w.exec_prepared("reports_delete", map_id, received_before).affected_rows());
  });
}

}  // namespace pl::store::detail
