// The map store's places (a version's place descriptors): put, read, replaced and deleted while the
// version is staged, copied to a child version.
#include <gtest/gtest.h>

#include <cstdint>
#include <optional>
#include <string>

#include "pl/schema/api_rules.hpp"
#include "pl/schema/store.hpp"
#include "error_of.hpp"
#include "store_fixture.hpp"
#include "store_test_util.hpp"

namespace {

using pl::store::Store;
using pl::test::contains;
using pl::test::error_of;
using pl::test::fake_draco;
using pl::test::kOrigin;
using pl::test::put_cell;
using pl::test::StoreTest;

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

}  // namespace
