// pl-map migrate as a user runs it: the built binary copies a SQLite store to PostgreSQL and back,
// prints what it copied and the digest both stores share, never prints the password of a URL, and
// refuses a destination that is not empty with exit code 2, leaving it as it was.
#include <gtest/gtest.h>

#include <string>

#include "pg_cluster.hpp"
#include "pl/common/text.hpp"
#include "pl/schema/store.hpp"
#include "pl/schema/store_copy.hpp"
#include "test_util.hpp"

namespace {

// The database's URL with a password in it (the test cluster trusts local connections: it is
// never asked for, but a user's URL would carry one).
std::string with_password(const std::string& url) {
  const std::size_t at = url.find('@');
  return url.substr(0, at) + ":s3cret-pw" + url.substr(at);
}

void fill(const std::string& path) {
  auto s = pl::store::Store::open(path);
  s.create_map("campus", {48.1, 11.5, 520.0}, 20.0, 0.2);
  s.create_version("campus", std::nullopt, "first");
  s.put_tile("campus", 1, {0, 0}, std::string(3000, 'x'), 10, 0, 0, 0, 1, 1, 1);
  s.put_tile("campus", 1, {1, 0}, std::string(2000, 'y'), 10, 20, 0, 0, 21, 1, 1);
  s.publish("campus", 1);
  s.create_version("campus", std::nullopt, "second, staged");
  s.add_token(pl::store::random_token(), pl::store::Role::Admin, "ops");
  s.log_upload("campus", 1, "publish", "", "pl-map");
}

}  // namespace

TEST(PlMapMigrate, CopiesToPostgresAndBackPrintingTheDigestAndNoPassword) {
  pl::test::TempDir dir;
  const std::string src = dir / "src.db", back = dir / "back.db";
  fill(src);
  std::string url;
  try {
    url = with_password(pl::test::PgCluster::get().new_database());
  } catch (const std::exception& e) {
    FAIL() << e.what();
  }
  const std::string digest = pl::store::store_digest(src);

  const auto to_pg = pl::test::run(pl::test::tool("pl-map") + " migrate --from " + src + " --to '" + url + "'");
  ASSERT_EQ(to_pg.exit_code, 0) << to_pg.output;
  EXPECT_EQ(to_pg.output.find("s3cret-pw"), std::string::npos) << to_pg.output;
  EXPECT_NE(to_pg.output.find(":***@"), std::string::npos) << to_pg.output;
  EXPECT_NE(to_pg.output.find("1 maps, 2 versions, 4 tiles, 2 blobs"), std::string::npos) << to_pg.output;
  EXPECT_NE(to_pg.output.find("1 tokens, 1 upload log entries"), std::string::npos) << to_pg.output;
  EXPECT_NE(to_pg.output.find("content digest " + digest + ": the same on both"), std::string::npos) << to_pg.output;
  // Not a terminal: no progress bar.
  EXPECT_EQ(to_pg.output.find('\r'), std::string::npos);

  const auto to_back = pl::test::run(pl::test::tool("pl-map") + " migrate --from '" + url + "' --to " + back);
  ASSERT_EQ(to_back.exit_code, 0) << to_back.output;
  EXPECT_EQ(to_back.output.find("s3cret-pw"), std::string::npos) << to_back.output;
  EXPECT_EQ(pl::store::store_digest(back), digest);

  // Into a store that is not empty: refused, named, unchanged.
  const auto again = pl::test::run(pl::test::tool("pl-map") + " migrate --from " + src + " --to '" + url + "'");
  EXPECT_EQ(again.exit_code, 2) << again.output;
  EXPECT_NE(again.output.find("pl-map: error: "), std::string::npos) << again.output;
  EXPECT_NE(again.output.find("the map store is not empty (it holds 1 map"), std::string::npos) << again.output;
  EXPECT_EQ(again.output.find("s3cret-pw"), std::string::npos) << again.output;
  EXPECT_EQ(pl::store::store_digest(url), digest);

  // A source that does not exist: exit 2 before anything is made.
  const auto missing = pl::test::run(pl::test::tool("pl-map") + " migrate --from " + (dir / "none.db") + " --to " + (dir / "new.db"));
  EXPECT_EQ(missing.exit_code, 2) << missing.output;
  EXPECT_NE(missing.output.find("none.db: no such map store"), std::string::npos) << missing.output;
  EXPECT_FALSE(pl::file_exists(dir / "new.db"));
}

// pl-map check: a sound store prints its content digest (the one migrate prints) and exits 0; a
// store whose blob bytes changed on disk is reported damaged with exit 1, naming the fix.
TEST(PlMapCheck, SoundStorePrintsItsDigestDamagedOneFails) {
  pl::test::TempDir dir;
  const std::string db = dir / "maps.db";
  fill(db);
  const auto good = pl::test::run(pl::test::tool("pl-map") + " check --db " + db);
  ASSERT_EQ(good.exit_code, 0) << good.output;
  EXPECT_NE(good.output.find("1 maps, 2 versions, sound"), std::string::npos) << good.output;
  EXPECT_NE(good.output.find("content digest " + pl::store::store_digest(db)), std::string::npos) << good.output;
  // One blob's bytes changed behind the store's back (same length: only its hash tells).
  ASSERT_EQ(pl::test::run("sqlite3 " + db + " \"UPDATE blobs SET bytes = CAST(replace(CAST(bytes AS TEXT), 'x', 'z') AS BLOB)"
                          " WHERE length(bytes) = 3000\"").exit_code, 0);
  const auto bad = pl::test::run(pl::test::tool("pl-map") + " check --db " + db);
  EXPECT_EQ(bad.exit_code, 1) << bad.output;
  EXPECT_NE(bad.output.find("DAMAGED: restore it from a backup"), std::string::npos) << bad.output;
  EXPECT_EQ(bad.output.find("content digest"), std::string::npos) << bad.output;
}
