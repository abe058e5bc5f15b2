#include "pl/schema/detail/sqlite.hpp"

#include <limits>

#include "pl/common/error.hpp"

namespace pl::store::detail {

namespace {

// SQLite's own words for a file it cannot make sense of: a b-tree, record or header that breaks
// the file format (SQLITE_CORRUPT, also from the R*Tree), or no database header at all.
bool says_damaged(int rc) {
  int primary = rc & 0xFF;
  return primary == SQLITE_CORRUPT || primary == SQLITE_NOTADB;
}

void config(sqlite3* db, const std::string& path, int option, int value, const char* name) {
  int now = -1;
  if (sqlite3_db_config(db, option, value, &now) != SQLITE_OK || now != value)
    throw Error(path + ": this SQLite (" + sqlite3_libversion() + ") cannot set " + name +
                ": install SQLite 3.35 or newer");
}

}  // namespace

// The map store is read from files that may be damaged (a failing disk, a torn copy) or crafted (a
// store handed over by someone else). Each setting closes one way such a file, or SQL in it, could
// do harm; none changes what a sound store answers.
void harden(sqlite3* db, const std::string& path) {
  // Ordinary SQL cannot corrupt the file: no writable_schema, no journal_mode=OFF, no direct writes
  // to the R*Tree's shadow tables (tile_rtree_node, ...), whose bytes the R*Tree code trusts.
  config(db, path, SQLITE_DBCONFIG_DEFENSIVE, 1, "SQLITE_DBCONFIG_DEFENSIVE");
  // Until Store::open has found the file's schema to be exactly the migrations' own (trust_schema),
  // SQL kept in the file (triggers, views, CHECK and DEFAULT expressions, index expressions) may call
  // only functions and virtual tables marked innocuous.
  config(db, path, SQLITE_DBCONFIG_TRUSTED_SCHEMA, 0, "SQLITE_DBCONFIG_TRUSTED_SCHEMA");
  // The store has no views: a view in a crafted file must not run in place of a table.
  config(db, path, SQLITE_DBCONFIG_ENABLE_VIEW, 0, "SQLITE_DBCONFIG_ENABLE_VIEW");
  // Debian's SQLite is built with the two-argument fts3_tokenizer(), which takes a C function
  // pointer from SQL; nothing here uses FTS.
  config(db, path, SQLITE_DBCONFIG_ENABLE_FTS3_TOKENIZER, 0, "SQLITE_DBCONFIG_ENABLE_FTS3_TOKENIZER");
  config(db, path, SQLITE_DBCONFIG_ENABLE_LOAD_EXTENSION, 0, "SQLITE_DBCONFIG_ENABLE_LOAD_EXTENSION");
  // SQLite already refuses a record that declares more bytes than the file has, or more than its
  // default limit of 1e9; this lower limit also bounds what a large file can make it allocate for
  // one value (once by SQLite, once more in a std::string): SQLITE_TOOBIG before any allocation.
  sqlite3_limit(db, SQLITE_LIMIT_LENGTH, static_cast<int>(kMaxValueBytes));
  // The store never attaches another file; no SQL it runs can reach one.
  sqlite3_limit(db, SQLITE_LIMIT_ATTACHED, 0);
  // The schema's triggers nest one deep (a tile write updates the R*Tree); Debian builds SQLite with
  // recursive triggers on, so bound any chain well below SQLite's 1000.
  sqlite3_limit(db, SQLITE_LIMIT_TRIGGER_DEPTH, 16);
  // Check each b-tree cell's size as its page is read: damage is reported where it is, instead of
  // being read past (or, by a writer, spread). A few per cent of CPU on reads.
  exec(db, path, "PRAGMA cell_size_check = ON");
  // No memory-mapped reads (the build's default, made explicit): a file truncated while mapped
  // would kill the process with SIGBUS instead of giving an error.
  exec(db, path, "PRAGMA mmap_size = 0");
}

void trust_schema(sqlite3* db, const std::string& path) {
  config(db, path, SQLITE_DBCONFIG_TRUSTED_SCHEMA, 1, "SQLITE_DBCONFIG_TRUSTED_SCHEMA");
}

void damaged(const std::string& path, const std::string& what) {
  throw Error(path + ": the map store is damaged (" + what + "): restore it from a backup, or rebuild it with pl-map");
}

void fail(sqlite3* db, const std::string& path, const std::string& what) {
  if (!db) throw Error(path + ": " + what + ": out of memory");
  int rc = sqlite3_extended_errcode(db);
  // Values written are checked against the length limit before they are bound (length_of), so
  // SQLITE_TOOBIG ("string or blob too big") can only come from a value the file declares.
  if (says_damaged(rc) || (rc & 0xFF) == SQLITE_TOOBIG) damaged(path, sqlite3_errmsg(db));
  throw Error(path + ": " + what + ": " + sqlite3_errmsg(db));
}

void exec(sqlite3* db, const std::string& path, const char* sql) {
  char* err = nullptr;
  int rc = sqlite3_exec(db, sql, nullptr, nullptr, &err);
  if (rc != SQLITE_OK) {
    std::string msg = err ? err : sqlite3_errstr(rc);
    sqlite3_free(err);
    if (says_damaged(rc)) damaged(path, msg);
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
  static_assert(kMaxValueBytes <= static_cast<std::size_t>(std::numeric_limits<int>::max()));
  if (v.size() > kMaxValueBytes)
    throw Error(path + ": a value of " + std::to_string(v.size()) + " bytes is larger than the map store's limit of " +
                std::to_string(kMaxValueBytes >> 20) + " MiB");
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
int Stmt::type(int col) const { return sqlite3_column_type(stmt_, col); }
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
