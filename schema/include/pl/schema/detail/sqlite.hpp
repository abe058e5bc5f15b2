// Thin RAII helpers over the SQLite C API for the store: prepared statements with bound parameters,
// and write scopes (BEGIN IMMEDIATE at the top level, a SAVEPOINT inside an open transaction).
// Every SQLite failure becomes a pl::Error "PATH: WHAT: SQLITE MESSAGE", except that a damaged file
// (SQLITE_CORRUPT, SQLITE_NOTADB, or SQLITE_TOOBIG for a value the file declares, at any point)
// gets the one message that names the fix (see damaged()).
#pragma once

#include <sqlite3.h>

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace pl::store::detail {

// The largest string or blob a store connection holds or builds (sqlite3_limit SQLITE_LIMIT_LENGTH):
// four times the largest tile pl-server accepts (64 MiB), so a damaged or crafted row that declares
// a value of gigabytes is refused before SQLite allocates it.
constexpr std::size_t kMaxValueBytes = std::size_t{256} << 20;

// The settings of every connection to a store file, which may be damaged or crafted (sqlite_util.cpp
// says why each is there). Call right after sqlite3_open_v2, before the first read.
void harden(sqlite3* db, const std::string& path);
// Lets the file's own SQL use every function and virtual table again, once the schema is known to
// be the migrations' own: their triggers keep the R*Tree in step, and SQLite 3.40 does not mark the
// R*Tree innocuous (with trusted_schema off it refuses "unsafe use of virtual table tile_rtree").
void trust_schema(sqlite3* db, const std::string& path);

// pl::Error "PATH: the map store is damaged (WHAT): restore it from a backup, or rebuild it with
// pl-map". For every value or structure in the file that breaks what the schema promises.
[[noreturn]] void damaged(const std::string& path, const std::string& what);

// Throws pl::Error "PATH: WHAT: <sqlite's message for the connection's last error>" (damaged() when
// that error says the file is damaged).
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
  int type(int col) const;  // SQLITE_INTEGER, SQLITE_FLOAT, SQLITE_TEXT, SQLITE_BLOB or SQLITE_NULL
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
