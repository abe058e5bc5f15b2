// The map store opened: content hashes and the names of roles and states, a fresh store on either
// engine, SQLite files of older schemas migrated, and files that are no store of ours refused.
#include <grp.h>
#include <gtest/gtest.h>
#include <pwd.h>
#include <sqlite3.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <utility>

#include "pl/schema/store.hpp"
#include "error_of.hpp"
#include "raw_sql.hpp"
#include "store_fixture.hpp"
#include "store_test_util.hpp"
#include "test_util.hpp"

namespace {

using pl::store::Role;
using pl::store::Store;
using pl::store::VersionState;
using pl::test::contains;
using pl::test::error_of;
using pl::test::file_bytes;
using pl::test::kOrigin;
using pl::test::migrations_up_to;
using pl::test::RawDb;
using pl::test::SqliteStoreTest;
using pl::test::StoreTest;

// Every TEST_P(StoreTest, ...) of the test_store_*.cpp files, on both engines.
PL_BOTH_BACKENDS(StoreTest);

// ---- hashing and names ---------------------------------------------------------------------------

TEST(StoreBasics, ContentHashIsSha256Hex) {
  EXPECT_EQ(pl::store::content_hash(""), "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
  EXPECT_EQ(pl::store::content_hash("abc"), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
  std::string with_nul("a\0b", 3);
  EXPECT_NE(pl::store::content_hash(with_nul), pl::store::content_hash("a"));
}

TEST(StoreBasics, RoleAndStateNames) {
  for (Role r : {Role::Read, Role::Report, Role::Upload, Role::Admin})
    EXPECT_EQ(pl::store::parse_role(pl::store::role_name(r)), r);
  EXPECT_STREQ(pl::store::role_name(Role::Report), "report");
  EXPECT_FALSE(pl::store::parse_role("root"));
  EXPECT_FALSE(pl::store::parse_role(""));
  EXPECT_FALSE(pl::store::parse_role("Report"));
  // Each includes the ones below it: a vehicle's report token reads maps, never writes versions.
  EXPECT_LT(Role::Read, Role::Report);
  EXPECT_LT(Role::Report, Role::Upload);
  EXPECT_LT(Role::Upload, Role::Admin);
  EXPECT_STREQ(pl::store::state_name(VersionState::Staged), "staged");
  EXPECT_STREQ(pl::store::state_name(VersionState::Published), "published");
  EXPECT_STREQ(pl::store::state_name(VersionState::Retired), "retired");
}

// ---- opening and migrating -----------------------------------------------------------------------

TEST_P(StoreTest, MigratesAFreshFileAndReopens) {
  {
    Store s = Store::open(path);
    EXPECT_EQ(s.schema_version(), Store::latest_schema_version());
    EXPECT_GE(Store::latest_schema_version(), 1);
    EXPECT_EQ(s.path(), path);
    s.create_map("city", kOrigin, 20.0, 0.2);
  }
  if (sqlite()) {
    RawDb raw(path);
    EXPECT_EQ(raw.scalar("PRAGMA user_version"), Store::latest_schema_version());
    EXPECT_EQ(raw.text("PRAGMA journal_mode"), "wal");
    for (const char* t : {"maps", "versions", "blobs", "tiles", "tile_rtree", "tokens", "upload_log", "places",
                          "signatures", "change_reports"})
      EXPECT_EQ(raw.scalar(std::string("SELECT count(*) FROM sqlite_schema WHERE name = '") + t + "'"), 1) << t;
    EXPECT_EQ(raw.scalar("SELECT count(*) FROM sqlite_schema WHERE name = 'tokens_v4'"), 0);
  } else {
    EXPECT_EQ(raw_scalar("SELECT max(number) FROM schema_migrations"), Store::latest_schema_version());
    for (const char* t : {"maps", "versions", "blobs", "tiles", "tokens", "upload_log", "places", "signatures",
                          "change_reports", "schema_migrations"})
      EXPECT_EQ(raw_scalar(std::string("SELECT count(*) FROM pg_tables WHERE tablename = '") + t + "'"), 1) << t;
    EXPECT_EQ(raw_scalar("SELECT count(*) FROM pg_indexes WHERE indexname = 'tiles_xy' AND indexdef LIKE '%gist%'"), 1);
  }
  Store s = Store::open(path, /*create=*/false);
  EXPECT_EQ(s.schema_version(), Store::latest_schema_version());
  auto m = s.find_map("city");
  ASSERT_TRUE(m);
  EXPECT_DOUBLE_EQ(m->origin.lat_deg, kOrigin.lat_deg);
  EXPECT_DOUBLE_EQ(m->origin.lon_deg, kOrigin.lon_deg);
  EXPECT_DOUBLE_EQ(m->origin.alt_m, kOrigin.alt_m);
  EXPECT_EQ(s.list_maps().size(), 1u);
  EXPECT_TRUE(s.integrity_ok());
}

TEST_F(SqliteStoreTest, RefusesANewerSchema) {
  { Store s = Store::open(path); }
  {
    RawDb raw(path);
    ASSERT_EQ(raw.exec("PRAGMA user_version = " + std::to_string(Store::latest_schema_version() + 1)), "");
  }
  std::string msg = error_of([&] { Store::open(path); });
  EXPECT_TRUE(contains(msg, path)) << msg;
  EXPECT_TRUE(contains(msg, "newer")) << msg;
  EXPECT_TRUE(contains(msg, "upgrade")) << msg;
  RawDb raw(path);
  EXPECT_EQ(raw.scalar("PRAGMA user_version"), Store::latest_schema_version() + 1);  // left alone
}

TEST_F(SqliteStoreTest, MigratesASchema1StoreOnOpen) {
  // A store as a build of schema version 1 left it: migration 001 alone, then a map with one
  // published version and one tile, written by SQLite directly.
  const std::string schema_1 = pl::test::read_file(std::string(PL_SOURCE_DIR) + "/schema/001_initial.sql");
  ASSERT_NE(schema_1.find("CREATE TABLE tiles"), std::string::npos);
  const std::string hash = pl::store::content_hash("abc");
  pl::test::raw_sql(path, "BEGIN; " + schema_1 + "\nPRAGMA user_version = 1; COMMIT; PRAGMA journal_mode = WAL;");
  pl::test::raw_sql(path,
                    "INSERT INTO maps (name, origin_lat, origin_lon, origin_alt, tile_size, voxel_size) "
                    "VALUES ('old', 48.1, 11.5, 519, 10, 0.2); "
                    "INSERT INTO versions (map_id, number, note) VALUES (1, 1, 'made at schema 1'); "
                    "INSERT INTO blobs (hash, bytes, size) VALUES ('" + hash + "', CAST('abc' AS BLOB), 3); "
                    "INSERT INTO tiles (map_id, version, tx, ty, hash, points, bytes, min_x, min_y, min_z, max_x, max_y, max_z) "
                    "VALUES (1, 1, 0, 0, '" + hash + "', 5, 3, 1, 1, 0, 9, 9, 1); "
                    "UPDATE versions SET state = 'published' WHERE number = 1; "
                    "UPDATE maps SET current_version = 1;");
  {
    RawDb raw(path);
    ASSERT_EQ(raw.scalar("PRAGMA user_version"), 1);
    ASSERT_EQ(raw.scalar("SELECT count(*) FROM sqlite_schema WHERE name = 'places'"), 0);
  }
  {
    Store s = Store::open(path, /*create=*/false);
    EXPECT_EQ(s.schema_version(), Store::latest_schema_version());
    auto m = s.find_map("old");
    ASSERT_TRUE(m);
    EXPECT_EQ(m->current, 1);
    EXPECT_EQ(s.find_version("old", 1)->note, "made at schema 1");
    ASSERT_TRUE(s.find_tile("old", 1, {0, 0}));
    EXPECT_EQ(s.blob(hash), "abc");
    EXPECT_FALSE(s.places("old", 1));
    EXPECT_TRUE(s.integrity_ok());
    // The migrated store takes places like a new one.
    auto v2 = s.create_version("old", std::nullopt, "");
    EXPECT_EQ(v2.tiles, 1);
    s.put_places("old", 2, "descriptors");
    EXPECT_EQ(s.places("old", 2), "descriptors");
  }
  RawDb raw(path);
  EXPECT_EQ(raw.scalar("PRAGMA user_version"), Store::latest_schema_version());
  EXPECT_EQ(raw.scalar("SELECT count(*) FROM places"), 1);
  // Reopening checks the schema against the migrations' own, and finds nothing left to migrate.
  Store again = Store::open(path, false);
  EXPECT_EQ(again.schema_version(), Store::latest_schema_version());
  EXPECT_EQ(again.places("old", 2), "descriptors");
}

TEST_F(SqliteStoreTest, MigratesASchema4StoreKeepingItsTokens) {
  // A store as a build of schema version 4 left it: tokens of each role it knew (one revoked, ids
  // with gaps), a map with a published version.
  const std::string read = "rd-token", upload = "up-token", admin = "ad-token", car = "car-token";
  pl::test::raw_sql(path,
                    "BEGIN; " + migrations_up_to("schema", 4) + "PRAGMA user_version = 4; COMMIT; PRAGMA journal_mode = WAL;");
  pl::test::raw_sql(path,
                    "INSERT INTO tokens (id, hash, role, note, created, revoked) VALUES "
                    "(3, '" + pl::store::content_hash(read) + "', 'read', 'viewer', '2024-01-02T03:04:05.678Z', NULL), "
                    "(5, '" + pl::store::content_hash(upload) + "', 'upload', 'survey car', '2024-02-02T03:04:05.678Z', "
                    "'2024-03-01T00:00:00.000Z'), "
                    "(9, '" + pl::store::content_hash(admin) + "', 'admin', 'ops', '2024-04-02T03:04:05.678Z', NULL); "
                    "INSERT INTO maps (name, origin_lat, origin_lon, origin_alt, tile_size, voxel_size) "
                    "VALUES ('old', 48.1, 11.5, 519, 10, 0.2); "
                    "INSERT INTO versions (map_id, number, note) VALUES (1, 1, 'made at schema 4'); "
                    "UPDATE versions SET state = 'published' WHERE number = 1; "
                    "UPDATE maps SET current_version = 1;");
  {
    RawDb raw(path);
    ASSERT_EQ(raw.scalar("PRAGMA user_version"), 4);
    // Schema 4 knows no report role.
    EXPECT_NE(raw.exec("INSERT INTO tokens (hash, role) VALUES ('" + pl::store::content_hash(car) + "', 'report')"), "");
  }
  {
    Store s = Store::open(path, /*create=*/false);
    EXPECT_EQ(s.schema_version(), Store::latest_schema_version());
    const auto tokens = s.list_tokens();
    ASSERT_EQ(tokens.size(), 3u);
    EXPECT_EQ(tokens[0].id, 3);
    EXPECT_EQ(tokens[0].role, Role::Read);
    EXPECT_EQ(tokens[0].note, "viewer");
    EXPECT_EQ(tokens[0].created, "2024-01-02T03:04:05.678Z");
    EXPECT_FALSE(tokens[0].revoked);
    EXPECT_EQ(tokens[1].id, 5);
    EXPECT_EQ(tokens[1].role, Role::Upload);
    EXPECT_EQ(tokens[1].revoked, "2024-03-01T00:00:00.000Z");
    EXPECT_EQ(tokens[2].id, 9);
    EXPECT_EQ(tokens[2].role, Role::Admin);
    EXPECT_EQ(s.check_token(read), Role::Read);
    EXPECT_FALSE(s.check_token(upload));  // still revoked
    EXPECT_EQ(s.check_token(admin), Role::Admin);
    // The migrated store takes report tokens and reports like a new one.
    EXPECT_EQ(s.add_token(car, Role::Report, "car 7"), 10);
    EXPECT_EQ(s.check_token(car), Role::Report);
    EXPECT_EQ(s.put_report("old", 1, "car-7", "d-1", 0, 1, "{}", "token 10"), Store::ReportPut::Stored);
    EXPECT_TRUE(s.integrity_ok());
  }
  RawDb raw(path);
  EXPECT_EQ(raw.scalar("PRAGMA user_version"), Store::latest_schema_version());
  EXPECT_EQ(raw.scalar("SELECT count(*) FROM sqlite_schema WHERE name = 'tokens_v4'"), 0);
  EXPECT_NE(raw.text("SELECT sql FROM sqlite_schema WHERE name = 'tokens'").find("'report'"), std::string::npos);
  EXPECT_EQ(raw.scalar("SELECT count(*) FROM pragma_foreign_key_check"), 0);
  // Reopening checks the schema against the migrations' own: the rebuilt table is exactly theirs.
  Store again = Store::open(path, false);
  EXPECT_EQ(again.list_tokens().size(), 4u);
  EXPECT_EQ(again.list_reports("old").size(), 1u);
}

TEST_F(SqliteStoreTest, RefusesAFileThatIsNotSqlite) {
  std::string text;
  while (text.size() < 8192) text += "this is a text file, not a map store\n";
  pl::test::write_file(path, text);
  std::string msg = error_of([&] { Store::open(path); });
  EXPECT_TRUE(contains(msg, path)) << msg;
  EXPECT_TRUE(contains(msg, "not a SQLite database")) << msg;
  EXPECT_EQ(file_bytes(path), text);  // untouched
}

TEST_F(SqliteStoreTest, RefusesAnotherApplicationsDatabase) {
  {
    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
    ASSERT_EQ(sqlite3_exec(db, "CREATE TABLE notes (id INTEGER PRIMARY KEY, body TEXT)", nullptr, nullptr, nullptr),
              SQLITE_OK);
    sqlite3_close(db);
  }
  std::string msg = error_of([&] { Store::open(path); });
  EXPECT_TRUE(contains(msg, path)) << msg;
  EXPECT_TRUE(contains(msg, "not a map store")) << msg;
}

TEST_F(SqliteStoreTest, OpenWithoutCreateNeedsAnExistingFile) {
  std::string msg = error_of([&] { Store::open(path, /*create=*/false); });
  EXPECT_TRUE(contains(msg, path)) << msg;
  EXPECT_FALSE(std::filesystem::exists(path));
}

// Runs `f` as an unprivileged user and returns what it returned: as root (CI is), in a child that
// drops to the user nobody first, since root ignores file permissions.
std::string unprivileged(const std::function<std::string()>& f) {
  if (geteuid() != 0) return f();
  const passwd* nobody = getpwnam("nobody");
  if (!nobody) return "no user 'nobody' to drop to";
  int fds[2];
  if (pipe(fds) != 0) return "pipe() failed";
  const pid_t pid = fork();
  if (pid == 0) {
    close(fds[0]);
    const bool dropped = setgroups(0, nullptr) == 0 && setgid(nobody->pw_gid) == 0 && setuid(nobody->pw_uid) == 0;
    const std::string out = dropped ? f() : "cannot drop root's privileges";
    const ssize_t written = write(fds[1], out.data(), out.size());
    _exit(written == static_cast<ssize_t>(out.size()) ? 0 : 1);  // no destructors: the parent owns the files
  }
  close(fds[1]);
  std::string out;
  char buf[4096];
  ssize_t n;
  while ((n = read(fds[0], buf, sizeof buf)) > 0) out.append(buf, static_cast<std::size_t>(n));
  close(fds[0]);
  int status = 0;
  waitpid(pid, &status, 0);
  return out;
}

TEST_F(SqliteStoreTest, RefusesAReadOnlyFile) {
  { Store s = Store::open(path); }
  namespace fs = std::filesystem;
  fs::permissions(dir.path(), fs::perms::owner_all | fs::perms::group_read | fs::perms::group_exec | fs::perms::others_read |
                                  fs::perms::others_exec);
  fs::permissions(path, fs::perms::owner_read | fs::perms::group_read | fs::perms::others_read);
  std::string msg = unprivileged([&] { return error_of([&] { Store::open(path); }); });
  EXPECT_TRUE(contains(msg, path)) << msg;
  EXPECT_TRUE(contains(msg, "read-only")) << msg;
}

TEST_P(StoreTest, MovedStoreKeepsTheConnection) {
  Store a = Store::open(path);
  Store b = std::move(a);
  b.create_map("m", kOrigin, 20, 0.2);
  Store c = Store::open(another("other.db"));
  c = std::move(b);
  EXPECT_TRUE(c.find_map("m"));
  EXPECT_EQ(c.path(), path);
}

}  // namespace
