// The map store's transactions (commit, rollback on destruction, nested savepoints) and its
// maintenance: integrity checks and size.
#include <gtest/gtest.h>

#include <cstdint>
#include <optional>
#include <stdexcept>

#include "pl/common/error.hpp"
#include "pl/schema/store.hpp"
#include "store_fixture.hpp"
#include "store_test_util.hpp"

namespace {

using pl::store::Store;
using pl::test::kOrigin;
using pl::test::put_cell;
using pl::test::StoreTest;

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

}  // namespace
