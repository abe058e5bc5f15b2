// The values the PostgreSQL store reads back, checked column by column (PgRow, store_pg.hpp): a
// damaged or altered database is refused with the table and column, never read as a default.
#include <charconv>
#include <cmath>
#include <cstring>

#include "pl/schema/api_rules.hpp"
#include "store_pg.hpp"

namespace pl::store::detail {

const char* PgRow::raw(int col, const char* column) const {
  const pqxx::field f = row_[col];
  if (f.is_null()) bad(column, "is NULL");
  return f.c_str();
}

void PgRow::bad(const char* column, const std::string& why) const {
  store_.damaged(std::string(table_) + "." + column + " " + why);
}

std::int64_t PgRow::integer(int col, const char* column, std::int64_t min, std::int64_t max) const {
  const char* s = raw(col, column);
  const char* end = s + std::strlen(s);
  std::int64_t v = 0;
  auto res = std::from_chars(s, end, v);
  if (res.ec != std::errc() || res.ptr != end) bad(column, "is not an integer in range");
  if (v < min || v > max) bad(column, "is out of range (" + std::to_string(v) + ")");
  return v;
}

std::optional<std::int64_t> PgRow::opt_integer(int col, const char* column, std::int64_t min, std::int64_t max) const {
  if (row_[col].is_null()) return std::nullopt;
  return integer(col, column, min, max);
}

double PgRow::number(int col, const char* column, double min, double max) const {
  const char* s = raw(col, column);
  const char* end = s + std::strlen(s);
  double v = 0;
  auto res = std::from_chars(s, end, v);
  if (res.ec != std::errc() || res.ptr != end || !std::isfinite(v)) bad(column, "is not a finite number");
  if (!(v >= min && v <= max)) bad(column, "is out of range (" + std::to_string(v) + ")");
  return v;
}

double PgRow::positive(int col, const char* column) const {
  double v = number(col, column);
  if (!(v > 0)) bad(column, "is not a positive number (" + std::to_string(v) + ")");
  return v;
}

std::string PgRow::text(int col, const char* column) const {
  const pqxx::field f = row_[col];
  if (f.is_null()) bad(column, "is NULL");
  return std::string(f.c_str(), f.size());
}

std::string PgRow::hash(int col, const char* column) const {
  std::string s = text(col, column);
  if (!api::is_hash(s)) bad(column, "is not a SHA-256 hash (64 lowercase hex digits)");
  return s;
}

std::string PgRow::bytes(int col, const char* column) const {
  const pqxx::field f = row_[col];
  if (f.is_null()) bad(column, "is NULL");
  return pqxx::binarystring(f).str();
}

std::string PgRow::timestamp(int col, const char* column) const {
  std::string s = text(col, column);
  static const char shape[] = "dddd-dd-ddTdd:dd:dd.dddZ";
  bool ok = s.size() == sizeof(shape) - 1;
  for (std::size_t i = 0; ok && i < s.size(); ++i)
    ok = shape[i] == 'd' ? (s[i] >= '0' && s[i] <= '9') : s[i] == shape[i];
  if (!ok) bad(column, "is not a UTC timestamp (YYYY-MM-DDTHH:MM:SS.sssZ)");
  return s;
}

VersionState PgRow::state(int col, const char* column) const {
  std::string s = text(col, column);
  if (s == "staged") return VersionState::Staged;
  if (s == "published") return VersionState::Published;
  if (s == "retired") return VersionState::Retired;
  bad(column, "is not one of staged, published, retired");
}

void PgRow::require(int col, const std::string& what) const {
  const pqxx::field f = row_[col];
  if (f.is_null() || std::strcmp(f.c_str(), "t") != 0) store_.damaged(std::string(table_) + ": " + what);
}

}  // namespace pl::store::detail
