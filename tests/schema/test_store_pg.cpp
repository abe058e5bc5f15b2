// What only a PostgreSQL store has: its own migrations table, other applications' tables in the same
// database, URLs with passwords, SQL edits through a second connection.
#include <gtest/gtest.h>

#include <cstdint>
#include <exception>
#include <optional>
#include <string>

#include "pl/schema/store.hpp"
#include "error_of.hpp"
#include "pg_cluster.hpp"
#include "store_fixture.hpp"
#include "test_util.hpp"

namespace {

using pl::store::Role;
using pl::store::Store;
using pl::test::contains;
using pl::test::error_of;
using pl::test::expect_damaged;
using pl::test::kOrigin;
using pl::test::make_sample_store;
using pl::test::migrations_up_to;

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
