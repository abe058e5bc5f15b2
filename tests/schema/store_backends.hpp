// The map store tests on both engines: a value-parameterized fixture whose store is a SQLite file
// in a temporary folder or a fresh database of the executable's throw-away PostgreSQL cluster
// (pg_cluster.hpp), and raw SQL on either, past the store.
#pragma once

#include <gtest/gtest.h>

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
