// Runs SQL straight on a SQLite file, past the project's own code: how the store and cache tests
// damage, age or tamper with a file. Fails the test (gtest ASSERT) when SQLite refuses.
#pragma once

#include <gtest/gtest.h>
#include <sqlite3.h>

#include <string>

namespace pl::test {

inline void raw_sql(const std::string& path, const std::string& sql) {
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
  char* err = nullptr;
  const int rc = sqlite3_exec(db, sql.c_str(), nullptr, nullptr, &err);
  const std::string msg = err ? err : "";
  sqlite3_free(err);
  sqlite3_close(db);
  ASSERT_EQ(rc, SQLITE_OK) << sql << ": " << msg;
}

}  // namespace pl::test
