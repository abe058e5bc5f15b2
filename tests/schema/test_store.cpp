// The map store on a real SQLite file: migrations, maps, versions, tiles, tokens, the upload log,
// change reports, transactions and integrity.
#include <grp.h>
#include <gtest/gtest.h>
#include <pwd.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <random>
#include <regex>
#include <set>
#include <utility>

#include "pl/common/error.hpp"
#include "pl/schema/api_rules.hpp"
#include "pl/schema/store.hpp"
#include "store_backends.hpp"
#include "store_test_util.hpp"
#include "error_of.hpp"
#include "raw_sql.hpp"
#include "test_util.hpp"

namespace {

using pl::store::Role;
using pl::store::Store;
using pl::store::TileRecord;
using pl::store::VersionState;
using pl::test::count_rows;
using pl::test::fake_draco;
using pl::test::put_cell;
using pl::test::RawDb;

const pl::GeoPoint kOrigin{48.137, 11.575, 519.0};

using pl::test::error_of;

bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

std::string file_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

bool is_utc_iso8601(const std::string& s) {
  return std::regex_match(s, std::regex(R"(\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d\.\d{3}Z)"));
}

// The migrations 1..`version` of `folder` (schema or schema/pg) as the source tree holds them: the
// schema a build of that version made (released migrations are never edited).
std::string migrations_up_to(const std::string& folder, int version) {
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
using StoreTest = pl::test::BackendTest;
PL_BOTH_BACKENDS(StoreTest);

// What only a SQLite file has: its bytes, its header, PRAGMAs, the WAL, migrations of old files.
class SqliteStoreTest : public ::testing::Test {
 protected:
  pl::test::TempDir dir;
  std::string path = dir / "maps.db";
};

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

// ---- maps ----------------------------------------------------------------------------------------

TEST_P(StoreTest, CreatesFindsAndListsMaps) {
  Store s = Store::open(path);
  auto b = s.create_map("b-map", kOrigin, 25.0, 0.1);
  auto a = s.create_map("a.map_1", {-33.9, 151.2, 3.0}, 20.0, 0.2);
  EXPECT_GT(a.id, 0);
  EXPECT_NE(a.id, b.id);
  EXPECT_EQ(b.name, "b-map");
  EXPECT_DOUBLE_EQ(b.tile_size, 25.0);
  EXPECT_DOUBLE_EQ(b.voxel_size, 0.1);
  EXPECT_FALSE(b.current);
  EXPECT_TRUE(is_utc_iso8601(b.created)) << b.created;

  auto found = s.find_map("b-map");
  ASSERT_TRUE(found);
  EXPECT_EQ(found->id, b.id);
  EXPECT_EQ(found->created, b.created);
  EXPECT_FALSE(s.find_map("nope"));
  EXPECT_FALSE(s.find_map("bad name"));

  auto all = s.list_maps();
  ASSERT_EQ(all.size(), 2u);
  EXPECT_EQ(all[0].name, "a.map_1");  // by name
  EXPECT_EQ(all[1].name, "b-map");
}

TEST_P(StoreTest, ValidatesMapNamesAndParameters) {
  Store s = Store::open(path);
  std::string longest(64, 'x');
  EXPECT_NO_THROW(s.create_map(longest, kOrigin, 20, 0.2));
  EXPECT_NO_THROW(s.create_map("Az09_.-", kOrigin, 20, 0.2));
  for (std::string bad :
       {std::string(), std::string(65, 'x'), std::string("has space"), std::string("a/b"), std::string("semi;colon"),
        std::string("quote'"), std::string("tab\t"), std::string("m\xc3\xbcnchen"), std::string("nul\0x", 5)}) {
    std::string msg = error_of([&] { s.create_map(bad, kOrigin, 20, 0.2); });
    EXPECT_TRUE(contains(msg, "invalid map name")) << "[" << bad << "] " << msg;
  }
  EXPECT_TRUE(contains(error_of([&] { s.create_map("m", {91, 0, 0}, 20, 0.2); }), "origin"));
  EXPECT_TRUE(contains(error_of([&] { s.create_map("m", {0, -181, 0}, 20, 0.2); }), "origin"));
  EXPECT_TRUE(contains(error_of([&] { s.create_map("m", kOrigin, 0, 0.2); }), "sizes"));
  EXPECT_TRUE(contains(error_of([&] { s.create_map("m", kOrigin, 20, -1); }), "sizes"));
  EXPECT_EQ(s.list_maps().size(), 2u);
}

TEST_P(StoreTest, RefusesADuplicateMapName) {
  Store s = Store::open(path);
  s.create_map("city", kOrigin, 20, 0.2);
  std::string msg = error_of([&] { s.create_map("city", kOrigin, 30, 0.3); });
  EXPECT_TRUE(contains(msg, "city")) << msg;
  EXPECT_TRUE(contains(msg, "already exists")) << msg;
  EXPECT_DOUBLE_EQ(s.find_map("city")->tile_size, 20);
}

// ---- versions ------------------------------------------------------------------------------------

TEST_P(StoreTest, VersionLifecycle) {
  Store s = Store::open(path);
  s.create_map("m", kOrigin, 10, 0.2);

  auto v1 = s.create_version("m", std::nullopt, "first survey");
  EXPECT_EQ(v1.number, 1);
  EXPECT_FALSE(v1.parent);
  EXPECT_EQ(v1.state, VersionState::Staged);
  EXPECT_EQ(v1.note, "first survey");
  EXPECT_EQ(v1.tiles, 0);
  EXPECT_TRUE(is_utc_iso8601(v1.created));
  put_cell(s, "m", 1, 0, 0, 1);
  put_cell(s, "m", 1, 1, 0, 2);
  put_cell(s, "m", 1, -1, -1, 3);
  EXPECT_FALSE(s.find_map("m")->current);  // staged: not current
  s.publish("m", 1);
  EXPECT_EQ(s.find_map("m")->current, 1);
  EXPECT_EQ(s.find_version("m", 1)->state, VersionState::Published);

  // A new version starts as a staged copy of the current one.
  auto v2 = s.create_version("m", std::nullopt, "second");
  EXPECT_EQ(v2.number, 2);
  EXPECT_EQ(v2.parent, 1);
  EXPECT_EQ(v2.state, VersionState::Staged);
  EXPECT_EQ(v2.tiles, 3);
  auto t1 = s.list_tiles("m", 1), t2 = s.list_tiles("m", 2);
  ASSERT_EQ(t1.size(), t2.size());
  for (std::size_t i = 0; i < t1.size(); ++i) {
    EXPECT_EQ(t1[i].key, t2[i].key);
    EXPECT_EQ(t1[i].hash, t2[i].hash);
    EXPECT_EQ(t1[i].points, t2[i].points);
    EXPECT_DOUBLE_EQ(t1[i].max_y, t2[i].max_y);
  }
  put_cell(s, "m", 2, 5, 5, 4);
  EXPECT_TRUE(s.delete_tile("m", 2, {0, 0}));
  EXPECT_EQ(s.find_map("m")->current, 1);  // still 1 until published
  EXPECT_EQ(s.list_tiles("m", 1).size(), 3u);
  EXPECT_FALSE(s.find_tile("m", 1, {5, 5}));  // staged tiles only through their version

  s.publish("m", 2);
  EXPECT_EQ(s.find_map("m")->current, 2);
  EXPECT_EQ(s.find_version("m", 1)->state, VersionState::Retired);
  EXPECT_EQ(s.find_version("m", 2)->state, VersionState::Published);

  // Published and retired versions are read-only; publishing them again is refused.
  for (std::int64_t v : {1, 2}) {
    std::string state = v == 1 ? "retired" : "published";
    std::string msg = error_of([&] { put_cell(s, "m", v, 9, 9, 5); });
    EXPECT_TRUE(contains(msg, "version " + std::to_string(v))) << msg;
    EXPECT_TRUE(contains(msg, state)) << msg;
    msg = error_of([&] { s.delete_tile("m", v, {1, 0}); });
    EXPECT_TRUE(contains(msg, state)) << msg;
    msg = error_of([&] { s.publish("m", v); });
    EXPECT_TRUE(contains(msg, "version " + std::to_string(v) + " is " + state)) << msg;
  }
  EXPECT_EQ(s.list_tiles("m", 1).size(), 3u);

  auto versions = s.list_versions("m");
  ASSERT_EQ(versions.size(), 2u);
  EXPECT_EQ(versions[0].number, 1);
  EXPECT_EQ(versions[1].number, 2);
  EXPECT_EQ(versions[1].tiles, 3);
}

TEST_P(StoreTest, VersionTotalsAndExplicitParent) {
  Store s = Store::open(path);
  s.create_map("m", kOrigin, 10, 0.2);
  s.create_version("m", std::nullopt, "");
  auto a = put_cell(s, "m", 1, 0, 0, 1, 300);
  auto b = put_cell(s, "m", 1, 0, 1, 2, 500);
  auto v = s.find_version("m", 1);
  ASSERT_TRUE(v);
  EXPECT_EQ(v->tiles, 2);
  EXPECT_EQ(v->points, a.points + b.points);
  EXPECT_EQ(v->bytes, 800);

  // Before any publish, an empty parent means an empty version; an explicit one is copied.
  auto v2 = s.create_version("m", std::nullopt, "empty");
  EXPECT_FALSE(v2.parent);
  EXPECT_EQ(v2.tiles, 0);
  auto v3 = s.create_version("m", 1, "from staged 1");
  EXPECT_EQ(v3.number, 3);
  EXPECT_EQ(v3.parent, 1);
  EXPECT_EQ(v3.tiles, 2);
  std::string msg = error_of([&] { s.create_version("m", 7, ""); });
  EXPECT_TRUE(contains(msg, "no version 7")) << msg;
  EXPECT_EQ(s.list_versions("m").size(), 3u);
}

// A rollback publishes a new version holding an older one's content: the current number only grows
// (vehicles refuse a lower one than they have verified), and repeated rollbacks walk back through
// the content history, never to a version that was rolled back.
TEST_P(StoreTest, RollbacksAreNewVersionsThatWalkBackThroughTheHistory) {
  Store s = Store::open(path);
  s.create_map("m", kOrigin, 10, 0.2);
  EXPECT_TRUE(contains(error_of([&] { s.rollback("m"); }), "no published version"));
  for (int i = 1; i <= 3; ++i) {
    s.create_version("m", std::nullopt, "v" + std::to_string(i));
    put_cell(s, "m", i, i, 0, static_cast<std::uint32_t>(i));
    s.put_places("m", i, "places of v" + std::to_string(i));
    s.publish("m", i);
  }
  EXPECT_EQ(s.create_version("m", std::nullopt, "staged, never published").number, 4);
  auto hashes = [&](std::int64_t v) {
    std::vector<std::string> out;
    for (const auto& t : s.list_tiles("m", v)) out.push_back(std::to_string(t.key.tx) + ":" + t.hash);
    return out;
  };
  EXPECT_EQ(s.find_map("m")->current, 3);
  EXPECT_EQ(s.rollback_target("m"), 2);
  const auto blobs_before = s.list_tiles("m", 2).size();
  EXPECT_EQ(s.rollback("m"), 5);  // 4 is the staged version above: a rollback takes the next number
  EXPECT_EQ(s.find_map("m")->current, 5);
  const auto v5 = s.find_version("m", 5);
  EXPECT_EQ(v5->state, VersionState::Published);
  EXPECT_EQ(v5->parent, 2);
  EXPECT_TRUE(contains(v5->note, "rollback of v3")) << v5->note;
  EXPECT_EQ(hashes(5), hashes(2));
  EXPECT_EQ(s.list_tiles("m", 2).size(), blobs_before);
  EXPECT_EQ(s.places("m", 5), "places of v2");
  EXPECT_EQ(s.find_version("m", 3)->state, VersionState::Retired);
  EXPECT_EQ(s.find_version("m", 2)->state, VersionState::Retired);  // never published again
  EXPECT_EQ(s.find_version("m", 4)->state, VersionState::Staged);

  // A new publish after the rollback: rolling back goes to 5's content (2's), then to 1's, never to 3's.
  s.create_version("m", std::nullopt, "v6");
  EXPECT_EQ(s.find_version("m", 6)->parent, 5);
  put_cell(s, "m", 6, 6, 0, 6);
  s.publish("m", 6);
  EXPECT_EQ(s.rollback("m"), 7);
  EXPECT_EQ(s.find_version("m", 7)->parent, 5);
  EXPECT_EQ(hashes(7), hashes(2));
  EXPECT_EQ(s.rollback("m"), 8);
  EXPECT_EQ(s.find_version("m", 8)->parent, 1);
  EXPECT_EQ(hashes(8), hashes(1));
  EXPECT_EQ(s.find_map("m")->current, 8);
  std::string msg = error_of([&] { s.rollback("m"); });
  EXPECT_TRUE(contains(msg, "first version published")) << msg;
  EXPECT_EQ(s.find_map("m")->current, 8);
  EXPECT_EQ(s.list_versions("m").size(), 8u);  // the refused rollback left no version behind

  int published = 0;
  for (const auto& v : s.list_versions("m")) published += v.state == VersionState::Published;
  EXPECT_EQ(published, 1);
  EXPECT_TRUE(s.integrity_ok());
}

// What runs before the copy is published runs in the rollback's transaction: when it throws,
// nothing of the rollback is left.
TEST_P(StoreTest, ARollbackWhoseSigningFailsLeavesNothing) {
  Store s = Store::open(path);
  s.create_map("m", kOrigin, 10, 0.2);
  for (int i = 1; i <= 2; ++i) {
    s.create_version("m", std::nullopt, "");
    put_cell(s, "m", i, i, 0, static_cast<std::uint32_t>(i));
    s.publish("m", i);
  }
  std::int64_t seen = 0;
  const std::string msg = error_of([&] {
    s.rollback("m", [&](std::int64_t staged) {
      seen = staged;
      EXPECT_EQ(s.find_version("m", staged)->state, VersionState::Staged);
      throw pl::Error("no key");
    });
  });
  EXPECT_TRUE(contains(msg, "no key")) << msg;
  EXPECT_EQ(seen, 3);
  EXPECT_EQ(s.find_map("m")->current, 2);
  EXPECT_EQ(s.list_versions("m").size(), 2u);
  EXPECT_EQ(s.rollback("m"), 3);
}

TEST_P(StoreTest, UnknownMapsAndVersions) {
  Store s = Store::open(path);
  EXPECT_FALSE(s.find_map("ghost"));
  EXPECT_FALSE(s.find_version("ghost", 1));
  EXPECT_TRUE(s.list_versions("ghost").empty());
  EXPECT_FALSE(s.find_tile("ghost", 1, {0, 0}));
  EXPECT_TRUE(s.list_tiles("ghost", 1).empty());
  EXPECT_TRUE(s.tiles_in_box("ghost", 1, -1e9, -1e9, 1e9, 1e9).empty());
  EXPECT_TRUE(s.upload_log("ghost").empty());
  for (auto& msg :
       {error_of([&] { s.create_version("ghost", std::nullopt, ""); }), error_of([&] { s.publish("ghost", 1); }),
        error_of([&] { s.rollback("ghost"); }), error_of([&] { put_cell(s, "ghost", 1, 0, 0, 1); }), error_of([&] {
          s.delete_tile("ghost", 1, {0, 0});
        })}) {
    EXPECT_TRUE(contains(msg, "unknown map ghost")) << msg;
    EXPECT_TRUE(contains(msg, path)) << msg;
  }
  EXPECT_FALSE(s.places("ghost", 1));
  EXPECT_FALSE(s.places_hash("ghost", 1));
  for (auto& msg : {error_of([&] { s.put_places("ghost", 1, "p"); }), error_of([&] { s.delete_places("ghost", 1); })}) {
    EXPECT_TRUE(contains(msg, "unknown map ghost")) << msg;
    EXPECT_TRUE(contains(msg, path)) << msg;
  }
  s.create_map("m", kOrigin, 10, 0.2);
  EXPECT_FALSE(s.find_version("m", 1));
  EXPECT_TRUE(contains(error_of([&] { s.publish("m", 1); }), "no version 1"));
  EXPECT_TRUE(contains(error_of([&] { put_cell(s, "m", 1, 0, 0, 1); }), "no version 1"));
  EXPECT_FALSE(s.places("m", 1));
  EXPECT_FALSE(s.places_hash("m", 1));
  EXPECT_TRUE(contains(error_of([&] { s.put_places("m", 1, "p"); }), "map m has no version 1"));
  EXPECT_TRUE(contains(error_of([&] { s.delete_places("m", 1); }), "map m has no version 1"));
}

// ---- tiles and blobs -----------------------------------------------------------------------------

TEST_P(StoreTest, PutTileIsIdempotentAndBlobsAreShared) {
  Store s = Store::open(path);
  s.create_map("m", kOrigin, 10, 0.2);
  s.create_version("m", std::nullopt, "");
  std::string data = fake_draco(42, 1000);
  auto r1 = s.put_tile("m", 1, {3, -4}, data, 1234, 31, -39, 0, 39, -31, 2);
  std::int64_t id1 = raw_scalar("SELECT id FROM tiles WHERE tx = 3 AND ty = -4");
  auto r2 = s.put_tile("m", 1, {3, -4}, data, 1234, 31, -39, 0, 39, -31, 2);
  EXPECT_EQ(r1.hash, pl::store::content_hash(data));
  EXPECT_EQ(r1.bytes, 1000);
  EXPECT_EQ(r2.hash, r1.hash);
  EXPECT_EQ(raw_scalar("SELECT id FROM tiles WHERE tx = 3 AND ty = -4"), id1);  // same record
  EXPECT_EQ(count("tiles"), 1);
  EXPECT_EQ(count("blobs"), 1);
  EXPECT_EQ(s.blob(r1.hash), data);
  EXPECT_TRUE(s.has_blob(r1.hash));
  EXPECT_FALSE(s.has_blob(pl::store::content_hash("other")));
  EXPECT_FALSE(s.blob(pl::store::content_hash("other")));

  auto found = s.find_tile("m", 1, {3, -4});
  ASSERT_TRUE(found);
  EXPECT_EQ(found->hash, r1.hash);
  EXPECT_EQ(found->points, 1234);
  EXPECT_DOUBLE_EQ(found->min_x, 31);
  EXPECT_DOUBLE_EQ(found->min_y, -39);
  EXPECT_DOUBLE_EQ(found->max_z, 2);

  // The same bytes under another key, and the copy in version 2: more rows, one blob.
  s.put_tile("m", 1, {0, 0}, data, 1234, 1, 1, 0, 9, 9, 2);
  s.publish("m", 1);
  s.create_version("m", std::nullopt, "");
  EXPECT_EQ(count("tiles"), 4);
  EXPECT_EQ(count("blobs"), 1);

  // New bytes for a key of version 2: a second blob; version 1 keeps its record and blob.
  std::string data2 = fake_draco(43, 700);
  auto r3 = s.put_tile("m", 2, {3, -4}, data2, 99, 31, -39, 0, 39, -31, 2);
  EXPECT_EQ(count("blobs"), 2);
  EXPECT_EQ(s.find_tile("m", 1, {3, -4})->hash, r1.hash);
  EXPECT_EQ(s.find_tile("m", 2, {3, -4})->hash, r3.hash);
  EXPECT_EQ(s.find_tile("m", 2, {3, -4})->points, 99);

  // Replacing it again drops the now unused blob; the shared one stays.
  s.put_tile("m", 2, {3, -4}, fake_draco(44, 600), 98, 31, -39, 0, 39, -31, 2);
  EXPECT_FALSE(s.has_blob(r3.hash));
  EXPECT_TRUE(s.has_blob(r1.hash));
  EXPECT_EQ(count("blobs"), 2);
  EXPECT_TRUE(s.integrity_ok());
}

// Bytes of every value, and long runs of them, come back as they went in (PostgreSQL hands bytea
// over as hex text, decoded by the store).
TEST_P(StoreTest, BlobsOfEveryByteValueReadBackExactly) {
  Store s = Store::open(path);
  s.create_map("m", kOrigin, 20, 0.2);
  s.create_version("m", std::nullopt, "");
  std::string every;
  for (int round = 0; round < 300; ++round)
    for (int b = 0; b < 256; ++b) every += static_cast<char>((b * 7 + round) & 0xFF);
  const auto rec = s.put_tile("m", 1, {0, 0}, every, 1, 0, 0, 0, 1, 1, 1);
  EXPECT_EQ(s.blob(rec.hash), every);
  const std::string one(1, '\0');
  const auto rec1 = s.put_tile("m", 1, {1, 0}, one, 1, 20, 0, 0, 21, 1, 1);
  EXPECT_EQ(s.blob(rec1.hash), one);
  s.put_places("m", 1, every);
  EXPECT_EQ(s.places("m", 1), every);
}

TEST_P(StoreTest, DeleteTile) {
  Store s = Store::open(path);
  s.create_map("m", kOrigin, 10, 0.2);
  s.create_version("m", std::nullopt, "");
  auto shared = put_cell(s, "m", 1, 0, 0, 1);
  s.publish("m", 1);
  s.create_version("m", std::nullopt, "");
  auto own = put_cell(s, "m", 2, 1, 1, 2);
  EXPECT_TRUE(s.delete_tile("m", 2, {0, 0}));
  EXPECT_FALSE(s.delete_tile("m", 2, {0, 0}));  // already gone
  EXPECT_FALSE(s.delete_tile("m", 2, {7, 7}));  // never there
  EXPECT_FALSE(s.find_tile("m", 2, {0, 0}));
  EXPECT_TRUE(s.find_tile("m", 1, {0, 0}));
  EXPECT_TRUE(s.has_blob(shared.hash));  // version 1 still uses it
  EXPECT_TRUE(s.delete_tile("m", 2, {1, 1}));
  EXPECT_FALSE(s.has_blob(own.hash));  // nobody uses it any more
  EXPECT_TRUE(s.tiles_in_box("m", 2, -100, -100, 100, 100).empty());
  EXPECT_EQ(s.tiles_in_box("m", 1, -100, -100, 100, 100).size(), 1u);
  if (sqlite()) {
    EXPECT_EQ(count("tile_rtree"), count("tiles"));
  }
  EXPECT_TRUE(s.integrity_ok());
}

TEST_P(StoreTest, PutTileValidatesItsInput) {
  Store s = Store::open(path);
  s.create_map("m", kOrigin, 10, 0.2);
  s.create_version("m", std::nullopt, "");
  EXPECT_TRUE(contains(error_of([&] { s.put_tile("m", 1, {0, 0}, "", 1, 0, 0, 0, 1, 1, 1); }), "empty"));
  EXPECT_TRUE(contains(error_of([&] { s.put_tile("m", 1, {0, 0}, "x", -1, 0, 0, 0, 1, 1, 1); }), "negative"));
  EXPECT_TRUE(contains(error_of([&] { s.put_tile("m", 1, {0, 0}, "x", 1, 2, 0, 0, 1, 1, 1); }), "min > max"));
  EXPECT_TRUE(contains(error_of([&] { s.put_tile("m", 1, {0, 0}, "x", 1, 0, 0, 0, 1, NAN, 1); }), "finite"));
  EXPECT_EQ(count("tiles"), 0);
  EXPECT_EQ(count("blobs"), 0);
}

TEST_P(StoreTest, TilesInBoxMatchesABruteForceFilter) {
  Store s = Store::open(path);
  s.create_map("m", kOrigin, 10, 0.2);
  s.create_map("other", kOrigin, 10, 0.2);
  s.create_version("m", std::nullopt, "");
  s.create_version("other", std::nullopt, "");
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  {
    Store::Transaction tx(s);
    for (int tx_ = -6; tx_ <= 5; ++tx_) {
      for (int ty = -6; ty <= 5; ++ty) {
        if ((tx_ * 7 + ty * 3) % 5 == 0) continue;  // holes
        // A random sub-box of the cell, with irrational-looking bounds (not float32-exact).
        double x0 = tx_ * 10.0, y0 = ty * 10.0;
        double ax = x0 + 4.9 * u(rng), bx = x0 + 5.0 + 4.999 * u(rng);
        double ay = y0 + 4.9 * u(rng), by = y0 + 5.0 + 4.999 * u(rng);
        std::uint32_t seed = static_cast<std::uint32_t>((tx_ + 10) * 100 + ty + 10);
        s.put_tile("m", 1, {tx_, ty}, fake_draco(seed, 64), 10, ax, ay, -1, bx, by, 1);
        // The other map has the same keys everywhere: it must never show up in m's answers.
        s.put_tile("other", 1, {tx_, ty}, fake_draco(seed + 1, 64), 10, x0, y0, -1, x0 + 10, y0 + 10, 1);
      }
    }
    tx.commit();
  }
  s.publish("m", 1);
  s.create_version("m", std::nullopt, "");  // version 2: copies, some moved and deleted
  s.put_tile("m", 2, {0, 0}, fake_draco(1, 64), 10, 40, 40, 0, 41, 41, 1);
  s.delete_tile("m", 2, {-6, -6});
  auto all1 = s.list_tiles("m", 1);
  auto all2 = s.list_tiles("m", 2);
  ASSERT_GT(all1.size(), 100u);

  auto brute = [](const std::vector<TileRecord>& all, double x0, double y0, double x1, double y1) {
    std::vector<TileRecord> out;
    for (const auto& t : all)
      if (t.min_x <= x1 && t.max_x >= x0 && t.min_y <= y1 && t.max_y >= y0) out.push_back(t);
    return out;
  };
  auto same = [](const std::vector<TileRecord>& a, const std::vector<TileRecord>& b) {
    if (a.size() != b.size()) return false;
    for (std::size_t i = 0; i < a.size(); ++i)
      if (a[i].key != b[i].key || a[i].hash != b[i].hash || a[i].min_x != b[i].min_x || a[i].max_y != b[i].max_y)
        return false;
    return true;
  };

  std::vector<std::array<double, 4>> queries;
  std::uniform_real_distribution<double> c(-75.0, 65.0), w(0.0, 30.0);
  for (int i = 0; i < 300; ++i) {
    double x = c(rng), y = c(rng);
    queries.push_back({x, y, x + w(rng) * (i % 3), y + w(rng) * (i % 4)});  // includes points and lines
  }
  queries.push_back({-1e9, -1e9, 1e9, 1e9});
  queries.push_back({1000, 1000, 2000, 2000});
  // Rectangles that exactly touch a tile's edge from outside (closed boxes: they intersect).
  for (std::size_t i = 0; i < all1.size(); i += 17) {
    const auto& t = all1[i];
    queries.push_back({t.max_x, t.min_y, t.max_x + 3, t.max_y});
    queries.push_back({t.min_x - 3, t.max_y, t.min_x, t.max_y + 3});
    queries.push_back({t.min_x - 3, t.min_y - 3, std::nextafter(t.min_x, -1e9), t.max_y});  // just misses
  }
  std::size_t nonempty = 0;
  for (const auto& q : queries) {
    auto got1 = s.tiles_in_box("m", 1, q[0], q[1], q[2], q[3]);
    auto want1 = brute(all1, q[0], q[1], q[2], q[3]);
    EXPECT_TRUE(same(got1, want1)) << q[0] << " " << q[1] << " " << q[2] << " " << q[3] << ": " << got1.size() << " vs "
                                   << want1.size();
    auto got2 = s.tiles_in_box("m", 2, q[0], q[1], q[2], q[3]);
    EXPECT_TRUE(same(got2, brute(all2, q[0], q[1], q[2], q[3])));
    nonempty += !want1.empty();
  }
  EXPECT_GT(nonempty, queries.size() / 3);
  EXPECT_TRUE(s.tiles_in_box("m", 1, 10, 10, -10, -10).empty());  // inverted
  EXPECT_TRUE(s.tiles_in_box("m", 1, NAN, 0, 10, 10).empty());
  EXPECT_TRUE(s.tiles_in_box("m", 3, -1e9, -1e9, 1e9, 1e9).empty());  // no such version
}

// ---- tokens and the upload log -------------------------------------------------------------------

TEST_P(StoreTest, TokensAreStoredHashed) {
  const std::string reader = "rd-7f3a9c2e41b84d0f9a6e5c3b2a1d0e9f";
  const std::string uploader = "up-0a1b2c3d4e5f60718293a4b5c6d7e8f9";
  const std::string admin = "ad-ffeeddccbbaa99887766554433221100";
  {
    Store s = Store::open(path);
    s.add_token(reader, Role::Read, "viewer");
    s.add_token(uploader, Role::Upload, "survey car");
    s.add_token(admin, Role::Admin, "ops");
    EXPECT_EQ(s.check_token(reader), Role::Read);
    EXPECT_EQ(s.check_token(uploader), Role::Upload);
    EXPECT_EQ(s.check_token(admin), Role::Admin);
    EXPECT_FALSE(s.check_token("rd-unknown"));
    EXPECT_FALSE(s.check_token(""));
    EXPECT_FALSE(s.check_token(pl::store::content_hash(reader)));  // the hash is not a token
    std::string msg = error_of([&] { s.add_token(reader, Role::Admin, "again"); });
    EXPECT_TRUE(contains(msg, "already registered")) << msg;
    EXPECT_FALSE(contains(msg, reader));
    EXPECT_EQ(s.check_token(reader), Role::Read);
    EXPECT_TRUE(contains(error_of([&] { s.add_token("", Role::Read, ""); }), "empty token"));
  }
  if (sqlite()) {
    // The file (and any WAL left) holds the hashes, never the tokens.
    std::string bytes;
    for (const char* suffix : {"", "-wal", "-shm"}) bytes += file_bytes(path + suffix);
    for (const auto& t : {reader, uploader, admin}) {
      EXPECT_FALSE(contains(bytes, t)) << t;
      EXPECT_TRUE(contains(bytes, pl::store::content_hash(t))) << t;
    }
  } else {
    // The database holds the hashes, never the tokens, in any column of any table.
    for (const auto& t : {reader, uploader, admin}) {
      EXPECT_EQ(raw_scalar("SELECT count(*) FROM tokens WHERE hash = '" + pl::store::content_hash(t) + "'"), 1) << t;
      EXPECT_EQ(raw_scalar("SELECT count(*) FROM tokens AS k WHERE position('" + t + "' IN k::text) > 0"), 0) << t;
    }
  }
  Store s = Store::open(path);
  EXPECT_EQ(s.check_token(admin), Role::Admin);
}

TEST_P(StoreTest, TokensHaveIdsAndAreRevokedForEveryConnectionAtOnce) {
  Store s = Store::open(path);
  Store other = Store::open(path);  // another connection: another server thread, process or replica
  const std::string a = pl::store::random_token(), b = pl::store::random_token();
  EXPECT_EQ(a.size(), 43u);
  EXPECT_NE(a, b);
  EXPECT_EQ(a.find_first_not_of("ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789-_"), std::string::npos) << a;
  const auto ida = s.add_token(a, Role::Upload, "survey car 1");
  const auto idb = s.add_token(b, Role::Admin, "ops");
  EXPECT_NE(ida, idb);
  auto found = other.find_token(a);
  ASSERT_TRUE(found);
  EXPECT_EQ(found->id, ida);
  EXPECT_EQ(found->role, Role::Upload);
  EXPECT_EQ(found->note, "survey car 1");
  EXPECT_TRUE(is_utc_iso8601(found->created)) << found->created;
  EXPECT_FALSE(found->revoked);

  EXPECT_TRUE(s.revoke_token(ida));
  EXPECT_FALSE(other.find_token(a));  // at once, on the other connection too
  EXPECT_FALSE(other.check_token(a));
  EXPECT_EQ(other.check_token(b), Role::Admin);  // the rest stay in force
  EXPECT_FALSE(s.revoke_token(ida));             // once
  EXPECT_FALSE(s.revoke_token(idb + 1000));      // no such token
  // A revoked token cannot be registered again (that would bring it back).
  EXPECT_TRUE(contains(error_of([&] { s.add_token(a, Role::Read, "again"); }), "already registered"));
  EXPECT_FALSE(s.check_token(a));

  auto list = other.list_tokens();
  ASSERT_EQ(list.size(), 2u);
  EXPECT_EQ(list[0].id, ida);
  ASSERT_TRUE(list[0].revoked);
  EXPECT_TRUE(is_utc_iso8601(*list[0].revoked)) << *list[0].revoked;
  EXPECT_FALSE(list[1].revoked);
  EXPECT_EQ(list[1].role, Role::Admin);
}

TEST_P(StoreTest, UploadLogIsAppendOnly) {
  {
    Store s = Store::open(path);
    s.log_upload("city", 3, "upload", "120 tiles", "survey-car-1");
    s.log_upload("city", std::nullopt, "create", "", "ops");
    s.log_upload("elsewhere", 1, "publish", "", "ops");
    auto log = s.upload_log("city");
    ASSERT_EQ(log.size(), 2u);
    EXPECT_EQ(log[0].action, "upload");
    EXPECT_EQ(log[0].version, 3);
    EXPECT_EQ(log[0].detail, "120 tiles");
    EXPECT_EQ(log[0].who, "survey-car-1");
    EXPECT_EQ(log[0].map, "city");
    EXPECT_TRUE(is_utc_iso8601(log[0].at)) << log[0].at;
    EXPECT_EQ(log[1].action, "create");
    EXPECT_FALSE(log[1].version);
    EXPECT_LT(log[0].id, log[1].id);
    EXPECT_TRUE(contains(error_of([&] { s.log_upload("city", 1, "", "", ""); }), "action"));
  }
  std::string msg = raw_exec("UPDATE upload_log SET who = 'mallory'");
  EXPECT_TRUE(contains(msg, "append-only")) << msg;
  msg = raw_exec("DELETE FROM upload_log WHERE map = 'city'");
  EXPECT_TRUE(contains(msg, "append-only")) << msg;
  EXPECT_EQ(raw_scalar("SELECT count(*) FROM upload_log"), 3);
  EXPECT_EQ(raw_scalar("SELECT count(*) FROM upload_log WHERE who = 'mallory'"), 0);
  EXPECT_EQ(raw_exec("INSERT INTO upload_log (map, action) VALUES ('x', 'note')"), "");  // appending works
}

TEST_P(StoreTest, SchemaRefusesTileWritesToPublishedVersions) {
  {
    Store s = Store::open(path);
    s.create_map("m", kOrigin, 10, 0.2);
    s.create_version("m", std::nullopt, "");
    put_cell(s, "m", 1, 0, 0, 1);
    s.publish("m", 1);
  }
  EXPECT_TRUE(contains(raw_exec("DELETE FROM tiles"), "staged"));
  EXPECT_TRUE(contains(raw_exec("UPDATE tiles SET points = 0"), "staged"));
  EXPECT_TRUE(contains(raw_exec("INSERT INTO tiles (map_id, version, tx, ty, hash, points, bytes, min_x, min_y, "
                                "min_z, max_x, max_y, max_z) SELECT map_id, version, 5, 5, hash, 1, 1, 0, 0, 0, 1, "
                                "1, 1 FROM tiles"),
                       "staged"));
  EXPECT_NE(raw_exec("UPDATE versions SET state = 'staged'"), "");
  EXPECT_NE(raw_exec("DELETE FROM blobs"), "");  // still used by a tile
  EXPECT_EQ(raw_scalar("SELECT count(*) FROM tiles"), 1);
}

// ---- places --------------------------------------------------------------------------------------

TEST_P(StoreTest, PlacesArePutReadReplacedAndDeleted) {
  Store s = Store::open(path);
  s.create_map("m", kOrigin, 10, 0.2);
  s.create_version("m", std::nullopt, "");
  EXPECT_FALSE(s.places("m", 1));
  EXPECT_FALSE(s.places_hash("m", 1));
  const std::string a = fake_draco(7, 5000) + std::string("\0end", 4), b = fake_draco(8, 300);
  s.put_places("m", 1, a);
  EXPECT_EQ(s.places("m", 1), a);  // byte for byte, NULs included
  EXPECT_EQ(s.places_hash("m", 1), pl::store::content_hash(a));
  const std::int64_t id = raw_scalar("SELECT id FROM places");
  EXPECT_EQ(raw_scalar("SELECT size FROM places"), 5004);
  s.put_places("m", 1, a);  // the same bytes again: nothing changes
  s.put_places("m", 1, b);  // other bytes replace them, in the same row
  EXPECT_EQ(s.places("m", 1), b);
  EXPECT_EQ(s.places_hash("m", 1), pl::store::content_hash(b));
  EXPECT_EQ(raw_scalar("SELECT id FROM places"), id);
  EXPECT_EQ(count("places"), 1);
  EXPECT_EQ(count("blobs"), 0);  // places are not tile blobs
  EXPECT_TRUE(s.integrity_ok());

  std::string msg = error_of([&] { s.put_places("m", 1, ""); });
  EXPECT_TRUE(contains(msg, path + ": map m version 1 places: empty")) << msg;
  msg = error_of([&] { s.put_places("m", 1, std::string(pl::api::kMaxPlacesBytes + 1, 'x')); });
  EXPECT_TRUE(contains(msg, "more than the store's limit of 64 MiB")) << msg;
  EXPECT_EQ(s.places("m", 1), b);  // refused writes leave them

  EXPECT_TRUE(s.delete_places("m", 1));
  EXPECT_FALSE(s.delete_places("m", 1));  // already gone
  EXPECT_FALSE(s.places("m", 1));
  EXPECT_FALSE(s.places_hash("m", 1));
  EXPECT_EQ(count("places"), 0);
  EXPECT_TRUE(s.integrity_ok());
}

TEST_P(StoreTest, PlacesAreWrittenOnlyWhileStagedAndCopiedToAChildVersion) {
  Store s = Store::open(path);
  s.create_map("m", kOrigin, 10, 0.2);
  s.create_version("m", std::nullopt, "");
  const std::string first = fake_draco(1, 2000), second = fake_draco(2, 1000);
  put_cell(s, "m", 1, 0, 0, 1);
  s.put_places("m", 1, first);
  s.publish("m", 1);
  std::string msg = error_of([&] { s.put_places("m", 1, second); });
  EXPECT_TRUE(contains(msg, path + ": map m version 1 is published: places can only be changed in a staged version"))
      << msg;
  EXPECT_TRUE(contains(error_of([&] { s.delete_places("m", 1); }), "version 1 is published")) << msg;

  // A new version starts with a copy of its parent's places; changing the copy leaves the parent's.
  auto v2 = s.create_version("m", std::nullopt, "");
  EXPECT_EQ(v2.parent, 1);
  EXPECT_EQ(s.places("m", 2), first);
  s.put_places("m", 2, second);
  EXPECT_EQ(s.places("m", 1), first);
  EXPECT_EQ(s.places("m", 2), second);
  EXPECT_TRUE(s.delete_places("m", 2));
  EXPECT_EQ(s.places("m", 1), first);
  auto v3 = s.create_version("m", 2, "from 2, which has none");
  EXPECT_FALSE(s.places("m", v3.number));
  s.put_places("m", 2, second);
  s.publish("m", 2);
  msg = error_of([&] { s.put_places("m", 1, second); });
  EXPECT_TRUE(contains(msg, "version 1 is retired")) << msg;
  EXPECT_EQ(s.places("m", 1), first);
  EXPECT_EQ(s.places("m", 2), second);
  EXPECT_TRUE(s.integrity_ok());

  // The schema refuses other writers too.
  EXPECT_TRUE(contains(raw_exec("UPDATE places SET size = size WHERE version = 1"), "staged"));
  EXPECT_TRUE(contains(raw_exec("DELETE FROM places WHERE version = 2"), "staged"));
  EXPECT_TRUE(contains(raw_exec("INSERT INTO places (map_id, version, hash, bytes, size) SELECT map_id, 1, hash, bytes, "
                                "size FROM places WHERE version = 2"),
                       "staged"));
  // Version 3 is staged: the CHECK constraints still hold.
  const std::string nul_hash = pl::store::content_hash(std::string(1, '\0'));
  EXPECT_NE(raw_exec("INSERT INTO places (map_id, version, hash, bytes, size) VALUES (1, 3, 'x', " + bytes_literal("00") + ", 1)"), "");
  EXPECT_NE(raw_exec("INSERT INTO places (map_id, version, hash, bytes, size) VALUES (1, 3, '" + nul_hash + "', " + bytes_literal("00") + ", 2)"), "");
  EXPECT_NE(raw_exec("INSERT INTO places (map_id, version, hash, bytes, size) VALUES (1, 3, '" + nul_hash + "', " + bytes_literal("") + ", 0)"), "");
  EXPECT_EQ(raw_scalar("SELECT count(*) FROM places"), 2);
}

// ---- change reports ------------------------------------------------------------------------------

// A report's bytes as the vehicle sent them: JSON here, but the store keeps any bytes, NULs included.
std::string report_json(const std::string& drive, int cells, char tail = '}') {
  std::string out = R"({"format":"pl-change-report","drive":")" + drive + R"(","tiles":[)";
  for (int i = 0; i < cells; ++i) out += (i ? "," : "") + std::to_string(i * 7919 % 1000);
  return out + "]" + std::string("\0", 1) + tail;
}

TEST_P(StoreTest, AChangeReportIsStoredOncePerDriveAndReadBackExactly) {
  Store s = Store::open(path);
  s.create_map("m", kOrigin, 10, 0.2);
  s.create_version("m", std::nullopt, "");
  s.publish("m", 1);
  s.create_version("m", std::nullopt, "");  // 2, staged
  const std::string a = report_json("d-1", 3000), b = report_json("d-1", 3000, ']');
  ASSERT_EQ(a.size(), b.size());
  using Put = Store::ReportPut;
  EXPECT_EQ(s.put_report("m", 1, "car-7", "2024-05-01:d-1", 1714550000.25, 1714553600.5, a, "token 3"), Put::Stored);
  auto list = s.list_reports("m");
  ASSERT_EQ(list.size(), 1u);
  const Store::ReportInfo r = list[0];
  EXPECT_GT(r.id, 0);
  EXPECT_EQ(r.map, "m");
  EXPECT_EQ(r.version, 1);
  EXPECT_EQ(r.vehicle, "car-7");
  EXPECT_EQ(r.drive, "2024-05-01:d-1");
  EXPECT_EQ(r.start, 1714550000.25);  // exactly
  EXPECT_EQ(r.end, 1714553600.5);
  EXPECT_EQ(r.hash, pl::store::content_hash(a));
  EXPECT_EQ(r.bytes, static_cast<std::int64_t>(a.size()));
  EXPECT_TRUE(is_utc_iso8601(r.received)) << r.received;
  EXPECT_EQ(r.who, "token 3");
  EXPECT_EQ(s.report_body("m", r.id), a);  // byte for byte, the NUL included

  // The same drive sent again: the same report, nothing written (not even a new time).
  EXPECT_EQ(s.put_report("m", 1, "car-7", "2024-05-01:d-1", 1714550000.25, 1714553600.5, a, "token 3"), Put::AlreadyStored);
  // Other bytes for that drive: a conflict, and the first report stays.
  EXPECT_EQ(s.put_report("m", 1, "car-7", "2024-05-01:d-1", 1714550000.25, 1714553600.5, b, "token 4"), Put::Conflict);
  EXPECT_EQ(s.put_report("m", 2, "car-7", "2024-05-01:d-1", 1, 2, b, "token 4"), Put::Conflict);  // whatever version
  EXPECT_EQ(count("change_reports"), 1);
  list = s.list_reports("m");
  ASSERT_EQ(list.size(), 1u);
  EXPECT_EQ(list[0].received, r.received);
  EXPECT_EQ(list[0].who, "token 3");
  EXPECT_EQ(s.report_body("m", r.id), a);

  // The key is (map, vehicle, drive): another vehicle's drive of the same name is another report,
  // and so is a report against a staged version.
  EXPECT_EQ(s.put_report("m", 1, "car-8", "2024-05-01:d-1", 10, 20, b, "token 4"), Put::Stored);
  EXPECT_EQ(s.put_report("m", 2, "car-7", "d-2", 30, 30, "{}", "token 3"), Put::Stored);
  EXPECT_EQ(s.put_report("m", 1, "Az09_.:-", std::string(128, 'x'), -5, 5, "x", "who"), Put::Stored);
  list = s.list_reports("m");
  ASSERT_EQ(list.size(), 4u);
  for (std::size_t i = 1; i < list.size(); ++i) EXPECT_LT(list[i - 1].id, list[i].id);  // the order received
  EXPECT_EQ(list[1].vehicle, "car-8");
  EXPECT_EQ(s.report_body("m", list[1].id), b);
  EXPECT_EQ(list[2].version, 2);
  EXPECT_EQ(list[2].start, list[2].end);
  EXPECT_EQ(list[3].drive, std::string(128, 'x'));

  // By version.
  const auto v1 = s.list_reports("m", 1), v2 = s.list_reports("m", 2);
  ASSERT_EQ(v1.size(), 3u);
  EXPECT_EQ(v1[0].id, list[0].id);
  EXPECT_EQ(v1[1].id, list[1].id);
  EXPECT_EQ(v1[2].id, list[3].id);
  ASSERT_EQ(v2.size(), 1u);
  EXPECT_EQ(v2[0].drive, "d-2");
  EXPECT_TRUE(s.list_reports("m", 3).empty());

  // Unknown maps and ids read as nothing.
  s.create_map("n", kOrigin, 10, 0.2);
  EXPECT_TRUE(s.list_reports("n").empty());
  EXPECT_TRUE(s.list_reports("nope").empty());
  EXPECT_TRUE(s.list_reports("bad name").empty());
  EXPECT_FALSE(s.report_body("n", r.id));  // another map's report
  EXPECT_FALSE(s.report_body("nope", r.id));
  EXPECT_FALSE(s.report_body("m", list.back().id + 1000));
  EXPECT_EQ(count("blobs"), 0);  // reports are not tile blobs
  EXPECT_TRUE(s.integrity_ok());

  // Another connection sees them (a server replica).
  Store other = Store::open(path, false);
  EXPECT_EQ(other.list_reports("m").size(), 4u);
  EXPECT_EQ(other.report_body("m", r.id), a);
}

TEST_P(StoreTest, ChangeReportsRefuseUnknownMapsVersionsAndBadArguments) {
  Store s = Store::open(path);
  s.create_map("m", kOrigin, 10, 0.2);
  s.create_version("m", std::nullopt, "");
  const std::string body = report_json("d", 10);
  auto put = [&](const std::string& map, std::int64_t version, const std::string& vehicle, const std::string& drive,
                 double start, double end, const std::string& bytes, const std::string& who) {
    return error_of([&] { s.put_report(map, version, vehicle, drive, start, end, bytes, who); });
  };
  std::string msg = put("ghost", 1, "car", "d", 0, 1, body, "t");
  EXPECT_TRUE(contains(msg, path + ": unknown map ghost")) << msg;
  msg = put("m", 7, "car", "d", 0, 1, body, "t");
  EXPECT_TRUE(contains(msg, path + ": map m has no version 7")) << msg;
  msg = put("bad name", 1, "car", "d", 0, 1, body, "t");
  EXPECT_TRUE(contains(msg, "invalid map name")) << msg;
  for (const std::string& bad : {std::string(), std::string(129, 'v'), std::string("car 7"), std::string("car/7"),
                                 std::string("car\n"), std::string("nul\0x", 5), std::string("m\xc3\xbcller")}) {
    msg = put("m", 1, bad, "d", 0, 1, body, "t");
    EXPECT_TRUE(contains(msg, path + ": map m version 1: change report: the vehicle id must be 1 to 128 of")) << msg;
    msg = put("m", 1, "car", bad, 0, 1, body, "t");
    EXPECT_TRUE(contains(msg, "the drive id must be 1 to 128 of")) << msg;
  }
  for (auto [start, end] : {std::pair<double, double>{2, 1}, {NAN, 1}, {0, NAN}, {-INFINITY, 0}, {0, INFINITY}}) {
    msg = put("m", 1, "car", "d", start, end, body, "t");
    EXPECT_TRUE(contains(msg, "change report of vehicle car drive d: the drive's span must be finite")) << msg;
  }
  msg = put("m", 1, "car", "d", 0, 1, "", "t");
  EXPECT_TRUE(contains(msg, "empty report")) << msg;
  msg = put("m", 1, "car", "d", 0, 1, std::string((std::size_t{32} << 20) + 1, 'x'), "t");
  EXPECT_TRUE(contains(msg, "more than the store's limit of 32 MiB")) << msg;
  msg = put("m", 1, "car", "d", 0, 1, body, "");
  EXPECT_TRUE(contains(msg, "empty sender")) << msg;
  EXPECT_EQ(count("change_reports"), 0);  // nothing written by any of them

  // Inside a Transaction, a refused put undoes only itself.
  {
    Store::Transaction tx(s);
    EXPECT_EQ(s.put_report("m", 1, "car", "d-1", 0, 1, body, "t"), Store::ReportPut::Stored);
    EXPECT_THROW(s.put_report("m", 9, "car", "d-2", 0, 1, body, "t"), pl::Error);
    EXPECT_EQ(s.put_report("m", 1, "car", "d-1", 0, 1, body, "t"), Store::ReportPut::AlreadyStored);
    tx.commit();
  }
  EXPECT_EQ(s.list_reports("m").size(), 1u);

  // The schema refuses what the store does: other writers too.
  const std::string hash = pl::store::content_hash("x");
  auto insert = [&](const std::string& vehicle, const std::string& drive, const std::string& span, const std::string& h,
                    const std::string& bytes, const std::string& size, const std::string& who) {
    return raw_exec("INSERT INTO change_reports (map_id, version, vehicle, drive, start_s, end_s, hash, body, size, who) "
                    "VALUES (1, 1, " + vehicle + ", " + drive + ", " + span + ", " + h + ", " + bytes + ", " + size + ", " +
                    who + ")");
  };
  const std::string x = bytes_literal("78");
  EXPECT_EQ(insert("'car'", "'raw'", "0, 1", "'" + hash + "'", x, "1", "'t'"), "");
  EXPECT_NE(insert("'car'", "'raw'", "0, 1", "'" + hash + "'", x, "1", "'t'"), "");  // the same drive again
  EXPECT_NE(insert("'car 7'", "'r2'", "0, 1", "'" + hash + "'", x, "1", "'t'"), "");
  EXPECT_NE(insert("'car'", "''", "0, 1", "'" + hash + "'", x, "1", "'t'"), "");
  EXPECT_NE(insert("'car'", "'r3'", "2, 1", "'" + hash + "'", x, "1", "'t'"), "");
  EXPECT_NE(insert("'car'", "'r4'", "0, 1", "'XYZ'", x, "1", "'t'"), "");
  EXPECT_NE(insert("'car'", "'r5'", "0, 1", "'" + hash + "'", x, "2", "'t'"), "");
  EXPECT_NE(insert("'car'", "'r6'", "0, 1", "'" + hash + "'", bytes_literal(""), "0", "'t'"), "");
  EXPECT_NE(insert("'car'", "'r7'", "0, 1", "'" + hash + "'", x, "1", "''"), "");
  EXPECT_NE(raw_exec("INSERT INTO change_reports (map_id, version, vehicle, drive, start_s, end_s, hash, body, size, who) "
                     "VALUES (1, 5, 'car', 'r8', 0, 1, '" + hash + "', " + x + ", 1, 't')"),
            "");  // no version 5
  EXPECT_EQ(count("change_reports"), 2);
}

TEST_P(StoreTest, ChangeReportsAreDeletedByTimeAndNeverChanged) {
  Store s = Store::open(path);
  for (const char* map : {"m", "n"}) {
    s.create_map(map, kOrigin, 10, 0.2);
    s.create_version(map, std::nullopt, "");
  }
  s.put_report("m", 1, "car", "early", 0, 1, "{}", "t");
  s.put_report("n", 1, "car", "early", 0, 1, "{}", "t");
  const std::string early = s.list_reports("m").at(0).received;
  std::string late;
  // The next millisecond at least: times are kept to the millisecond.
  for (int i = 0; i < 1000 && (late.empty() || late <= early); ++i) {
    usleep(2000);
    s.put_report("m", 1, "car", "late-" + std::to_string(i), 0, 1, "{}", "t");
    late = s.list_reports("m").back().received;
  }
  ASSERT_LT(early, late);
  const std::int64_t reports = static_cast<std::int64_t>(s.list_reports("m").size());

  EXPECT_EQ(s.delete_reports("m", "2000-01-01T00:00:00.000Z"), 0);
  EXPECT_EQ(s.delete_reports("m", early), 0);  // before it, not at it
  // Every report received before the last one: the first and any made in the same millisecond as it.
  const std::int64_t before_late = s.delete_reports("m", late);
  EXPECT_GE(before_late, 1);
  EXPECT_EQ(static_cast<std::int64_t>(s.list_reports("m").size()), reports - before_late);
  EXPECT_EQ(s.list_reports("m").back().received, late);
  EXPECT_EQ(s.list_reports("n").size(), 1u);  // another map's reports stay
  EXPECT_EQ(s.delete_reports("m", "9999-12-31T23:59:59.999Z"), reports - before_late);
  EXPECT_TRUE(s.list_reports("m").empty());
  EXPECT_EQ(s.list_reports("n").size(), 1u);
  // A drive retention forgot may be reported again.
  EXPECT_EQ(s.put_report("m", 1, "car", "early", 0, 1, "{}", "t"), Store::ReportPut::Stored);

  std::string msg = error_of([&] { s.delete_reports("ghost", late); });
  EXPECT_TRUE(contains(msg, path + ": unknown map ghost")) << msg;
  for (const std::string& bad :
       {std::string("yesterday"), std::string("2024-05-01T10:11:12Z"), std::string("2024-05-01 10:11:12.345"),
        std::string("2024-02-30T00:00:00.000Z"), std::string("2023-02-29T00:00:00.000Z"), std::string("2024-13-01T00:00:00.000Z"),
        std::string("2024-05-01T24:00:00.000Z"), std::string("0000-01-01T00:00:00.000Z"), std::string()}) {
    msg = error_of([&] { s.delete_reports("m", bad); });
    EXPECT_TRUE(contains(msg, "YYYY-MM-DDTHH:MM:SS.sssZ")) << "[" << bad << "] " << msg;
  }
  EXPECT_EQ(s.delete_reports("m", "2024-02-29T23:59:59.999Z"), 0);  // a leap day
  EXPECT_EQ(s.list_reports("m").size(), 1u);

  // Reports never change: the schema refuses every other writer's update too. Deleting is retention.
  msg = raw_exec("UPDATE change_reports SET who = 'mallory'");
  EXPECT_TRUE(contains(msg, "change reports never change")) << msg;
  EXPECT_TRUE(contains(raw_exec("UPDATE change_reports SET version = version"), "never change"));
  EXPECT_EQ(raw_scalar("SELECT count(*) FROM change_reports WHERE who = 'mallory'"), 0);
  EXPECT_EQ(raw_exec("DELETE FROM change_reports WHERE vehicle = 'car'"), "");
  EXPECT_EQ(count("change_reports"), 0);
}

TEST_P(StoreTest, AChangeReportAlteredOnDiskIsDamage) {
  {
    Store s = Store::open(path);
    s.create_map("m", kOrigin, 10, 0.2);
    s.create_version("m", std::nullopt, "");
    s.put_report("m", 1, "car", "d", 0, 1, report_json("d", 500), "t");
    EXPECT_TRUE(s.integrity_ok());
  }
  ASSERT_EQ(pl::test::zero_report_bodies(GetParam(), path), "");
  Store s = Store::open(path, false);
  const auto list = s.list_reports("m");  // the row itself still reads
  ASSERT_EQ(list.size(), 1u);
  const std::string msg = error_of([&] { s.report_body("m", list[0].id); });
  EXPECT_TRUE(contains(msg, path + ": the map store is damaged (change_reports.body of change report " +
                                std::to_string(list[0].id) + " does not match its content hash)"))
      << msg;
  EXPECT_TRUE(contains(msg, "restore it from a backup, or rebuild it with pl-map")) << msg;
  EXPECT_FALSE(s.integrity_ok());
}

TEST_P(StoreTest, AReportTokenRoundTrips) {
  const std::string car = pl::store::random_token();
  std::int64_t id = 0;
  {
    Store s = Store::open(path);
    s.add_token(pl::store::random_token(), Role::Read, "viewer");
    id = s.add_token(car, Role::Report, "car 7");
    EXPECT_EQ(s.check_token(car), Role::Report);
  }
  EXPECT_EQ(raw_scalar("SELECT count(*) FROM tokens WHERE role = 'report'"), 1);
  Store s = Store::open(path, false);
  const auto found = s.find_token(car);
  ASSERT_TRUE(found);
  EXPECT_EQ(found->id, id);
  EXPECT_EQ(found->role, Role::Report);
  EXPECT_EQ(found->note, "car 7");
  const auto list = s.list_tokens();
  ASSERT_EQ(list.size(), 2u);
  EXPECT_EQ(list[1].role, Role::Report);
  EXPECT_TRUE(s.revoke_token(id));
  EXPECT_FALSE(s.check_token(car));
  EXPECT_NE(raw_exec("INSERT INTO tokens (hash, role) VALUES ('" + pl::store::content_hash("x") + "', 'vehicle')"), "");
}

// ---- transactions and maintenance ----------------------------------------------------------------

TEST_P(StoreTest, TransactionCommitsAndRollsBackOnDestruction) {
  Store s = Store::open(path);
  s.create_map("m", kOrigin, 10, 0.2);
  s.create_version("m", std::nullopt, "");
  {
    Store::Transaction tx(s);
    for (int i = 0; i < 50; ++i) put_cell(s, "m", 1, i, 0, static_cast<std::uint32_t>(i));
    tx.commit();
  }
  EXPECT_EQ(s.list_tiles("m", 1).size(), 50u);
  {
    Store::Transaction tx(s);
    for (int i = 0; i < 50; ++i) put_cell(s, "m", 1, i, 1, static_cast<std::uint32_t>(100 + i));
    s.delete_tile("m", 1, {0, 0});
    s.create_map("n", kOrigin, 10, 0.2);
    s.publish("m", 1);
    EXPECT_EQ(s.list_tiles("m", 1).size(), 99u);  // the transaction sees its own writes
  }                                               // not committed
  EXPECT_EQ(s.list_tiles("m", 1).size(), 50u);
  EXPECT_FALSE(s.find_map("n"));
  EXPECT_FALSE(s.find_map("m")->current);
  EXPECT_EQ(count("blobs"), 50);

  // An exception leaves the scope: rolled back too.
  try {
    Store::Transaction tx(s);
    put_cell(s, "m", 1, 99, 99, 999);
    throw std::runtime_error("import failed");
  } catch (const std::runtime_error&) {
  }
  EXPECT_FALSE(s.find_tile("m", 1, {99, 99}));
  EXPECT_TRUE(s.integrity_ok());
}

TEST_P(StoreTest, AFailedCallInsideATransactionUndoesOnlyItself) {
  Store s = Store::open(path);
  s.create_map("m", kOrigin, 10, 0.2);
  s.create_version("m", std::nullopt, "");
  s.publish("m", 1);
  s.create_version("m", std::nullopt, "");
  {
    Store::Transaction tx(s);
    put_cell(s, "m", 2, 0, 0, 1);
    EXPECT_THROW(put_cell(s, "m", 1, 0, 0, 2), pl::Error);  // published
    EXPECT_THROW(s.create_map("m", kOrigin, 10, 0.2), pl::Error);
    {
      Store::Transaction inner(s);  // nested: a savepoint
      put_cell(s, "m", 2, 1, 0, 3);
    }  // inner rolled back
    {
      Store::Transaction inner(s);
      put_cell(s, "m", 2, 2, 0, 4);
      inner.commit();
    }
    tx.commit();
  }
  EXPECT_TRUE(s.find_tile("m", 2, {0, 0}));
  EXPECT_FALSE(s.find_tile("m", 2, {1, 0}));
  EXPECT_TRUE(s.find_tile("m", 2, {2, 0}));
  EXPECT_EQ(count("blobs"), 2);
}

TEST_P(StoreTest, IntegrityAndSize) {
  Store s = Store::open(path);
  EXPECT_TRUE(s.integrity_ok());
  std::int64_t empty = s.database_bytes();
  EXPECT_GT(empty, 0);
  s.create_map("m", kOrigin, 10, 0.2);
  s.create_version("m", std::nullopt, "note with 'quotes'; DROP TABLE maps; --");
  {
    Store::Transaction tx(s);
    for (int i = 0; i < 20; ++i) put_cell(s, "m", 1, i, -i, static_cast<std::uint32_t>(i), 50000);
    tx.commit();
  }
  s.delete_tile("m", 1, {3, -3});
  put_cell(s, "m", 1, 4, -4, 77, 100);
  s.publish("m", 1);
  s.create_version("m", std::nullopt, "");
  s.log_upload("m", 1, "upload", "", "");
  EXPECT_EQ(s.find_version("m", 1)->note, "note with 'quotes'; DROP TABLE maps; --");
  EXPECT_GE(s.database_bytes(), empty + 18 * 50000);
  EXPECT_TRUE(s.integrity_ok());

  if (sqlite()) {
    // Tampering with the R*Tree behind the store's back is noticed.
    ASSERT_EQ(raw_exec("DELETE FROM tile_rtree WHERE id = (SELECT max(id) FROM tiles)"), "");
  } else {
    // Bytes of a blob edited behind the store's back (the same length: the CHECK on size holds).
    ASSERT_EQ(raw_exec("UPDATE blobs SET bytes = decode(repeat('00', size::int), 'hex') "
                       "WHERE hash = (SELECT min(hash) FROM blobs)"),
              "");
  }
  EXPECT_FALSE(s.integrity_ok());
}


// ---- damaged and crafted files -------------------------------------------------------------------
// A store file may be damaged (a failing disk, a torn copy) or crafted by someone else. Each class
// the fuzz target tests/fuzz/fuzz_store.cpp covers has a test here on a real store: the file is
// refused with the one message that names the fix, or read correctly, and refusing leaves it as it was.

const char* kDamaged = "the map store is damaged";
const char* kFix = "restore it from a backup, or rebuild it with pl-map";

// One map: version 1 published with 30 tiles and places, version 2 staged from it; a token; a log
// entry; a change report.
void make_sample_store(const std::string& path) {
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
  s.add_token("secret-read", Role::Read, "");
  s.log_upload("town", 1, "publish", "", "test");
  s.put_report("town", 1, "car-1", "drive-1", 100, 200, fake_draco(98, 1500), "token 1");
}

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

void expect_damaged(const std::string& msg, const std::string& path, const std::string& detail) {
  EXPECT_TRUE(contains(msg, path)) << msg;
  EXPECT_TRUE(contains(msg, kDamaged)) << msg;
  EXPECT_TRUE(contains(msg, kFix)) << msg;
  EXPECT_TRUE(contains(msg, detail)) << msg;
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

// ---- PostgreSQL only ------------------------------------------------------------------------------
// What only a PostgreSQL database has: its own migrations table, other applications' tables in the
// same database, URLs with passwords, SQL edits through a second connection.

class PgStoreTest : public ::testing::Test {
 protected:
  void SetUp() override {
    try {
      url = pl::test::PgCluster::get().new_database();
    } catch (const std::exception& e) {
      FAIL() << e.what();  // never skipped: the message says to install PostgreSQL
    }
  }
  std::int64_t objects() const {
    return pl::test::pg_scalar(url, "SELECT count(*) FROM pg_class WHERE relnamespace = 'public'::regnamespace");
  }
  std::string url;
};

TEST_F(PgStoreTest, RefusesANewerSchema) {
  { Store s = Store::open(url); }
  const std::string future = std::to_string(Store::latest_schema_version() + 1);
  ASSERT_EQ(pl::test::pg_exec(url, "INSERT INTO schema_migrations (number, name) VALUES (" + future + ", 'future')"), "");
  std::string msg = error_of([&] { Store::open(url); });
  EXPECT_TRUE(contains(msg, url)) << msg;
  EXPECT_TRUE(contains(msg, "newer")) << msg;
  EXPECT_TRUE(contains(msg, "upgrade")) << msg;
  EXPECT_EQ(pl::test::pg_scalar(url, "SELECT max(number) FROM schema_migrations"), Store::latest_schema_version() + 1);
}

TEST_F(PgStoreTest, RefusesAnotherApplicationsDatabase) {
  ASSERT_EQ(pl::test::pg_exec(url, "CREATE TABLE notes (id integer PRIMARY KEY, body text)"), "");
  const std::int64_t before = objects();
  for (bool create : {false, true}) {
    std::string msg = error_of([&] { Store::open(url, create); });
    EXPECT_TRUE(contains(msg, url)) << msg;
    EXPECT_TRUE(contains(msg, "not a map store")) << msg;
  }
  // Someone else's schema_migrations (a web framework's) is not the store's either.
  EXPECT_EQ(objects(), before);  // nothing written
  ASSERT_EQ(pl::test::pg_exec(url, "DROP TABLE notes; CREATE TABLE schema_migrations (version text)"), "");
  EXPECT_TRUE(contains(error_of([&] { Store::open(url, true); }), "not a map store"));
  EXPECT_EQ(objects(), 1);
}

TEST_F(PgStoreTest, EmptyDatabaseIsNotAStoreWithoutCreate) {
  std::string msg = error_of([&] { Store::open(url, false); });
  EXPECT_TRUE(contains(msg, url)) << msg;
  EXPECT_TRUE(contains(msg, "empty")) << msg;
  EXPECT_TRUE(contains(msg, "pl-map")) << msg;
  EXPECT_EQ(objects(), 0);
  Store s = Store::open(url, true);  // pl-map makes a store of it
  EXPECT_EQ(s.schema_version(), Store::latest_schema_version());
}

TEST_F(PgStoreTest, MissingDatabaseOrServerIsAnErrorNamingIt) {
  const std::string missing = pl::test::PgCluster::get().url("no_such_database");
  std::string msg = error_of([&] { Store::open(missing, false); });
  EXPECT_TRUE(contains(msg, missing + ": cannot connect")) << msg;
  EXPECT_TRUE(contains(msg, "no_such_database")) << msg;
  const std::string no_server = "postgresql://nobody@127.0.0.1:1/db";
  msg = error_of([&] { Store::open(no_server, true); });
  EXPECT_TRUE(contains(msg, no_server + ": cannot connect")) << msg;
}

TEST_F(PgStoreTest, PasswordsNeverShowInMessages) {
  // The cluster trusts local connections, so a password in the URL is accepted and ignored.
  const std::string secret = "hunter2-5ecret";
  std::string with_password = url;
  with_password.replace(with_password.find('@'), 1, ":" + secret + "@");
  Store s = Store::open(with_password);
  EXPECT_FALSE(contains(s.path(), secret)) << s.path();
  EXPECT_TRUE(contains(s.path(), ":***@")) << s.path();
  std::string msg = error_of([&] { s.create_version("ghost", std::nullopt, ""); });
  EXPECT_FALSE(contains(msg, secret)) << msg;
  EXPECT_TRUE(contains(msg, "unknown map ghost")) << msg;
  msg = error_of([&] { Store::open(with_password + "_missing", false); });
  EXPECT_FALSE(contains(msg, secret)) << msg;
  const std::string in_query = url + "?sslmode=disable&password=" + secret;
  Store q = Store::open(in_query);
  EXPECT_FALSE(contains(q.path(), secret)) << q.path();
  EXPECT_TRUE(contains(q.path(), "password=***")) << q.path();
}

TEST_F(PgStoreTest, BytesEditedInTheDatabaseAreRefusedAsDamaged) {
  make_sample_store(url);
  Store s = Store::open(url, false);
  EXPECT_TRUE(s.integrity_ok());
  const std::string hash = s.list_tiles("town", 1).front().hash;
  // Same length (the CHECK on size holds), other bytes: only the hash can tell.
  ASSERT_EQ(pl::test::pg_exec(url, "UPDATE blobs SET bytes = decode(repeat('00', size::int), 'hex') WHERE hash = '" +
                                       hash + "'"),
            "");
  expect_damaged(error_of([&] { s.blob(hash); }), url, "of blob " + hash + " do not match its content hash");
  EXPECT_FALSE(s.integrity_ok());
  EXPECT_TRUE(s.find_tile("town", 1, {0, 0}));  // the rows are still read
  // Places of the staged version 2 (the triggers keep those of version 1, published, read-only).
  ASSERT_EQ(pl::test::pg_exec(url, "UPDATE places SET bytes = decode(repeat('00', size::int), 'hex') WHERE version = 2"),
            "");
  expect_damaged(error_of([&] { s.places("town", 2); }), url,
                 "places.bytes of map town version 2 do not match their content hash");
  EXPECT_TRUE(s.places("town", 1));
  EXPECT_TRUE(contains(pl::test::pg_exec(url, "UPDATE places SET bytes = bytes WHERE version = 1"), "staged"));
}

TEST_F(PgStoreTest, ACurrentVersionThatIsNotPublishedIsDamage) {
  make_sample_store(url);
  // Only with the triggers off (a restore gone wrong, a hand edit).
  ASSERT_EQ(pl::test::pg_exec(url, "ALTER TABLE maps DISABLE TRIGGER USER; UPDATE maps SET current_version = 2; "
                                   "ALTER TABLE maps ENABLE TRIGGER USER"),
            "");
  Store s = Store::open(url, false);
  expect_damaged(error_of([&] { s.find_map("town"); }), url, "current_version 2 is not a published");
  EXPECT_FALSE(s.integrity_ok());
}

TEST_F(PgStoreTest, UploadLogCannotBeUpdatedDeletedOrTruncated) {
  {
    Store s = Store::open(url);
    s.log_upload("city", 1, "upload", "", "ops");
  }
  for (const char* sql : {"UPDATE upload_log SET who = 'mallory'", "DELETE FROM upload_log", "TRUNCATE upload_log"}) {
    std::string msg = pl::test::pg_exec(url, sql);
    EXPECT_TRUE(contains(msg, "append-only")) << sql << ": " << msg;
  }
  EXPECT_EQ(pl::test::pg_scalar(url, "SELECT count(*) FROM upload_log WHERE who = 'ops'"), 1);
}

TEST_F(PgStoreTest, MigratesASchema1DatabaseOnOpen) {
  // A store as a build of schema version 1 left it: migration pg/001 alone, then a map with one
  // published version and one tile, written with SQL directly.
  const std::string schema_1 = pl::test::read_file(std::string(PL_SOURCE_DIR) + "/schema/pg/001_initial.sql");
  ASSERT_NE(schema_1.find("CREATE TABLE tiles"), std::string::npos);
  const std::string hash = pl::store::content_hash("abc");
  ASSERT_EQ(pl::test::pg_exec(url, "BEGIN; " + schema_1 +
                                       "\nINSERT INTO schema_migrations (number, name) VALUES (1, '001_initial.sql'); "
                                       "COMMIT;"),
            "");
  ASSERT_EQ(pl::test::pg_exec(url,
                              "INSERT INTO maps (name, origin_lat, origin_lon, origin_alt, tile_size, voxel_size) "
                              "VALUES ('old', 48.1, 11.5, 519, 10, 0.2); "
                              "INSERT INTO versions (map_id, number, note) VALUES (1, 1, 'made at schema 1'); "
                              "INSERT INTO blobs (hash, bytes, size) VALUES ('" + hash + "', 'abc'::bytea, 3); "
                              "INSERT INTO tiles (map_id, version, tx, ty, hash, points, bytes, min_x, min_y, min_z, "
                              "max_x, max_y, max_z) VALUES (1, 1, 0, 0, '" + hash + "', 5, 3, 1, 1, 0, 9, 9, 1); "
                              "UPDATE versions SET state = 'published' WHERE number = 1; "
                              "UPDATE maps SET current_version = 1;"),
            "");
  ASSERT_EQ(pl::test::pg_scalar(url, "SELECT count(*) FROM pg_tables WHERE tablename = 'places'"), 0);
  {
    Store s = Store::open(url, /*create=*/false);
    EXPECT_EQ(s.schema_version(), Store::latest_schema_version());
    EXPECT_EQ(s.find_map("old")->current, 1);
    EXPECT_EQ(s.find_version("old", 1)->note, "made at schema 1");
    EXPECT_EQ(s.blob(hash), "abc");
    EXPECT_FALSE(s.places("old", 1));
    EXPECT_TRUE(s.integrity_ok());
    EXPECT_EQ(s.create_version("old", std::nullopt, "").tiles, 1);
    s.put_places("old", 2, "descriptors");
    EXPECT_EQ(s.places("old", 2), "descriptors");
  }
  EXPECT_EQ(pl::test::pg_scalar(url, "SELECT max(number) FROM schema_migrations"), Store::latest_schema_version());
  Store again = Store::open(url, false);
  EXPECT_EQ(again.places("old", 2), "descriptors");
}

TEST_F(PgStoreTest, MigratesASchema4DatabaseKeepingItsTokens) {
  // A store as a build of schema version 4 left it: tokens of each role it knew (one revoked).
  const std::string read = "rd-token", upload = "up-token", admin = "ad-token", car = "car-token";
  ASSERT_EQ(pl::test::pg_exec(url, "BEGIN; " + migrations_up_to("schema/pg", 4) +
                                       "INSERT INTO schema_migrations (number, name) VALUES (1, '001_initial.sql'), "
                                       "(2, '002_places.sql'), (3, '003_token_revocation.sql'), (4, '004_signatures.sql'); "
                                       "COMMIT;"),
            "");
  ASSERT_EQ(pl::test::pg_exec(url,
                              "INSERT INTO tokens (hash, role, note, created, revoked) VALUES "
                              "('" + pl::store::content_hash(read) + "', 'read', 'viewer', '2024-01-02T03:04:05.678Z', NULL), "
                              "('" + pl::store::content_hash(upload) + "', 'upload', 'survey car', '2024-02-02T03:04:05.678Z', "
                              "'2024-03-01T00:00:00.000Z'), "
                              "('" + pl::store::content_hash(admin) + "', 'admin', 'ops', '2024-04-02T03:04:05.678Z', NULL); "
                              "INSERT INTO maps (name, origin_lat, origin_lon, origin_alt, tile_size, voxel_size) "
                              "VALUES ('old', 48.1, 11.5, 519, 10, 0.2); "
                              "INSERT INTO versions (map_id, number, note) VALUES (1, 1, 'made at schema 4');"),
            "");
  EXPECT_NE(pl::test::pg_exec(url, "INSERT INTO tokens (hash, role) VALUES ('" + pl::store::content_hash(car) + "', 'report')"),
            "");  // schema 4 knows no report role
  {
    Store s = Store::open(url, /*create=*/false);
    EXPECT_EQ(s.schema_version(), Store::latest_schema_version());
    const auto tokens = s.list_tokens();
    ASSERT_EQ(tokens.size(), 3u);
    EXPECT_EQ(tokens[0].role, Role::Read);
    EXPECT_EQ(tokens[0].created, "2024-01-02T03:04:05.678Z");
    EXPECT_EQ(tokens[1].role, Role::Upload);
    EXPECT_EQ(tokens[1].revoked, "2024-03-01T00:00:00.000Z");
    EXPECT_EQ(tokens[2].role, Role::Admin);
    EXPECT_EQ(s.check_token(read), Role::Read);
    EXPECT_FALSE(s.check_token(upload));
    EXPECT_EQ(s.check_token(admin), Role::Admin);
    const std::int64_t id = s.add_token(car, Role::Report, "car 7");
    EXPECT_GT(id, tokens[2].id);
    EXPECT_EQ(s.check_token(car), Role::Report);
    EXPECT_EQ(s.put_report("old", 1, "car-7", "d-1", 0, 1, "{}", "token " + std::to_string(id)), Store::ReportPut::Stored);
    EXPECT_TRUE(s.integrity_ok());
  }
  EXPECT_EQ(pl::test::pg_scalar(url, "SELECT max(number) FROM schema_migrations"), Store::latest_schema_version());
  Store again = Store::open(url, false);
  EXPECT_EQ(again.list_tokens().size(), 4u);
  EXPECT_EQ(again.list_reports("old").size(), 1u);
}

TEST_F(PgStoreTest, ChangeReportsCannotBeUpdated) {
  {
    Store s = Store::open(url);
    s.create_map("m", kOrigin, 10, 0.2);
    s.create_version("m", std::nullopt, "");
    s.put_report("m", 1, "car", "d", 0, 1, "{}", "t");
  }
  for (const char* sql : {"UPDATE change_reports SET who = 'mallory'", "UPDATE change_reports SET body = body"}) {
    std::string msg = pl::test::pg_exec(url, sql);
    EXPECT_TRUE(contains(msg, "change reports never change")) << sql << ": " << msg;
  }
  EXPECT_EQ(pl::test::pg_scalar(url, "SELECT count(*) FROM change_reports WHERE who = 't'"), 1);
}

TEST_F(PgStoreTest, FreeTextMustBeUtf8WithoutNul) {
  Store s = Store::open(url);
  s.create_map("m", kOrigin, 10, 0.2);
  for (const std::string& bad : {std::string("caf\xe9"), std::string("a\0b", 3), std::string("\xed\xa0\x80")}) {
    std::string msg = error_of([&] { s.create_version("m", std::nullopt, bad); });
    EXPECT_TRUE(contains(msg, "UTF-8")) << msg;
    EXPECT_TRUE(contains(error_of([&] { s.log_upload("m", 1, "a", bad, ""); }), "UTF-8"));
    EXPECT_TRUE(s.upload_log(bad).empty());
  }
  EXPECT_TRUE(s.list_versions("m").empty());
  // UTF-8 itself goes in and out byte for byte.
  const std::string text = "Stra\xc3\x9f" "e \xe2\x86\x92 \xf0\x9f\x97\xba 'quoted' \\x00";
  EXPECT_EQ(s.create_version("m", std::nullopt, text).note, text);
  s.log_upload("m", 1, "note", text, text);
  EXPECT_EQ(s.upload_log("m").at(0).detail, text);
}

}  // namespace
