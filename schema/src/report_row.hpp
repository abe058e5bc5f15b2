// A change_reports row read the same way on both engines (schema/005_change_reports.sql), as
// tile_row.hpp reads tiles: R is SQLite's Row or PostgreSQL's PgRow (the same integer / number /
// text / hash / bad). Private to pl_schema.
#pragma once

#include <cmath>
#include <cstdint>
#include <string>
#include <string_view>

#include "pl/schema/store.hpp"

namespace pl::store::detail {

// A vehicle's or a drive's id: 1 to 128 of [A-Za-z0-9_.:-] (what the report's parser takes).
inline bool valid_report_id(std::string_view s) {
  if (s.empty() || s.size() > 128) return false;
  for (char c : s)
    if (!((c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_' || c == '.' || c == ':' ||
          c == '-'))
      return false;
  return true;
}

// The columns id, version, vehicle, drive, start_s, end_s, hash, size, who from `first` on; the
// caller reads `received` (a timestamp, which each engine reads its own way) and sets `map`.
template <typename R>
Store::ReportInfo report_row(const R& row, int first) {
  Store::ReportInfo r;
  r.id = row.integer(first, "id", 1);
  r.version = row.integer(first + 1, "version", 1);
  r.vehicle = row.text(first + 2, "vehicle");
  if (!valid_report_id(r.vehicle)) row.bad("vehicle", "is not 1 to 128 of A-Z a-z 0-9 _ . : -");
  r.drive = row.text(first + 3, "drive");
  if (!valid_report_id(r.drive)) row.bad("drive", "is not 1 to 128 of A-Z a-z 0-9 _ . : -");
  r.start = row.number(first + 4, "start_s");
  r.end = row.number(first + 5, "end_s");
  if (!(r.start <= r.end)) row.bad("start_s", "is after end_s");
  r.hash = row.hash(first + 6, "hash");
  r.bytes = row.integer(first + 7, "size", 1);
  r.who = row.text(first + 8, "who");
  if (r.who.empty()) row.bad("who", "is empty");
  return r;
}

}  // namespace pl::store::detail
