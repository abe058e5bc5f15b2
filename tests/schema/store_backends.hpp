// The map store tests on both engines: a value-parameterized fixture whose store is a SQLite file
// in a temporary folder or a fresh database of the executable's throw-away PostgreSQL cluster
// (pg_cluster.hpp), and raw SQL on either, past the store.
#pragma once

#include <gtest/gtest.h>
#include <sqlite3.h>

#include <cstdint>
#include <exception>
#include <ostream>
#include <string>

#include "pg_cluster.hpp"
#include "store_test_util.hpp"
#include "test_util.hpp"

namespace pl::test {

enum class Backend { Sqlite, Postgres };

inline void PrintTo(Backend b, std::ostream* os) { *os << (b == Backend::Sqlite ? "sqlite" : "postgresql"); }

inline std::string backend_name(const ::testing::TestParamInfo<Backend>& info) {
  return info.param == Backend::Sqlite ? "sqlite" : "postgresql";
}

// A fresh store name for `backend`: a file path in `dir` (named after `name`) or the URL of a new
// database. A PostgreSQL cluster that cannot start (PostgreSQL not installed, ...) throws.
inline std::string fresh_store(Backend backend, const TempDir& dir, const std::string& name = "maps.db") {
  if (backend == Backend::Sqlite) return dir / name;
  return PgCluster::get().new_database();
}

// Raw SQL on a store (the same SQL reads the same on both where the tests use it).
// SQLite's foreign keys are on for it (a setting of the connection, off by default).
inline std::string raw_exec(Backend backend, const std::string& store, const std::string& sql) {
  if (backend == Backend::Sqlite) return RawDb(store).exec("PRAGMA foreign_keys = ON; " + sql);
  return pg_exec(store, sql);
}
inline std::int64_t raw_scalar(Backend backend, const std::string& store, const std::string& sql) {
  if (backend == Backend::Sqlite) return RawDb(store).scalar(sql);
  return pg_scalar(store, sql);
}

// Raw SQL on `table` with the store's triggers off (SQLite: for this connection alone; PostgreSQL:
// on the table, within one transaction): what damage, or an edit behind the store's back, leaves
// that no writer could. Returns "" on success, else the engine's message.
inline std::string raw_exec_untriggered(Backend backend, const std::string& store, const std::string& table,
                                        const std::string& sql) {
  if (backend == Backend::Postgres)
    return pg_exec(store, "BEGIN; ALTER TABLE " + table + " DISABLE TRIGGER USER; " + sql + "; ALTER TABLE " + table +
                              " ENABLE TRIGGER USER; COMMIT");
  sqlite3* db = nullptr;
  if (sqlite3_open_v2(store.c_str(), &db, SQLITE_OPEN_READWRITE, nullptr) != SQLITE_OK ||
      sqlite3_db_config(db, SQLITE_DBCONFIG_ENABLE_TRIGGER, 0, nullptr) != SQLITE_OK) {
    sqlite3_close_v2(db);
    return "cannot open " + store;
  }
  char* err = nullptr;
  const int rc = sqlite3_exec(db, sql.c_str(), nullptr, nullptr, &err);
  const std::string msg = rc == SQLITE_OK ? "" : (err ? err : "error");
  sqlite3_free(err);
  sqlite3_close_v2(db);
  return msg;
}

// Every change report's body as zeros of its length (the size CHECK holds: only the hash can tell).
inline std::string zero_report_bodies(Backend backend, const std::string& store) {
  return raw_exec_untriggered(backend, store, "change_reports",
                              backend == Backend::Sqlite
                                  ? "UPDATE change_reports SET body = zeroblob(size)"
                                  : "UPDATE change_reports SET body = decode(repeat('00', size::int), 'hex')");
}

class BackendTest : public ::testing::TestWithParam<Backend> {
 protected:
  void SetUp() override {
    try {
      path = fresh_store(GetParam(), dir);
    } catch (const std::exception& e) {
      // Never skipped: a machine without PostgreSQL fails these tests, saying what to install.
      FAIL() << e.what();
    }
  }

  bool sqlite() const { return GetParam() == Backend::Sqlite; }
  // Another, empty store of the same engine.
  std::string another(const std::string& name) const { return fresh_store(GetParam(), dir, name); }
  std::string raw_exec(const std::string& sql) const { return pl::test::raw_exec(GetParam(), path, sql); }
  std::int64_t raw_scalar(const std::string& sql) const { return pl::test::raw_scalar(GetParam(), path, sql); }
  std::int64_t count(const std::string& table) const { return raw_scalar("SELECT count(*) FROM " + table); }
  // A literal of bytes given in hex, in the engine's SQL.
  std::string bytes_literal(const std::string& hex) const {
    return sqlite() ? "x'" + hex + "'" : "'\\x" + hex + "'::bytea";
  }

  TempDir dir;
  std::string path;  // the store's file path or URL
};

#define PL_BOTH_BACKENDS(suite)                                                                                     \
  INSTANTIATE_TEST_SUITE_P(Both, suite, ::testing::Values(pl::test::Backend::Sqlite, pl::test::Backend::Postgres), \
                           pl::test::backend_name)

}  // namespace pl::test
