#include <gtest/gtest.h>

#include <atomic>
#include <stdexcept>
#include <string>
#include <thread>

#include "pl/common/read_ahead.hpp"

TEST(ReadAhead, GivesEveryItemInOrderMadeOffTheCallersThread) {
  const std::thread::id caller = std::this_thread::get_id();
  std::atomic<int> elsewhere{0};
  pl::ReadAhead<std::string> items(50, [&](std::size_t i) {
    if (std::this_thread::get_id() != caller) ++elsewhere;
    return "item " + std::to_string(i);
  });
  for (std::size_t i = 0; i < 50; ++i) {
    ASSERT_FALSE(items.done());
    EXPECT_EQ(items.next(), "item " + std::to_string(i));
  }
  EXPECT_TRUE(items.done());
  EXPECT_EQ(elsewhere.load(), 50);
}

TEST(ReadAhead, AFailedItemRethrowsInTheCallerAndNothingIsLeftRunning) {
  std::atomic<int> made{0};
  {
    pl::ReadAhead<int> items(10, [&](std::size_t i) {
      ++made;
      if (i == 3) throw std::runtime_error("scan 3 is truncated");
      return static_cast<int>(i);
    });
    for (int i = 0; i < 3; ++i) EXPECT_EQ(items.next(), i);
    try {
      items.next();
      FAIL() << "no exception";
    } catch (const std::runtime_error& e) {
      EXPECT_STREQ(e.what(), "scan 3 is truncated");
    }
  }
  EXPECT_EQ(made.load(), 4);  // one ahead at most: nothing made past the failure
}

TEST(ReadAhead, NoItemsMakesNothing) {
  bool called = false;
  pl::ReadAhead<int> items(0, [&](std::size_t) {
    called = true;
    return 0;
  });
  EXPECT_TRUE(items.done());
  EXPECT_FALSE(called);
}
