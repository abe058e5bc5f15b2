// Damaged and crafted SQLite store files. A store file may be damaged (a failing disk, a torn copy)
// or crafted by someone else. Each class the fuzz target tests/fuzz/fuzz_store.cpp covers has a test
// here on a real store: the file is refused with the one message that names the fix, or read
// correctly, and refusing leaves it as it was.
#include <gtest/gtest.h>
#include <sqlite3.h>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "pl/schema/store.hpp"
#include "error_of.hpp"
#include "store_fixture.hpp"
#include "store_test_util.hpp"
#include "test_util.hpp"

namespace {

using pl::store::Store;
using pl::test::contains;
using pl::test::error_of;
using pl::test::expect_damaged;
using pl::test::file_bytes;
using pl::test::kDamaged;
using pl::test::kOrigin;
using pl::test::make_sample_store;
using pl::test::put_cell;
using pl::test::RawDb;
using pl::test::SqliteStoreTest;

// What pl-server reads; throws what the store throws.
void read_like_the_server(const std::string& path) {
  Store s = Store::open(path, /*create=*/false);
  for (const auto& m : s.list_maps())
    for (const auto& v : s.list_versions(m.name)) {
      for (const auto& t : s.list_tiles(m.name, v.number)) s.blob(t.hash);
      s.tiles_in_box(m.name, v.number, -1e9, -1e9, 1e9, 1e9);
      s.places_hash(m.name, v.number);
      s.places(m.name, v.number);
    }
  s.check_token("secret-read");
  s.upload_log("town");
  for (const auto& r : s.list_reports("town")) s.report_body("town", r.id);
}

// SQL run on the file by SQLite alone with the schema's triggers, CHECK constraints and foreign
// keys off: the rows someone crafting a file (or a damaged one) may hold.
void tamper(const std::string& path, const std::string& sql) {
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
  ASSERT_EQ(sqlite3_db_config(db, SQLITE_DBCONFIG_ENABLE_TRIGGER, 0, nullptr), SQLITE_OK);
  char* err = nullptr;
  int rc = sqlite3_exec(db, ("PRAGMA ignore_check_constraints = ON; " + sql).c_str(), nullptr, nullptr, &err);
  std::string msg = err ? err : "";
  sqlite3_free(err);
  sqlite3_close(db);
  ASSERT_EQ(rc, SQLITE_OK) << sql << ": " << msg;
}

// Overwrites `n` bytes at `offset` of the file with `byte`.
void overwrite(const std::string& path, std::int64_t offset, std::size_t n, char byte) {
  std::fstream f(path, std::ios::in | std::ios::out | std::ios::binary);
  f.seekp(offset);
  f << std::string(n, byte);
  ASSERT_TRUE(f.good());
}

// The byte offset of the first page of a table or index.
std::int64_t root_page_offset(const std::string& path, const std::string& name) {
  RawDb raw(path);
  return (raw.scalar("SELECT rootpage FROM sqlite_schema WHERE name = '" + name + "'") - 1) *
         raw.scalar("PRAGMA page_size");
}

TEST_F(SqliteStoreTest, TruncatedFileIsRefusedAsDamagedAndLeftAsItWas) {
  make_sample_store(path);
  const std::string whole = file_bytes(path);
  for (std::size_t keep : {whole.size() / 2, whole.size() - 4096, std::size_t{4096 + 100}}) {
    std::filesystem::resize_file(path, keep);
    const std::string cut = file_bytes(path);
    std::string msg = error_of([&] { read_like_the_server(path); });
    expect_damaged(msg, path, "malformed");
    EXPECT_EQ(file_bytes(path), cut) << "kept " << keep;  // nothing written, nothing "repaired"
    pl::test::write_file(path, whole);
  }
  EXPECT_NO_THROW(read_like_the_server(path));
}

TEST_F(SqliteStoreTest, DamagedPageIsRefusedAsDamagedAndLeftAsItWas) {
  make_sample_store(path);
  overwrite(path, root_page_offset(path, "tiles"), 8, '\xee');  // not a b-tree page any more
  const std::string damaged = file_bytes(path);
  std::string msg = error_of([&] { read_like_the_server(path); });
  expect_damaged(msg, path, "malformed");
  EXPECT_EQ(file_bytes(path), damaged);
  Store s = Store::open(path, false);  // opening a current WAL store reads only what it needs
  EXPECT_FALSE(s.integrity_ok());
}

TEST_F(SqliteStoreTest, UnreadableHeaderIsRefusedAsDamaged) {
  make_sample_store(path);
  overwrite(path, 44, 4, '\x09');  // the schema format number: 1 to 4 are the ones SQLite writes
  const std::string damaged = file_bytes(path);
  expect_damaged(error_of([&] { Store::open(path, false); }), path, "unsupported file format");
  EXPECT_EQ(file_bytes(path), damaged);
}

TEST_F(SqliteStoreTest, HeaderThatOnlyLetsSqliteReadIsRefusedAsDamaged) {
  make_sample_store(path);
  overwrite(path, 18, 1, '\x42');  // the write version: SQLite writes 1 (legacy) or 2 (WAL)
  const std::string damaged = file_bytes(path);
  for (bool create : {false, true})
    expect_damaged(error_of([&] { Store::open(path, create); }), path, "may only read it");
  EXPECT_EQ(file_bytes(path), damaged);
}

TEST_F(SqliteStoreTest, StoreToSwitchToWalIsCheckedWholeFirst) {
  make_sample_store(path);
  { RawDb(path).exec("PRAGMA journal_mode = DELETE"); }
  // Damage a page that opening does not read: only a check of the whole file finds it.
  overwrite(path, root_page_offset(path, "tokens"), 8, '\xee');
  const std::string damaged = file_bytes(path);
  std::string msg = error_of([&] { Store::open(path, false); });
  expect_damaged(msg, path, "quick_check");
  EXPECT_EQ(file_bytes(path), damaged);  // not switched to WAL
  EXPECT_TRUE(contains(error_of([&] { Store::open(path, true); }), kDamaged));
  EXPECT_EQ(file_bytes(path), damaged);
}

TEST_F(SqliteStoreTest, EmptyFileIsNotAStoreWithoutCreate) {
  pl::test::write_file(path, "");
  std::string msg = error_of([&] { Store::open(path, false); });
  EXPECT_TRUE(contains(msg, path)) << msg;
  EXPECT_TRUE(contains(msg, "empty")) << msg;
  EXPECT_TRUE(contains(msg, "pl-map")) << msg;
  EXPECT_EQ(std::filesystem::file_size(path), 0u);
  Store s = Store::open(path, true);  // pl-map makes a store of it
  EXPECT_EQ(s.schema_version(), Store::latest_schema_version());
}

TEST_F(SqliteStoreTest, CraftedSchemaIsRefusedBeforeAnyOfItRuns) {
  struct Case {
    const char* sql;
    const char* detail;
  };
  const Case cases[] = {
      {"CREATE TRIGGER wipe AFTER INSERT ON upload_log BEGIN DELETE FROM tokens; END", "unknown trigger wipe"},
      // A view that never ends, where a table should be.
      {"DROP TABLE tokens; CREATE VIEW tokens (id, hash, role, note, created) AS WITH RECURSIVE c(x) AS "
       "(SELECT 1 UNION ALL SELECT x + 1 FROM c) SELECT x, x, 'admin', '', '' FROM c",
       "is missing"},
      {"CREATE INDEX tiles_points ON tiles (points)", "unknown index tiles_points"},
      {"DROP TRIGGER upload_log_no_delete", "trigger upload_log_no_delete is missing"},
      // The same table without its CHECK constraints (as someone rebuilding it would leave it).
      {"PRAGMA writable_schema = ON; UPDATE sqlite_schema SET sql = replace(sql, 'CHECK (role IN (''read'', "
       "''report'', ''upload'', ''admin''))', '') WHERE name = 'tokens'",
       "table tokens is not defined as this software defines it"},
      {"DROP TRIGGER change_reports_no_update", "trigger change_reports_no_update is missing"},
      {"CREATE TABLE notes (body TEXT)", "unknown table notes"},
  };
  make_sample_store(path);
  const std::string sound = file_bytes(path);
  for (const Case& c : cases) {
    pl::test::write_file(path, sound);
    tamper(path, c.sql);
    const std::string crafted = file_bytes(path);
    for (bool create : {false, true}) {
      std::string msg = error_of([&] { Store::open(path, create); });
      expect_damaged(msg, path, c.detail);
      EXPECT_TRUE(contains(msg, "schema")) << msg;
    }
    EXPECT_EQ(file_bytes(path), crafted) << c.sql;
  }
}

TEST_F(SqliteStoreTest, ValuesThatBreakTheSchemasPromisesAreRefused) {
  struct Case {
    std::string sql;
    std::function<void(Store&)> read;
    const char* detail;
  };
  auto tiles = [](Store& s) { s.list_tiles("town", 1); };
  const std::string first_tile = "(SELECT min(id) FROM tiles)";
  const std::vector<Case> cases = {
      {"UPDATE maps SET tile_size = 'twenty'", [](Store& s) { s.find_map("town"); }, "maps.tile_size is not a number"},
      {"UPDATE maps SET tile_size = -20", [](Store& s) { s.list_maps(); }, "maps.tile_size is not a positive number"},
      {"UPDATE maps SET voxel_size = 9e999", [](Store& s) { s.list_maps(); }, "maps.voxel_size"},
      {"UPDATE maps SET origin_lat = 1000", [](Store& s) { s.list_maps(); }, "maps.origin_lat is out of range"},
      {"UPDATE maps SET name = 'bad name'", [](Store& s) { s.list_maps(); }, "maps.name is not a valid map name"},
      {"UPDATE maps SET name = x'746f776e'", [](Store& s) { s.list_maps(); }, "maps.name is not text"},
      {"UPDATE maps SET created = 'yesterday'", [](Store& s) { s.list_maps(); }, "maps.created is not a UTC timestamp"},
      {"UPDATE maps SET current_version = 9", [](Store& s) { s.find_map("town"); }, "current_version 9 is not a published"},
      {"UPDATE maps SET current_version = 2", [](Store& s) { s.find_map("town"); }, "current_version 2 is not a published"},
      {"UPDATE versions SET state = 'bogus' WHERE number = 2", [](Store& s) { s.list_versions("town"); },
       "versions.state is not one of"},
      {"UPDATE versions SET parent = 42 WHERE number = 2", [](Store& s) { s.find_version("town", 2); },
       "has parent 42, which does not exist"},
      {"UPDATE versions SET number = 4.5 WHERE number = 2", [](Store& s) { s.list_versions("town"); },
       "versions.number is not an integer"},
      {"UPDATE tiles SET tx = 1099511627776 WHERE id = " + first_tile, tiles, "tiles.tx is out of range (1099511627776)"},
      {"UPDATE tiles SET hash = 'zz' WHERE id = " + first_tile, tiles, "tiles.hash is not a SHA-256 hash"},
      {"UPDATE tiles SET min_x = 'west' WHERE id = " + first_tile, tiles, "tiles.min_x is not a number"},
      {"UPDATE tiles SET min_x = max_x + 1 WHERE id = " + first_tile, tiles, "min > max"},
      {"UPDATE tiles SET points = 'many' WHERE id = " + first_tile, [](Store& s) { s.find_version("town", 1); },
       "tiles.points or tiles.bytes is not a non-negative integer"},
      {"UPDATE tiles SET points = 4611686018427387904", [](Store& s) { s.find_version("town", 1); },
       "tiles.points (total) is out of range"},
      {"UPDATE blobs SET bytes = zeroblob(size) WHERE hash = (SELECT hash FROM tiles WHERE id = " + first_tile + ")",
       [](Store& s) { s.blob(s.list_tiles("town", 1).front().hash); }, "do not match its content hash"},
      {"UPDATE blobs SET bytes = 'text'", [](Store& s) { s.blob(s.list_tiles("town", 1).front().hash); },
       "blobs.bytes is not a blob"},
      {"UPDATE places SET bytes = zeroblob(size) WHERE version = 1", [](Store& s) { s.places("town", 1); },
       "places.bytes of map town version 1 do not match their content hash"},
      {"UPDATE places SET bytes = 'text' WHERE version = 2", [](Store& s) { s.places("town", 2); },
       "places.bytes is not a blob"},
      {"UPDATE places SET size = size + 1", [](Store& s) { s.places("town", 1); }, "places.size is not the length"},
      {"UPDATE places SET size = 0", [](Store& s) { s.places_hash("town", 1); }, "places.size is out of range"},
      {"UPDATE places SET hash = upper(hash)", [](Store& s) { s.places_hash("town", 2); },
       "places.hash is not a SHA-256 hash"},
      {"UPDATE places SET version = 7 WHERE version = 2", [](Store& s) { s.places("town", 7); },
       "map town version 7 has places but no such version"},
      {"UPDATE tokens SET role = 'root'", [](Store& s) { s.check_token("secret-read"); }, "tokens.role is not one of"},
      {"UPDATE upload_log SET at = 'then'", [](Store& s) { s.upload_log("town"); }, "upload_log.at is not a UTC timestamp"},
      {"UPDATE upload_log SET detail = x'00ff'", [](Store& s) { s.upload_log("town"); }, "upload_log.detail is not text"},
      {"UPDATE change_reports SET vehicle = 'car 1'", [](Store& s) { s.list_reports("town"); },
       "change_reports.vehicle is not 1 to 128 of"},
      {"UPDATE change_reports SET drive = x'64'", [](Store& s) { s.list_reports("town", 1); },
       "change_reports.drive is not text"},
      {"UPDATE change_reports SET start_s = end_s + 1", [](Store& s) { s.list_reports("town"); },
       "change_reports.start_s is after end_s"},
      {"UPDATE change_reports SET end_s = 9e999", [](Store& s) { s.list_reports("town"); }, "change_reports.end_s is not finite"},
      {"UPDATE change_reports SET received = 'now'", [](Store& s) { s.list_reports("town"); },
       "change_reports.received is not a UTC timestamp"},
      {"UPDATE change_reports SET who = ''", [](Store& s) { s.list_reports("town"); }, "change_reports.who is empty"},
      {"UPDATE change_reports SET version = 9", [](Store& s) { s.list_reports("town"); },
       "map town has a change report of version 9 but no such version"},
      {"UPDATE change_reports SET body = zeroblob(size)", [](Store& s) { s.report_body("town", 1); },
       "change_reports.body of change report 1 does not match its content hash"},
      {"UPDATE change_reports SET size = size + 1", [](Store& s) { s.report_body("town", 1); },
       "change_reports.size is not the length"},
      {"UPDATE change_reports SET body = 'text'", [](Store& s) { s.report_body("town", 1); },
       "change_reports.body is not a blob"},
  };
  make_sample_store(path);
  const std::string sound = file_bytes(path);
  for (const Case& c : cases) {
    pl::test::write_file(path, sound);
    tamper(path, c.sql);
    const std::string crafted = file_bytes(path);
    Store s = Store::open(path, false);
    expect_damaged(error_of([&] { c.read(s); }), path, c.detail);
    EXPECT_EQ(file_bytes(path), crafted) << c.sql;
  }
  // Places of a version that does not exist break a foreign key: a full check finds it too.
  pl::test::write_file(path, sound);
  tamper(path, "UPDATE places SET version = 7 WHERE version = 2");
  EXPECT_FALSE(Store::open(path, false).integrity_ok());
}

TEST_F(SqliteStoreTest, NullInANotNullColumnIsRefused) {
  // A NULL where the schema says NOT NULL: SQLite only checks NOT NULL on writes, so a crafted file
  // (written with the constraint edited out, then put back) may hold one.
  make_sample_store(path);
  tamper(path,
         "PRAGMA writable_schema = ON; "
         "UPDATE sqlite_schema SET sql = replace(sql, 'tile_size REAL NOT NULL', 'tile_size REAL') WHERE name = 'maps'");
  tamper(path, "UPDATE maps SET tile_size = NULL");
  tamper(path,
         "PRAGMA writable_schema = ON; "
         "UPDATE sqlite_schema SET sql = replace(sql, 'tile_size REAL CHECK', 'tile_size REAL NOT NULL CHECK') "
         "WHERE name = 'maps'");
  Store s = Store::open(path, false);
  expect_damaged(error_of([&] { s.find_map("town"); }), path, "maps.tile_size is not a number");
  EXPECT_FALSE(s.integrity_ok());
}


// ---- a record that declares a blob of gigabytes --------------------------------------------------
// SQLite's varints and record format, just enough to rewrite one cell of a table's leaf page the
// way a crafted file would: the record says its blob has `declared` bytes, of which the page holds
// the first few and an overflow chain (that does not exist) the rest.

std::size_t get_varint(const std::string& b, std::size_t i, std::uint64_t& v) {
  v = 0;
  for (int k = 0; k < 9; ++k) {
    auto c = static_cast<unsigned char>(b[i + k]);
    if (k == 8) {
      v = (v << 8) | c;
      return i + 9;
    }
    v = (v << 7) | (c & 0x7F);
    if (c < 0x80) return i + k + 1;
  }
  return i;
}

std::string put_varint(std::uint64_t v) {
  std::string out(1, static_cast<char>(v & 0x7F));
  for (v >>= 7; v; v >>= 7) out.insert(out.begin(), static_cast<char>(0x80 | (v & 0x7F)));
  return out;
}

std::string be32(std::uint32_t v) {
  return {static_cast<char>(v >> 24), static_cast<char>(v >> 16), static_cast<char>(v >> 8), static_cast<char>(v)};
}

// Rewrites the only cell of the blobs table's root page (a leaf) to declare `declared` blob bytes.
void declare_huge_blob(const std::string& path, std::uint64_t declared) {
  std::int64_t page_size = 0, root = root_page_offset(path, "blobs");
  {
    RawDb raw(path);
    page_size = raw.scalar("PRAGMA page_size");
    ASSERT_EQ(raw.scalar("SELECT count(*) FROM blobs"), 1);
  }
  std::string file = file_bytes(path);
  std::string page = file.substr(static_cast<std::size_t>(root), static_cast<std::size_t>(page_size));
  ASSERT_EQ(page[0], 13) << "the blobs root is not a leaf page";
  const std::size_t at = (static_cast<unsigned char>(page[8]) << 8) | static_cast<unsigned char>(page[9]);
  std::uint64_t payload = 0, rowid = 0, header = 0;
  std::size_t i = get_varint(page, get_varint(page, at, payload), rowid);
  const std::string record = page.substr(i, payload);
  get_varint(record, 0, header);
  // Header: its size (9), the hash (text of 64: 141), the blob (5-byte varint), size (an int16: 2).
  const std::string hash = record.substr(header, 64), blob = record.substr(header + 64);
  const std::uint64_t usable = static_cast<std::uint64_t>(page_size), min_local = (usable - 12) * 32 / 255 - 23;
  const std::uint64_t local = min_local + 8;  // bytes of the record kept on the page
  // SQLite keeps min_local + (P - min_local) % (usable - 4) bytes of a P-byte record on the page.
  const std::uint64_t total = local + ((declared + 75 - local) / (usable - 4)) * (usable - 4);
  std::string head = put_varint(9) + put_varint(141) + put_varint(2 * (total - 75) + 12) + put_varint(2);
  ASSERT_EQ(head.size(), 9u);
  std::string kept = (head + hash + blob + std::string(local, '\0')).substr(0, local);
  std::string cell = put_varint(total) + put_varint(rowid) + kept + be32(2);  // "overflow" to page 2
  const std::size_t start = page.size() - cell.size();
  page.replace(start, cell.size(), cell);
  page[5] = page[8] = static_cast<char>(start >> 8);
  page[6] = page[9] = static_cast<char>(start & 0xFF);
  file.replace(static_cast<std::size_t>(root), page.size(), page);
  pl::test::write_file(path, file);
}

TEST_F(SqliteStoreTest, BlobThatDeclaresGigabytesIsRefusedAsDamaged) {
  // 600 MB: more than the store's limit (256 MiB), less than SQLite's own (1e9 bytes); 3 GB: more
  // than either.
  for (std::uint64_t declared : {std::uint64_t{600} << 20, std::uint64_t{3} << 30}) {
    std::filesystem::remove(path);
    std::string hash;
    {
      Store s = Store::open(path);
      s.create_map("town", kOrigin, 10, 0.2);
      s.create_version("town", std::nullopt, "");
      hash = put_cell(s, "town", 1, 0, 0, 1, 300).hash;
    }
    declare_huge_blob(path, declared);
    const std::string crafted = file_bytes(path);
    Store s = Store::open(path, false);
    EXPECT_EQ(s.list_tiles("town", 1).size(), 1u);
    expect_damaged(error_of([&] { s.blob(hash); }), path, "string or blob too big");
    EXPECT_EQ(file_bytes(path), crafted);
  }
}

}  // namespace
