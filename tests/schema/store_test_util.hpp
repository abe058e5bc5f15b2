// Helpers for the map store tests: a raw SQLite connection to look under the store, and tiles.
#pragma once

#include <sqlite3.h>

#include <cstdint>
#include <random>
#include <stdexcept>
#include <string>

#include "pl/schema/store.hpp"

namespace pl::test {

// A plain SQLite connection to the store's file (no store logic), for checks and tampering.
class RawDb {
 public:
  explicit RawDb(const std::string& path) {
    if (sqlite3_open_v2(path.c_str(), &db_, SQLITE_OPEN_READWRITE, nullptr) != SQLITE_OK)
      throw std::runtime_error("raw open failed: " + path);
    sqlite3_busy_timeout(db_, 5000);
  }
  ~RawDb() { sqlite3_close_v2(db_); }
  RawDb(const RawDb&) = delete;
  RawDb& operator=(const RawDb&) = delete;

  // Runs SQL; returns "" on success, else SQLite's message.
  std::string exec(const std::string& sql) {
    char* err = nullptr;
    int rc = sqlite3_exec(db_, sql.c_str(), nullptr, nullptr, &err);
    std::string msg = rc == SQLITE_OK ? "" : (err ? err : "error");
    sqlite3_free(err);
    return msg;
  }
  // First column of the first row as an integer (throws when the query fails).
  std::int64_t scalar(const std::string& sql) {
    sqlite3_stmt* st = nullptr;
    if (sqlite3_prepare_v2(db_, sql.c_str(), -1, &st, nullptr) != SQLITE_OK)
      throw std::runtime_error(std::string("raw prepare failed: ") + sqlite3_errmsg(db_));
    int rc = sqlite3_step(st);
    std::int64_t v = rc == SQLITE_ROW ? sqlite3_column_int64(st, 0) : 0;
    sqlite3_finalize(st);
    if (rc != SQLITE_ROW && rc != SQLITE_DONE) throw std::runtime_error(std::string("raw step failed"));
    return v;
  }
  std::string text(const std::string& sql) {
    sqlite3_stmt* st = nullptr;
    if (sqlite3_prepare_v2(db_, sql.c_str(), -1, &st, nullptr) != SQLITE_OK)
      throw std::runtime_error(std::string("raw prepare failed: ") + sqlite3_errmsg(db_));
    std::string v;
    if (sqlite3_step(st) == SQLITE_ROW && sqlite3_column_text(st, 0))
      v = reinterpret_cast<const char*>(sqlite3_column_text(st, 0));
    sqlite3_finalize(st);
    return v;
  }

 private:
  sqlite3* db_ = nullptr;
};

inline std::int64_t count_rows(const std::string& path, const std::string& table) {
  RawDb raw(path);
  return raw.scalar("SELECT count(*) FROM " + table);
}

// Deterministic pseudo-random bytes standing in for a Draco tile.
inline std::string fake_draco(std::uint32_t seed, std::size_t n = 256) {
  std::mt19937 rng(seed);
  std::string s(n, '\0');
  for (auto& c : s) c = static_cast<char>(rng() & 0xFF);
  return s;
}

// Puts a tile whose points fill the middle of its 10 m cell.
inline pl::store::TileRecord put_cell(pl::store::Store& s, const std::string& map, std::int64_t version, int tx, int ty,
                                      std::uint32_t seed, std::size_t n = 256) {
  double x0 = tx * 10.0, y0 = ty * 10.0;
  return s.put_tile(map, version, {tx, ty}, fake_draco(seed, n), 100 + seed % 50, x0 + 1, y0 + 1, -2.0, x0 + 9, y0 + 9,
                    5.0);
}

}  // namespace pl::test
