// The project's internal SQLite toolkit, shared by the two SQLite files the product opens: the map
// store (schema/src/store.cpp) and the vehicle's disk cache of tiles (client/src/tile_cache.cpp).
// It is not a stable API and no public header includes it: it lives under pl/schema/detail so that
// pl_client can reach it, and it may change with its two users.
//
// Both files may be damaged (a failing disk, a power cut, a torn copy) or crafted (a file handed
// over by someone else), so both are opened, checked and read the same way:
// - prepare_connection: extended result codes, the busy timeout, SQLite's defensive settings, and a
//   refusal of a file SQLite can only read;
// - read_header, check_identity, check_schema, quick_check: the checks made before anything is
//   written to the file (a refused file is left as it was);
// - Stmt and Row: statements with bound parameters, and a reader that checks every value against
//   what the file's own writes promise.
// Every SQLite failure becomes a pl::Error "PATH: WHAT: SQLITE MESSAGE", except that a damaged file
// (SQLITE_CORRUPT, SQLITE_NOTADB, or SQLITE_TOOBIG for a value the file declares, at any point) and
// every value that breaks a promise get the one message that names the fix:
// "PATH: the KIND is damaged (WHAT): FIX" (see FileKind and damaged()).
#pragma once

#include <sqlite3.h>

#include <cstddef>
#include <cstdint>
#include <limits>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace pl::sqlite {

// The largest string or blob a connection holds or builds (sqlite3_limit SQLITE_LIMIT_LENGTH): four
// times the largest tile pl-server accepts (64 MiB), so a damaged or crafted row that declares a
// value of gigabytes is refused before SQLite allocates it. The cache holds the store's tiles.
constexpr std::size_t kMaxValueBytes = std::size_t{256} << 20;
// How long a connection waits for another one's lock (writers take it up front: WriteScope).
constexpr int kBusyTimeoutMs = 5000;

// What a file is to the person reading a message about it.
struct FileKind {
  const char* name;              // "map store": "PATH: the map store is damaged (...)"
  std::int64_t application_id;   // PRAGMA application_id of every file of this kind
  const char* if_damaged;        // the fix for a damaged file
  const char* if_other;          // the fix for a file that is not of this kind
  const char* if_newer;          // the fix for a file written by a newer build
};

// The prepared statements of one connection kept for reuse, by SQL text. Preparing (parsing and
// planning) a short query costs SQLite more than running it: a server answering thousands of
// lookups a second spends a third of its time there without this. A statement is lent out whole
// (two Stmts of the same SQL at once get two statements) and given back reset, without bindings.
// Owned next to the connection and destroyed before it is closed (it finalizes what it keeps).
class StmtCache {
 public:
  StmtCache() = default;
  ~StmtCache();
  StmtCache(const StmtCache&) = delete;
  StmtCache& operator=(const StmtCache&) = delete;

  sqlite3_stmt* take(const char* sql);         // a kept statement of this SQL, or null
  void give(sqlite3_stmt* s);                   // keeps it (reset and cleared), or finalizes it

 private:
  static constexpr std::size_t kMaxKept = 128;  // the store's SQL texts number about 60
  std::map<std::string, sqlite3_stmt*, std::less<>> kept_;
};

// One connection as the helpers see it: the handle, and the file's path and kind for messages, and
// the connection's kept statements (if it keeps any). Borrows all of them: it is made for a call
// (Store and TileCache own the handle, the path and the cache).
class Db {
 public:
  Db(sqlite3* handle, const std::string& path, const FileKind& kind, StmtCache* stmts = nullptr)
      : handle_(handle), path_(&path), kind_(&kind), stmts_(stmts) {}
  sqlite3* get() const { return handle_; }
  const std::string& path() const { return *path_; }
  const FileKind& kind() const { return *kind_; }
  StmtCache* stmts() const { return stmts_; }

 private:
  sqlite3* handle_;
  const std::string* path_;
  const FileKind* kind_;
  StmtCache* stmts_;
};

// The connection of an object that owns `handle` (a sqlite3*, or null once closed or moved from):
// throws pl::Error "KIND: used after it was moved from" (no path) or "PATH: the KIND is closed".
Db checked(void* handle, const std::string& path, const FileKind& kind, StmtCache* stmts = nullptr);

// Process-wide settings, made once before the first connection opens (no-ops once SQLite has
// started, e.g. when another part of the program opened a database first): no memory statistics,
// whose global mutex every allocation takes, so that threads on separate connections do not wait
// on each other.
void configure_library();

// The settings of every connection, made right after sqlite3_open_v2(SQLITE_OPEN_READWRITE ...),
// before the first read (sqlite.cpp says why each is there); then refuses a file SQLite may only
// read ("PATH: the KIND is read-only (check the permissions of the file and its folder)").
void prepare_connection(const Db& db);
// Lets the file's own SQL use every function and virtual table again, once check_schema has found
// it to be the user's own (the store's triggers keep its R*Tree in step, and SQLite 3.40 does not
// mark the R*Tree innocuous: with trusted_schema off it refuses "unsafe use of virtual table").
void trust_schema(const Db& db);

// pl::Error "PATH: the KIND is damaged (WHAT): FIX". For every value or structure in the file that
// breaks what its writes promise, and for SQLite's own reports of damage.
[[noreturn]] void damaged(const Db& db, const std::string& what);
// Throws pl::Error "PATH: WHAT: <sqlite's message for the connection's last error>" (damaged() when
// that error says the file is damaged).
[[noreturn]] void fail(const Db& db, const std::string& what);

// Runs SQL without parameters (may hold several statements). Only for fixed SQL text.
void exec(const Db& db, const char* sql);
// The first column of the first row of a query without parameters (0 when there is no row).
std::int64_t query_int(const Db& db, const char* sql);

// Text from the file for a message: one line of printable ASCII, at most `max` characters.
std::string plain(const std::string& s, std::size_t max = 160);

// A statement: taken from the connection's StmtCache when it keeps one of this SQL (else prepared),
// and given back to it when destroyed (else finalized).
class Stmt {
 public:
  Stmt(const Db& db, const char* sql);
  ~Stmt();
  Stmt(const Stmt&) = delete;
  Stmt& operator=(const Stmt&) = delete;

  // Parameters are numbered from 1 (write them ?1, ?2, ... in the SQL). A text or blob larger than
  // kMaxValueBytes is refused: "PATH: a value of N bytes is larger than the KIND's limit of 256 MiB".
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

  const Db& db() const { return db_; }

 private:
  Db db_;
  sqlite3_stmt* stmt_ = nullptr;
};

// The values of a row read from the file, checked against what the file's writes promise: SQLite
// checks neither column types nor CHECK or NOT NULL constraints on the rows it reads, and a damaged
// or crafted file may hold anything in them. A value that breaks the promise is a damaged() error
// "TABLE.COLUMN WHY" (never the value's text, which may be anything).
class Row {
 public:
  Row(const Stmt& st, const char* table) : st_(st), table_(table) {}

  std::int64_t integer(int col, const char* column, std::int64_t min = std::numeric_limits<std::int64_t>::min(),
                       std::int64_t max = std::numeric_limits<std::int64_t>::max()) const;
  // NULL, or integer().
  std::optional<std::int64_t> opt_integer(int col, const char* column, std::int64_t min, std::int64_t max) const;
  // A finite number in [min, max] (a REAL column reads an integral value as a real).
  double number(int col, const char* column, double min = -std::numeric_limits<double>::max(),
                double max = std::numeric_limits<double>::max()) const;
  double positive(int col, const char* column) const;  // a finite number > 0
  std::string text(int col, const char* column) const;
  std::string hash(int col, const char* column) const;  // text that api::is_hash accepts
  std::string blob(int col, const char* column) const;
  // A condition computed by the query itself (0 or 1) that must hold: damaged() "TABLE: WHAT".
  void require(int col, const std::string& what) const;
  [[noreturn]] void bad(const char* column, const std::string& why) const;

 private:
  const Stmt& st_;
  const char* table_;
};

// One all-or-nothing group of writes. At the top level it is BEGIN IMMEDIATE ... COMMIT (the write
// lock is taken at the start, so WAL readers never have to upgrade and the busy timeout applies);
// inside an open transaction it is SAVEPOINT name ... RELEASE name, so a failure undoes only this
// group. Rolls back when destroyed uncommitted; never throws from the destructor.
class WriteScope {
 public:
  explicit WriteScope(const Db& db, const char* savepoint = "pl_write");
  ~WriteScope();
  WriteScope(const WriteScope&) = delete;
  WriteScope& operator=(const WriteScope&) = delete;
  void commit();
  bool nested() const { return nested_; }

 private:
  Db db_;
  std::string savepoint_;
  bool nested_ = false;
  bool done_ = false;
};

// The pieces WriteScope and Store::Transaction share.
bool begin_write(const Db& db, const std::string& savepoint);  // returns nested
void commit_write(const Db& db, const std::string& savepoint, bool nested);
void rollback_write_quietly(sqlite3* db, const std::string& savepoint, bool nested) noexcept;

// One read transaction, so that the values an open checks come from one snapshot (even while
// another connection migrates the file). end() commits it; destroyed before that, it rolls back.
class ReadSnapshot {
 public:
  explicit ReadSnapshot(const Db& db);
  ~ReadSnapshot();
  ReadSnapshot(const ReadSnapshot&) = delete;
  ReadSnapshot& operator=(const ReadSnapshot&) = delete;
  void end();

 private:
  Db db_;
  bool open_ = true;
};

// ---- the checks before anything is written ---------------------------------------------------------

struct Header {
  std::int64_t application_id = 0;
  std::int64_t user_version = 0;  // the schema version
  std::int64_t objects = 0;       // tables, indexes, triggers, views
};

// The first read of the file, where a file that is not SQLite shows: "PATH: not a KIND (not a
// SQLite database: ...): IF_OTHER". A header or schema SQLite cannot use, and a header that lets
// SQLite only read the file (a write version other than 1 or 2), are damaged().
Header read_header(const Db& db);

// Refuses a file that is not of this kind, and one a newer build wrote:
// - another application's database, or one with tables but no schema version: "PATH: not a KIND
//   (...): IF_OTHER";
// - a schema version above `latest`: "PATH: the KIND has schema version N, newer than this build
//   knows (LATEST): IF_NEWER" (refuse_newer);
// - a negative schema version: damaged().
// A file without tables and without a schema version (a new, empty one) passes.
void check_identity(const Db& db, const Header& h, std::int64_t latest);
[[noreturn]] void refuse_newer(const Db& db, std::int64_t version, std::int64_t latest);

// The schema objects of a database (sqlite_schema): (type, name) -> SQL text. The objects SQLite
// makes itself with text that may differ between SQLite versions map to "": its own tables and
// automatic indexes (sqlite_*), and the shadow tables of a virtual table (e.g. tile_rtree_node for
// the R*Tree tile_rtree), whose name prefixes the user gives as `shadow_prefixes`.
using Schema = std::map<std::pair<std::string, std::string>, std::string>;
Schema read_schema(const Db& db, const std::vector<std::string>& shadow_prefixes = {});
// What `scripts` make, run in order in a private in-memory database.
Schema schema_of(const FileKind& kind, const std::vector<const char*>& scripts,
                 const std::vector<std::string>& shadow_prefixes = {});
// Refuses a file whose schema is not exactly `want`: a crafted file could otherwise keep a trigger
// that runs on the user's writes, a view or virtual table in place of a table, or a table without
// the constraints the user relies on. ANALYZE's statistics tables (sqlite_stat1, sqlite_stat4) are
// allowed too: an administrator may run it, and they only steer query plans. damaged()
// "HEAD: table X is missing" (or "... is not defined as this software defines it", "... it has an
// unknown index Y").
void check_schema(const Db& db, const Schema& want, const std::string& head,
                  const std::vector<std::string>& shadow_prefixes = {});

// PRAGMA quick_check: every page and record of the file is well formed (not the indexes' content).
// It reads the whole file, so the users run it only when an open is about to write to the file for
// the first time (a switch to WAL, a migration). damaged() "quick_check: SQLITE'S FIRST FINDING".
void quick_check(const Db& db);
std::string journal_mode(const Db& db);
// Switches the file to WAL (persistent in the file; readers next to one writer, across threads and
// processes) with synchronous = NORMAL (a power cut loses at most the last transactions, never the
// file): "PATH: cannot switch the KIND to WAL journal mode (...; WAL needs a local file system)".
void use_wal(const Db& db);

}  // namespace pl::sqlite
