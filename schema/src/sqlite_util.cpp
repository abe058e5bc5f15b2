#include "sqlite_util.hpp"

#include <limits>

#include "pl/common/error.hpp"

namespace pl::store::detail {

void fail(sqlite3* db, const std::string& path, const std::string& what) {
  std::string msg = path + ": " + what + ": ";
  msg += db ? sqlite3_errmsg(db) : "out of memory";
  throw Error(msg);
}

void exec(sqlite3* db, const std::string& path, const char* sql) {
  char* err = nullptr;
  int rc = sqlite3_exec(db, sql, nullptr, nullptr, &err);
  if (rc != SQLITE_OK) {
    std::string msg = err ? err : sqlite3_errstr(rc);
    sqlite3_free(err);
    std::string head(sql);
    if (head.size() > 40) head = head.substr(0, 37) + "...";
    throw Error(path + ": " + head + ": " + msg);
  }
}

Stmt::Stmt(sqlite3* db, const std::string& path, const char* sql) : db_(db), path_(path) {
  if (sqlite3_prepare_v2(db, sql, -1, &stmt_, nullptr) != SQLITE_OK) {
    sqlite3_finalize(stmt_);
    stmt_ = nullptr;
    fail(db, path, std::string("preparing \"") + sql + "\"");
  }
}

Stmt::~Stmt() { sqlite3_finalize(stmt_); }

namespace {
void check_bind(sqlite3* db, const std::string& path, int rc) {
  if (rc != SQLITE_OK) fail(db, path, "binding a parameter");
}
int length_of(std::string_view v, const std::string& path) {
  if (v.size() > static_cast<std::size_t>(std::numeric_limits<int>::max()))
    throw Error(path + ": a value of " + std::to_string(v.size()) + " bytes is too large for SQLite");
  return static_cast<int>(v.size());
}
}  // namespace

Stmt& Stmt::bind_int64(int i, std::int64_t v) {
  check_bind(db_, path_, sqlite3_bind_int64(stmt_, i, v));
  return *this;
}
Stmt& Stmt::bind_double(int i, double v) {
  check_bind(db_, path_, sqlite3_bind_double(stmt_, i, v));
  return *this;
}
Stmt& Stmt::bind_text(int i, std::string_view v) {
  // data() of an empty view may be null, which SQLite would bind as NULL; "" binds an empty text.
  check_bind(db_, path_, sqlite3_bind_text(stmt_, i, v.empty() ? "" : v.data(), length_of(v, path_), SQLITE_TRANSIENT));
  return *this;
}
Stmt& Stmt::bind_blob_static(int i, std::string_view v) {
  check_bind(db_, path_,
             v.empty() ? sqlite3_bind_zeroblob(stmt_, i, 0)
                       : sqlite3_bind_blob(stmt_, i, v.data(), length_of(v, path_), SQLITE_STATIC));
  return *this;
}
Stmt& Stmt::bind_null(int i) {
  check_bind(db_, path_, sqlite3_bind_null(stmt_, i));
  return *this;
}
Stmt& Stmt::bind_opt_int64(int i, const std::optional<std::int64_t>& v) { return v ? bind_int64(i, *v) : bind_null(i); }

bool Stmt::step() {
  int rc = sqlite3_step(stmt_);
  if (rc == SQLITE_ROW) return true;
  if (rc == SQLITE_DONE) return false;
  std::string sql = sqlite3_sql(stmt_) ? sqlite3_sql(stmt_) : "";
  std::string head = sql.substr(0, sql.find_first_of(" \n"));
  // The statement's error message is the one to report; reset clears nothing of it.
  fail(db_, path_, head.empty() ? std::string("statement failed") : head + " failed");
}

void Stmt::run() {
  while (step()) {
  }
}

void Stmt::reset() { sqlite3_reset(stmt_); }

bool Stmt::is_null(int col) const { return sqlite3_column_type(stmt_, col) == SQLITE_NULL; }
std::int64_t Stmt::int64(int col) const { return sqlite3_column_int64(stmt_, col); }
double Stmt::real(int col) const { return sqlite3_column_double(stmt_, col); }
std::string Stmt::text(int col) const {
  const unsigned char* p = sqlite3_column_text(stmt_, col);
  int n = sqlite3_column_bytes(stmt_, col);
  return p ? std::string(reinterpret_cast<const char*>(p), static_cast<std::size_t>(n)) : std::string();
}
std::string Stmt::blob(int col) const {
  const void* p = sqlite3_column_blob(stmt_, col);
  int n = sqlite3_column_bytes(stmt_, col);
  return p ? std::string(static_cast<const char*>(p), static_cast<std::size_t>(n)) : std::string();
}
std::optional<std::int64_t> Stmt::opt_int64(int col) const {
  if (is_null(col)) return std::nullopt;
  return int64(col);
}

bool begin_write(sqlite3* db, const std::string& path, const std::string& savepoint) {
  bool nested = sqlite3_get_autocommit(db) == 0;
  // Savepoint names are fixed identifiers from this library, never user values.
  exec(db, path, nested ? ("SAVEPOINT " + savepoint).c_str() : "BEGIN IMMEDIATE");
  return nested;
}

void commit_write(sqlite3* db, const std::string& path, const std::string& savepoint, bool nested) {
  exec(db, path, nested ? ("RELEASE " + savepoint).c_str() : "COMMIT");
}

void rollback_write_quietly(sqlite3* db, const std::string& savepoint, bool nested) noexcept {
  if (nested) {
    // Fails harmlessly when SQLite already rolled the whole transaction back (e.g. after SQLITE_FULL).
    std::string sql = "ROLLBACK TO " + savepoint + "; RELEASE " + savepoint;
    sqlite3_exec(db, sql.c_str(), nullptr, nullptr, nullptr);
  } else if (sqlite3_get_autocommit(db) == 0) {
    sqlite3_exec(db, "ROLLBACK", nullptr, nullptr, nullptr);
  }
}

WriteScope::WriteScope(sqlite3* db, const std::string& path, const char* savepoint)
    : db_(db), path_(path), savepoint_(savepoint) {
  nested_ = begin_write(db_, path_, savepoint_);
}

WriteScope::~WriteScope() {
  if (!done_) rollback_write_quietly(db_, savepoint_, nested_);
}

void WriteScope::commit() {
  commit_write(db_, path_, savepoint_, nested_);
  done_ = true;
}

}  // namespace pl::store::detail
