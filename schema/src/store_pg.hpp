// The map store over PostgreSQL (libpqxx): a StoreBackend over one connection to a database named
// by a postgresql:// URL. store_pg.cpp: opening, migrating, transactions, maps and versions;
// store_pg_tiles.cpp: tiles, blobs, places, tokens, the upload log and maintenance;
// store_pg_reports.cpp: change reports. The schema is
// schema/pg/NNN_*.sql, the SQLite schema concept for concept. Private to pl_schema.
//
// Transactions: libpqxx's transaction classes are scoped objects, one at a time per connection,
// while a Store::Transaction spans many Store calls. So every statement runs through a
// pqxx::nontransaction (a plain executor that sends no BEGIN or COMMIT of its own), and the store
// sends the transaction control itself: BEGIN / COMMIT / ROLLBACK for a Store::Transaction at depth
// 0 and SAVEPOINT pl_transaction / RELEASE / ROLLBACK TO inside one. Each call is all-or-nothing on
// its own: outside a Transaction it is one transaction (BEGIN ... COMMIT, or a single autocommitted
// statement for reads and single-statement writes), inside one it is a savepoint (pl_call), rolled
// back to when the call fails, so a failed call leaves the Transaction's earlier writes in place and
// the transaction usable (PostgreSQL refuses every statement of a transaction after an error until
// it is rolled back to a savepoint). The connection never reconnects on its own: a transaction must
// not go on silently on a new connection that does not hold it.
//
// Concurrency (several connections and processes on one database, READ COMMITTED): every write
// to a map starts by locking the map's row (SELECT ... FOR NO KEY UPDATE), so writers to one map
// take turns and create_version numbers without gaps or duplicates, while readers never wait. Blobs
// are shared between maps: a put_tile holds the blob's row (FOR KEY SHARE) from before its tile row
// is written until it commits, and the garbage collection of a blob locks it (FOR UPDATE) and then
// looks for users in a new statement (a new snapshot), so it never deletes a blob a concurrent
// put_tile is about to use. Migrations at open take a transaction-scoped advisory lock.
#pragma once

#include <pqxx/pqxx>

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
#include <vector>

#include "store_backend.hpp"

namespace pl::store::detail {

class PgStore final : public StoreBackend {
 public:
  // Connects to `url`, checks that the database is a map store (or empty, with `create`), migrates
  // it and prepares the statements. Throws pl::Error naming the URL (its password as ***).
  PgStore(const std::string& url, bool create);

  const std::string& path() const override { return name_; }
  int schema_version() const override;

  MapInfo create_map(const std::string& name, const GeoPoint& origin, double tile_size, double voxel_size) override;
  std::optional<MapInfo> find_map(const std::string& name) const override;
  std::vector<MapInfo> list_maps() const override;

  VersionInfo create_version(const std::string& map, std::optional<std::int64_t> parent, const std::string& note) override;
  std::optional<VersionInfo> find_version(const std::string& map, std::int64_t number) const override;
  std::vector<VersionInfo> list_versions(const std::string& map) const override;
  bool publish(const std::string& map, std::int64_t number,
               const std::optional<std::optional<std::int64_t>>& only_if_current,
               std::optional<std::int64_t> restores) override;
  std::int64_t rollback_target(const std::string& map) const override;

  TileRecord put_tile(const std::string& map, std::int64_t version, const TileKey& key, std::string_view draco_bytes,
                      std::int64_t points, double min_x, double min_y, double min_z, double max_x, double max_y,
                      double max_z) override;
  bool delete_tile(const std::string& map, std::int64_t version, const TileKey& key) override;
  std::optional<TileRecord> find_tile(const std::string& map, std::int64_t version, const TileKey& key) const override;
  std::vector<TileRecord> list_tiles(const std::string& map, std::int64_t version) const override;
  std::vector<TileRecord> tiles_in_box(const std::string& map, std::int64_t version, double min_x, double min_y,
                                       double max_x, double max_y) const override;
  std::optional<std::string> blob(const std::string& hash) const override;
  bool has_blob(const std::string& hash) const override;

  void put_places(const std::string& map, std::int64_t version, std::string_view bytes) override;
  bool delete_places(const std::string& map, std::int64_t version) override;
  std::optional<std::string> places(const std::string& map, std::int64_t version) const override;
  std::optional<std::string> places_hash(const std::string& map, std::int64_t version) const override;

  bool usable() const override { return conn_->is_open(); }
  void put_signature(const std::string& map, std::int64_t version, std::string_view public_key,
                     std::string_view signature) override;
  std::optional<Store::Signature> signature(const std::string& map, std::int64_t version) const override;
  std::int64_t add_token(const std::string& token, Role role, const std::string& note) override;
  std::optional<std::pair<Store::TokenInfo, std::string>> token_by_hash(const std::string& hash) const override;
  bool revoke_token(std::int64_t id) override;
  std::vector<Store::TokenInfo> list_tokens() const override;

  void log_upload(const std::string& map, std::optional<std::int64_t> version, const std::string& action,
                  const std::string& detail, const std::string& who) override;
  std::vector<Store::LogEntry> upload_log(const std::string& map) const override;

  Store::ReportPut put_report(const std::string& map, std::int64_t version, const std::string& vehicle,
                              const std::string& drive, double start, double end, std::string_view body,
                              const std::string& hash, const std::string& who) override;
  std::vector<Store::ReportInfo> list_reports(const std::string& map, std::optional<std::int64_t> version) const override;
  std::optional<std::string> report_body(const std::string& map, std::int64_t id) const override;
  std::int64_t delete_reports(const std::string& map, const std::string& received_before) override;

  bool begin_transaction() override;
  void commit_transaction(bool nested) override;
  void rollback_transaction_quietly(bool nested) noexcept override;

  std::int64_t database_bytes() const override;
  bool integrity_ok(bool hash_bytes) const override;
  // The exact copy (store_copy_sqlite.cpp / store_pg_copy.cpp).
  void export_rows(RowSink& out) const override;
  StoreContent content() const override;
  std::unique_ptr<RowSink> importer() override;

  // ---- for the implementation files ----

  using Work = pqxx::nontransaction;
  // The connection, and whether a Store::Transaction is open on it (the exact copy's reader and
  // writer, store_pg_copy.cpp, send their own statements).
  pqxx::connection& connection() const { return *conn_; }
  bool in_transaction() const { return depth_ > 0; }

  // Runs f(Work&) all-or-nothing: one transaction outside a Store::Transaction, a savepoint inside
  // one. Every failure leaves as a pl::Error naming the database.
  template <typename F>
  auto atomically(F&& f) const -> std::invoke_result_t<F, Work&> {
    return guarded([&] {
      Work w(*conn_);
      const bool nested = depth_ > 0;
      w.exec(nested ? "SAVEPOINT pl_call" : "BEGIN");
      try {
        if constexpr (std::is_void_v<std::invoke_result_t<F, Work&>>) {
          f(w);
          w.exec(nested ? "RELEASE SAVEPOINT pl_call" : "COMMIT");
        } else {
          auto result = f(w);
          w.exec(nested ? "RELEASE SAVEPOINT pl_call" : "COMMIT");
          return result;
        }
      } catch (...) {
        undo(w, nested);
        throw;
      }
    });
  }

  // Runs f(Work&), whose one statement is atomic on its own (a read, a single insert): sent as it is
  // outside a Store::Transaction, in a savepoint inside one (so that its failure does not abort the
  // Transaction).
  template <typename F>
  auto one_statement(F&& f) const -> std::invoke_result_t<F, Work&> {
    if (depth_ > 0) return atomically(std::forward<F>(f));
    return guarded([&] {
      Work w(*conn_);
      return f(w);
    });
  }

  // Runs f(), turning libpqxx's exceptions into pl::Error "NAME: WHAT" (pl::Error passes through).
  template <typename F>
  auto guarded(F&& f) const -> decltype(f()) {
    try {
      return f();
    } catch (const pqxx::broken_connection& e) {
      fail_connection(e);
    } catch (const pqxx::sql_error& e) {
      fail_sql(e);
    } catch (const pqxx::failure& e) {
      fail_other(e);
    } catch (const pqxx::usage_error& e) {
      fail_other(e);
    } catch (const pqxx::conversion_error& e) {
      fail_other(e);
    }
  }

  [[noreturn]] void damaged(const std::string& what) const;
  [[noreturn]] void fail_connection(const std::exception& e) const;
  [[noreturn]] void fail_sql(const pqxx::sql_error& e) const;
  [[noreturn]] void fail_other(const std::exception& e) const;
  // Free text (notes, the upload log) must be text PostgreSQL can hold: UTF-8 without NUL bytes.
  void require_text(const std::string& s, const char* what) const;

  // Lookups inside a write (atomically): the map's row locked, a version's state.
  std::int64_t lock_map(Work& w, const std::string& name) const;  // throws for an unknown map
  std::optional<VersionState> version_state(Work& w, std::int64_t map_id, std::int64_t number) const;
  VersionState require_version(Work& w, const std::string& map, std::int64_t map_id, std::int64_t number) const;
  void require_staged(Work& w, const std::string& map, std::int64_t map_id, std::int64_t number,
                      const char* what) const;
  std::optional<VersionInfo> version_by_id(Work& w, std::int64_t map_id, std::int64_t number) const;

 private:
  void undo(Work& w, bool nested) const noexcept;
  void check_and_migrate(bool create);
  void prepare_statements();

  std::string name_;  // the URL without its password
  std::unique_ptr<pqxx::connection> conn_;  // never null
  int depth_ = 0;  // open Store::Transaction levels: 0 none, 1 a BEGIN, more: savepoints in it
};

// ---- values read from the database ---------------------------------------------------------------
// PostgreSQL enforces the schema's types, NOT NULL and CHECK constraints on every write, but a
// database restored from a damaged backup or edited with its triggers and constraints off may
// still break what the store promises (a hash that does not match its bytes, a current version that
// is not published): those reads are the "damaged" error, as on SQLite.

class PgRow {
 public:
  PgRow(const PgStore& store, const pqxx::row& row, const char* table) : store_(store), row_(row), table_(table) {}

  std::int64_t integer(int col, const char* column, std::int64_t min = INT64_MIN, std::int64_t max = INT64_MAX) const;
  std::optional<std::int64_t> opt_integer(int col, const char* column, std::int64_t min = INT64_MIN,
                                          std::int64_t max = INT64_MAX) const;
  double number(int col, const char* column, double min = -1.7976931348623157e308,
                double max = 1.7976931348623157e308) const;
  double positive(int col, const char* column) const;
  std::string text(int col, const char* column) const;
  std::string hash(int col, const char* column) const;
  std::string bytes(int col, const char* column) const;  // a bytea
  std::string timestamp(int col, const char* column) const;
  VersionState state(int col, const char* column) const;
  // A condition computed by the query itself that must hold: damaged "TABLE: WHAT".
  void require(int col, const std::string& what) const;
  [[noreturn]] void bad(const char* column, const std::string& why) const;

 private:
  const char* raw(int col, const char* column) const;  // non-NULL text of the field
  const PgStore& store_;
  const pqxx::row row_;  // a handle sharing the result (r[i] is a temporary)
  const char* table_;
};

// SQL of a timestamptz column as store.hpp writes timestamps (UTC, milliseconds, 'Z').
#define PL_PG_TIMESTAMP(column) "to_char(" column " AT TIME ZONE 'UTC', 'YYYY-MM-DD\"T\"HH24:MI:SS.MS\"Z\"')"

// Parameters: doubles written exactly (shortest round-trip form), optional integers as NULL.
std::string pg_double(double v);
const char* pg_opt(const std::optional<std::string>& s);
std::optional<std::string> pg_opt_int(const std::optional<std::int64_t>& v);
std::string pg_num(std::int64_t v);

// A row of tx, ty, hash, points, bytes, min_x, min_y, min_z, max_x, max_y, max_z, checked;
// `first`: the column its tx is in (the exact copy's rows have their ids before it).
TileRecord read_pg_tile(const PgStore& store, const pqxx::row& row, int first = 0);

// The statements (prepared once at open): name and SQL.
struct PgStatement {
  const char* name;
  const char* sql;
};
extern const PgStatement kPgStatements[];
extern const std::size_t kPgStatementCount;
extern const PgStatement kPgTileStatements[];
extern const std::size_t kPgTileStatementCount;
extern const PgStatement kPgReportStatements[];
extern const std::size_t kPgReportStatementCount;

}  // namespace pl::store::detail
