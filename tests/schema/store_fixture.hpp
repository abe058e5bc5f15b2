// What the map store tests (test_store_*.cpp) share: the fixtures on both engines and on a SQLite
// file alone, checks of text and bytes, the migrations as the source tree holds them, and a sample
// store with the message a damaged one is refused with.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cctype>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <optional>
#include <regex>
#include <string>
#include <vector>

#include "pl/common/geo.hpp"
#include "pl/schema/store.hpp"
#include "store_backends.hpp"
#include "store_test_util.hpp"
#include "test_util.hpp"

namespace pl::test {

inline const pl::GeoPoint kOrigin{48.137, 11.575, 519.0};

inline bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

inline std::string file_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

inline bool is_utc_iso8601(const std::string& s) {
  return std::regex_match(s, std::regex(R"(\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d\.\d{3}Z)"));
}

// The migrations 1..`version` of `folder` (schema or schema/pg) as the source tree holds them: the
// schema a build of that version made (released migrations are never edited).
inline std::string migrations_up_to(const std::string& folder, int version) {
  std::vector<std::string> files;
  for (const auto& e : std::filesystem::directory_iterator(std::string(PL_SOURCE_DIR) + "/" + folder)) {
    const std::string name = e.path().filename().string();
    if (name.size() > 8 && name.compare(name.size() - 4, 4, ".sql") == 0 && std::isdigit(static_cast<unsigned char>(name[0])) &&
        std::stoi(name.substr(0, 3)) <= version)
      files.push_back(e.path().string());
  }
  std::sort(files.begin(), files.end());
  EXPECT_EQ(files.size(), static_cast<std::size_t>(version)) << folder;
  std::string sql;
  for (const auto& f : files) sql += pl::test::read_file(f) + "\n";
  return sql;
}

// The store on both engines (store_backends.hpp): `path` is a SQLite file or a PostgreSQL URL.
// Instantiated once, in test_store_open.cpp.
using StoreTest = BackendTest;

// What only a SQLite file has: its bytes, its header, PRAGMAs, the WAL, migrations of old files.
class SqliteStoreTest : public ::testing::Test {
 protected:
  TempDir dir;
  std::string path = dir / "maps.db";
};

// A damaged or crafted store is refused with this message (test_store_damage.cpp, test_store_pg.cpp).
inline const char* const kDamaged = "the map store is damaged";
inline const char* const kFix = "restore it from a backup, or rebuild it with pl-map";

// One map: version 1 published with 30 tiles and places, version 2 staged from it; a token; a log
// entry; a change report.
inline void make_sample_store(const std::string& path) {
  using pl::store::Store;
  Store s = Store::open(path);
  s.create_map("town", kOrigin, 10, 0.2);
  s.create_version("town", std::nullopt, "first");
  {
    Store::Transaction tx(s);
    for (int i = 0; i < 30; ++i) put_cell(s, "town", 1, i % 6, i / 6, static_cast<std::uint32_t>(i), 2000);
    s.put_places("town", 1, fake_draco(99, 3000));
    tx.commit();
  }
  s.publish("town", 1);
  s.create_version("town", std::nullopt, "second");
  s.add_token("secret-read", pl::store::Role::Read, "");
  s.log_upload("town", 1, "publish", "", "test");
  s.put_report("town", 1, "car-1", "drive-1", 100, 200, fake_draco(98, 1500), "token 1");
}

inline void expect_damaged(const std::string& msg, const std::string& path, const std::string& detail) {
  EXPECT_TRUE(contains(msg, path)) << msg;
  EXPECT_TRUE(contains(msg, kDamaged)) << msg;
  EXPECT_TRUE(contains(msg, kFix)) << msg;
  EXPECT_TRUE(contains(msg, detail)) << msg;
}

}  // namespace pl::test
