// Thin RAII helpers over the SQLite C API for the store: prepared statements with bound parameters,
// and write scopes (BEGIN IMMEDIATE at the top level, a SAVEPOINT inside an open transaction).
// Every SQLite failure becomes a pl::Error "PATH: WHAT: SQLITE MESSAGE".
#pragma once

#include <sqlite3.h>

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace pl::store::detail {

// Throws pl::Error "PATH: WHAT: <sqlite's message for the connection's last error>".
[[noreturn]] void fail(sqlite3* db, const std::string& path, const std::string& what);

// Runs SQL without parameters (may hold several statements). Only for fixed SQL text.
void exec(sqlite3* db, const std::string& path, const char* sql);

class Stmt {
 public:
  Stmt(sqlite3* db, const std::string& path, const char* sql);
  ~Stmt();
  Stmt(const Stmt&) = delete;
  Stmt& operator=(const Stmt&) = delete;

  // Parameters are numbered from 1 (write them ?1, ?2, ... in the SQL).
  Stmt& bind_int64(int i, std::int64_t v);
  Stmt& bind_double(int i, double v);
  Stmt& bind_text(int i, std::string_view v);         // copied
  Stmt& bind_blob_static(int i, std::string_view v);  // not copied: must outlive every step()
  Stmt& bind_null(int i);
  Stmt& bind_opt_int64(int i, const std::optional<std::int64_t>& v);

  bool step();   // true: a row is ready; false: done. Throws on error.
  void run();    // steps to the end, ignoring rows
  void reset();  // ready to step again (bindings stay)

  bool is_null(int col) const;
  std::int64_t int64(int col) const;
  double real(int col) const;
  std::string text(int col) const;
  std::string blob(int col) const;
  std::optional<std::int64_t> opt_int64(int col) const;

 private:
  sqlite3* db_;
  const std::string& path_;
  sqlite3_stmt* stmt_ = nullptr;
};

// One all-or-nothing group of writes. At the top level it is BEGIN IMMEDIATE ... COMMIT (the write
// lock is taken at the start, so WAL readers never have to upgrade and the busy timeout applies);
// inside an open transaction it is SAVEPOINT name ... RELEASE name, so a failure undoes only this
// group. Rolls back when destroyed uncommitted; never throws from the destructor.
class WriteScope {
 public:
  WriteScope(sqlite3* db, const std::string& path, const char* savepoint = "pl_write");
  ~WriteScope();
  WriteScope(const WriteScope&) = delete;
  WriteScope& operator=(const WriteScope&) = delete;
  void commit();
  bool nested() const { return nested_; }

 private:
  sqlite3* db_;
  const std::string& path_;
  std::string savepoint_;
  bool nested_ = false;
  bool done_ = false;
};

// The pieces WriteScope and Store::Transaction share.
bool begin_write(sqlite3* db, const std::string& path, const std::string& savepoint);  // returns nested
void commit_write(sqlite3* db, const std::string& path, const std::string& savepoint, bool nested);
void rollback_write_quietly(sqlite3* db, const std::string& savepoint, bool nested) noexcept;

}  // namespace pl::store::detail
