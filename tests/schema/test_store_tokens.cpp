// The map store's tokens (stored hashed, with ids, revoked for every connection at once) and its
// append-only upload log.
#include <gtest/gtest.h>

#include <optional>
#include <string>

#include "pl/schema/store.hpp"
#include "error_of.hpp"
#include "store_fixture.hpp"

namespace {

using pl::store::Role;
using pl::store::Store;
using pl::test::contains;
using pl::test::error_of;
using pl::test::file_bytes;
using pl::test::is_utc_iso8601;
using pl::test::StoreTest;

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

}  // namespace
