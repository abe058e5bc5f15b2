// The SQLite toolkit of the map store and the tile cache (pl/schema/detail/sqlite.hpp).
#include "pl/schema/detail/sqlite.hpp"

#include <cmath>
#include <mutex>

#include "pl/common/error.hpp"
#include "pl/schema/api_rules.hpp"

namespace pl::sqlite {

namespace {

// SQLite's own words for a file it cannot make sense of: a b-tree, record or header that breaks
// the file format (SQLITE_CORRUPT, also from the R*Tree), or no database header at all.
bool says_damaged(int rc) {
  int primary = rc & 0xFF;
  return primary == SQLITE_CORRUPT || primary == SQLITE_NOTADB;
}

void config(const Db& db, int option, int value, const char* name) {
  int now = -1;
  if (sqlite3_db_config(db.get(), option, value, &now) != SQLITE_OK || now != value)
    throw Error(db.path() + ": this SQLite (" + sqlite3_libversion() + ") cannot set " + name +
                ": install SQLite 3.35 or newer");
}

std::string kind_name(const Db& db) { return db.kind().name; }

}  // namespace

void configure_library() {
  static std::once_flag once;
  std::call_once(once, [] { sqlite3_config(SQLITE_CONFIG_MEMSTATUS, 0); });
}

Db checked(void* handle, const std::string& path, const FileKind& kind, StmtCache* stmts) {
  if (!handle)
    throw Error(path.empty() ? std::string(kind.name) + ": used after it was moved from"
                             : path + ": the " + kind.name + " is closed");
  return Db(static_cast<sqlite3*>(handle), path, kind, stmts);
}

// Both files are read from disks that may fail and may have been handed over by someone else. Each
// setting closes one way such a file, or SQL in it, could do harm; none changes what a sound file
// answers.
void prepare_connection(const Db& db) {
  sqlite3* h = db.get();
  sqlite3_extended_result_codes(h, 1);
  sqlite3_busy_timeout(h, kBusyTimeoutMs);
  // Ordinary SQL cannot corrupt the file: no writable_schema, no journal_mode=OFF, no direct writes
  // to an R*Tree's shadow tables (tile_rtree_node, ...), whose bytes the R*Tree code trusts.
  config(db, SQLITE_DBCONFIG_DEFENSIVE, 1, "SQLITE_DBCONFIG_DEFENSIVE");
  // Until the user has found the file's schema to be exactly its own (check_schema, trust_schema),
  // SQL kept in the file (triggers, views, CHECK and DEFAULT expressions, index expressions) may call
  // only functions and virtual tables marked innocuous.
  config(db, SQLITE_DBCONFIG_TRUSTED_SCHEMA, 0, "SQLITE_DBCONFIG_TRUSTED_SCHEMA");
  // Neither file has views: a view in a crafted file must not run in place of a table.
  config(db, SQLITE_DBCONFIG_ENABLE_VIEW, 0, "SQLITE_DBCONFIG_ENABLE_VIEW");
  // Debian's SQLite is built with the two-argument fts3_tokenizer(), which takes a C function
  // pointer from SQL; nothing here uses FTS.
  config(db, SQLITE_DBCONFIG_ENABLE_FTS3_TOKENIZER, 0, "SQLITE_DBCONFIG_ENABLE_FTS3_TOKENIZER");
  config(db, SQLITE_DBCONFIG_ENABLE_LOAD_EXTENSION, 0, "SQLITE_DBCONFIG_ENABLE_LOAD_EXTENSION");
  // SQLite already refuses a record that declares more bytes than the file has, or more than its
  // default limit of 1e9; this lower limit also bounds what a large file can make it allocate for
  // one value (once by SQLite, once more in a std::string): SQLITE_TOOBIG before any allocation.
  sqlite3_limit(h, SQLITE_LIMIT_LENGTH, static_cast<int>(kMaxValueBytes));
  // Neither user attaches another file; no SQL they run can reach one.
  sqlite3_limit(h, SQLITE_LIMIT_ATTACHED, 0);
  // The store's triggers nest one deep (a tile write updates the R*Tree), the cache has none; Debian
  // builds SQLite with recursive triggers on, so bound any chain well below SQLite's 1000.
  sqlite3_limit(h, SQLITE_LIMIT_TRIGGER_DEPTH, 16);
  // Check each b-tree cell's size as its page is read: damage is reported where it is, instead of
  // being read past (or, by a writer, spread). A few per cent of CPU on reads.
  exec(db, "PRAGMA cell_size_check = ON");
  // No memory-mapped reads (the build's default, made explicit): a file truncated while mapped
  // would kill the process with SIGBUS instead of giving an error.
  exec(db, "PRAGMA mmap_size = 0");
  if (sqlite3_db_readonly(h, "main") == 1)
    throw Error(db.path() + ": the " + kind_name(db) + " is read-only (check the permissions of the file and its folder)");
}

void trust_schema(const Db& db) { config(db, SQLITE_DBCONFIG_TRUSTED_SCHEMA, 1, "SQLITE_DBCONFIG_TRUSTED_SCHEMA"); }

void damaged(const Db& db, const std::string& what) {
  throw Error(db.path() + ": the " + kind_name(db) + " is damaged (" + what + "): " + db.kind().if_damaged);
}

void fail(const Db& db, const std::string& what) {
  if (!db.get()) throw Error(db.path() + ": " + what + ": out of memory");
  int rc = sqlite3_extended_errcode(db.get());
  // Values written are checked against the length limit before they are bound (length_of), so
  // SQLITE_TOOBIG ("string or blob too big") can only come from a value the file declares.
  if (says_damaged(rc) || (rc & 0xFF) == SQLITE_TOOBIG) damaged(db, sqlite3_errmsg(db.get()));
  throw Error(db.path() + ": " + what + ": " + sqlite3_errmsg(db.get()));
}

void exec(const Db& db, const char* sql) {
  char* err = nullptr;
  int rc = sqlite3_exec(db.get(), sql, nullptr, nullptr, &err);
  if (rc != SQLITE_OK) {
    std::string msg = err ? err : sqlite3_errstr(rc);
    sqlite3_free(err);
    if (says_damaged(rc)) damaged(db, msg);
    std::string head(sql);
    if (head.size() > 40) head = head.substr(0, 37) + "...";
    throw Error(db.path() + ": " + head + ": " + msg);
  }
}

std::int64_t query_int(const Db& db, const char* sql) {
  Stmt st(db, sql);
  return st.step() ? st.int64(0) : 0;
}

std::string plain(const std::string& s, std::size_t max) {
  std::string out;
  for (char c : s.substr(0, max)) out += c == '\n' ? std::string("; ") : std::string(1, (c >= 0x20 && c < 0x7F) ? c : '?');
  return s.size() > max ? out + "..." : out;
}

// ---- statements ----------------------------------------------------------------------------------

StmtCache::~StmtCache() {
  for (auto& [sql, s] : kept_) sqlite3_finalize(s);
}

sqlite3_stmt* StmtCache::take(const char* sql) {
  auto it = kept_.find(std::string_view(sql));
  if (it == kept_.end()) return nullptr;
  sqlite3_stmt* s = it->second;
  kept_.erase(it);
  return s;
}

void StmtCache::give(sqlite3_stmt* s) {
  const char* sql = sqlite3_sql(s);  // the text it was prepared from (the caller's may be gone)
  // reset ends the statement's read of the file (its transaction) as finalize would; its result
  // repeats the last step's error, which that step has reported already.
  sqlite3_reset(s);
  sqlite3_clear_bindings(s);
  if (!sql || kept_.size() >= kMaxKept || !kept_.emplace(sql, s).second) sqlite3_finalize(s);
}

Stmt::Stmt(const Db& db, const char* sql) : db_(db) {
  if (db.stmts() && (stmt_ = db.stmts()->take(sql))) return;
  // SQLITE_PREPARE_PERSISTENT when kept: SQLite allocates the statement for a long life.
  const unsigned flags = db.stmts() ? SQLITE_PREPARE_PERSISTENT : 0;
  if (sqlite3_prepare_v3(db.get(), sql, -1, flags, &stmt_, nullptr) != SQLITE_OK) {
    sqlite3_finalize(stmt_);
    stmt_ = nullptr;
    fail(db, std::string("preparing \"") + sql + "\"");
  }
}

Stmt::~Stmt() {
  if (stmt_ && db_.stmts())
    db_.stmts()->give(stmt_);
  else
    sqlite3_finalize(stmt_);
}

namespace {
void check_bind(const Db& db, int rc) {
  if (rc != SQLITE_OK) fail(db, "binding a parameter");
}
int length_of(std::string_view v, const Db& db) {
  static_assert(kMaxValueBytes <= static_cast<std::size_t>(std::numeric_limits<int>::max()));
  if (v.size() > kMaxValueBytes)
    throw Error(db.path() + ": a value of " + std::to_string(v.size()) + " bytes is larger than the " + kind_name(db) +
                "'s limit of " + std::to_string(kMaxValueBytes >> 20) + " MiB");
  return static_cast<int>(v.size());
}
}  // namespace

Stmt& Stmt::bind_int64(int i, std::int64_t v) {
  check_bind(db_, sqlite3_bind_int64(stmt_, i, v));
  return *this;
}
Stmt& Stmt::bind_double(int i, double v) {
  check_bind(db_, sqlite3_bind_double(stmt_, i, v));
  return *this;
}
Stmt& Stmt::bind_text(int i, std::string_view v) {
  // data() of an empty view may be null, which SQLite would bind as NULL; "" binds an empty text.
  check_bind(db_, sqlite3_bind_text(stmt_, i, v.empty() ? "" : v.data(), length_of(v, db_), SQLITE_TRANSIENT));
  return *this;
}
Stmt& Stmt::bind_blob_static(int i, std::string_view v) {
  // Likewise zeroblob(0) is an empty blob where a null pointer would bind NULL.
  check_bind(db_, v.empty() ? sqlite3_bind_zeroblob(stmt_, i, 0)
                            : sqlite3_bind_blob(stmt_, i, v.data(), length_of(v, db_), SQLITE_STATIC));
  return *this;
}
Stmt& Stmt::bind_null(int i) {
  check_bind(db_, sqlite3_bind_null(stmt_, i));
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
  fail(db_, head.empty() ? std::string("statement failed") : head + " failed");
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

// ---- checked rows --------------------------------------------------------------------------------

std::int64_t Row::integer(int col, const char* column, std::int64_t min, std::int64_t max) const {
  if (st_.type(col) != SQLITE_INTEGER) bad(column, "is not an integer");
  std::int64_t v = st_.int64(col);
  if (v < min || v > max) bad(column, "is out of range (" + std::to_string(v) + ")");
  return v;
}

std::optional<std::int64_t> Row::opt_integer(int col, const char* column, std::int64_t min, std::int64_t max) const {
  if (st_.is_null(col)) return std::nullopt;
  return integer(col, column, min, max);
}

double Row::number(int col, const char* column, double min, double max) const {
  int type = st_.type(col);
  if (type != SQLITE_FLOAT && type != SQLITE_INTEGER) bad(column, "is not a number");
  double v = st_.real(col);
  if (!std::isfinite(v)) bad(column, "is not finite");
  if (!(v >= min && v <= max)) bad(column, "is out of range (" + std::to_string(v) + ")");
  return v;
}

double Row::positive(int col, const char* column) const {
  double v = number(col, column);
  if (!(v > 0)) bad(column, "is not a positive number (" + std::to_string(v) + ")");
  return v;
}

std::string Row::text(int col, const char* column) const {
  if (st_.type(col) != SQLITE_TEXT) bad(column, "is not text");
  return st_.text(col);
}

std::string Row::hash(int col, const char* column) const {
  std::string s = text(col, column);
  if (!api::is_hash(s)) bad(column, "is not a SHA-256 hash (64 lowercase hex digits)");
  return s;
}

std::string Row::blob(int col, const char* column) const {
  if (st_.type(col) != SQLITE_BLOB) bad(column, "is not a blob");
  return st_.blob(col);
}

void Row::require(int col, const std::string& what) const {
  if (st_.type(col) != SQLITE_INTEGER || st_.int64(col) != 1) damaged(st_.db(), std::string(table_) + ": " + what);
}

void Row::bad(const char* column, const std::string& why) const {
  damaged(st_.db(), std::string(table_) + "." + column + " " + why);
}

// ---- transactions --------------------------------------------------------------------------------

bool begin_write(const Db& db, const std::string& savepoint) {
  bool nested = sqlite3_get_autocommit(db.get()) == 0;
  // Savepoint names are fixed identifiers of the users, never outside values.
  exec(db, nested ? ("SAVEPOINT " + savepoint).c_str() : "BEGIN IMMEDIATE");
  return nested;
}

void commit_write(const Db& db, const std::string& savepoint, bool nested) {
  exec(db, nested ? ("RELEASE " + savepoint).c_str() : "COMMIT");
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

WriteScope::WriteScope(const Db& db, const char* savepoint) : db_(db), savepoint_(savepoint) {
  nested_ = begin_write(db_, savepoint_);
}

WriteScope::~WriteScope() {
  if (!done_) rollback_write_quietly(db_.get(), savepoint_, nested_);
}

void WriteScope::commit() {
  commit_write(db_, savepoint_, nested_);
  done_ = true;
}

ReadSnapshot::ReadSnapshot(const Db& db) : db_(db) { exec(db_, "BEGIN"); }

ReadSnapshot::~ReadSnapshot() {
  if (open_) sqlite3_exec(db_.get(), "ROLLBACK", nullptr, nullptr, nullptr);
}

void ReadSnapshot::end() {
  open_ = false;
  exec(db_, "COMMIT");
}

}  // namespace pl::sqlite
