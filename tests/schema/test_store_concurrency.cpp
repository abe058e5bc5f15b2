// Several connections to one store (threads, processes), and crashes in the middle of a write, on
// both engines (store_backends.hpp): a SQLite file and a PostgreSQL database.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <exception>
#include <set>
#include <filesystem>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "pl/common/error.hpp"
#include "pl/schema/store.hpp"
#include "store_backends.hpp"
#include "store_test_util.hpp"
#include "test_util.hpp"

namespace {

using pl::store::Store;
using pl::store::VersionState;
using pl::test::Backend;
using pl::test::put_cell;

const pl::GeoPoint kOrigin{48.137, 11.575, 519.0};

using StoreConcurrencyTest = pl::test::BackendTest;

// Runs f(0) .. f(n - 1) on n threads released together (each waits for all to have started);
// returns each one's exception message ("" when it threw none).
template <class F>
std::vector<std::string> all_at_once(int n, F f) {
  std::vector<std::string> errors(static_cast<std::size_t>(n));
  std::atomic<int> ready{0};
  std::vector<std::thread> threads;
  for (int t = 0; t < n; ++t)
    threads.emplace_back([&, t] {
      const auto i = static_cast<std::size_t>(t);
      ready.fetch_add(1);
      while (ready.load() < n) std::this_thread::yield();
      try {
        f(i);
      } catch (const std::exception& e) {
        errors[i] = e.what();
      }
    });
  for (auto& th : threads) th.join();
  return errors;
}
PL_BOTH_BACKENDS(StoreConcurrencyTest);

TEST_P(StoreConcurrencyTest, TwoConnectionsSeeEachOthersCommittedWrites) {
  Store a = Store::open(path);
  Store b = Store::open(path);
  a.create_map("m", kOrigin, 10, 0.2);
  ASSERT_TRUE(b.find_map("m"));
  b.create_version("m", std::nullopt, "from b");
  EXPECT_EQ(a.find_version("m", 1)->note, "from b");
  put_cell(a, "m", 1, 0, 0, 1);
  EXPECT_TRUE(b.find_tile("m", 1, {0, 0}));

  // An open write transaction on one connection is invisible to the other until it commits,
  // and the reader is not blocked meanwhile (SQLite: WAL; PostgreSQL: MVCC).
  {
    Store::Transaction tx(a);
    put_cell(a, "m", 1, 1, 0, 2);
    a.publish("m", 1);
    EXPECT_FALSE(b.find_tile("m", 1, {1, 0}));
    EXPECT_FALSE(b.find_map("m")->current);
    EXPECT_EQ(b.find_version("m", 1)->state, VersionState::Staged);
    tx.commit();
  }
  EXPECT_TRUE(b.find_tile("m", 1, {1, 0}));
  EXPECT_EQ(b.find_map("m")->current, 1);
  EXPECT_THROW(b.rollback("m"), pl::Error);  // version 1 was the first publish
  EXPECT_EQ(a.find_map("m")->current, 1);
}

TEST_P(StoreConcurrencyTest, ThreadsWriteConcurrently) {
  { Store s = Store::open(path); }
  constexpr int kThreads = 4, kTiles = 40;
  std::atomic<int> failures{0};
  std::vector<std::string> errors(kThreads);
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t) {
    threads.emplace_back([&, t] {
      try {
        Store s = Store::open(path);  // one connection per thread
        std::string map = "map" + std::to_string(t);
        s.create_map(map, kOrigin, 10, 0.2);
        s.create_version(map, std::nullopt, "");
        for (int i = 0; i < kTiles; ++i) {
          put_cell(s, map, 1, i, t, static_cast<std::uint32_t>(i % 7));  // blobs shared across threads
          if (i % 10 == 0) s.list_maps();
        }
        s.publish(map, 1);
        s.log_upload(map, 1, "publish", "", "thread");
      } catch (const std::exception& e) {
        errors[static_cast<std::size_t>(t)] = e.what();
        ++failures;
      }
    });
  }
  for (auto& th : threads) th.join();
  for (const auto& e : errors) EXPECT_EQ(e, "");
  ASSERT_EQ(failures.load(), 0);
  Store s = Store::open(path);
  EXPECT_EQ(s.list_maps().size(), static_cast<std::size_t>(kThreads));
  for (int t = 0; t < kThreads; ++t) {
    std::string map = "map" + std::to_string(t);
    EXPECT_EQ(s.find_map(map)->current, 1);
    EXPECT_EQ(s.list_tiles(map, 1).size(), static_cast<std::size_t>(kTiles));
  }
  EXPECT_EQ(count("blobs"), 7);
  EXPECT_TRUE(s.integrity_ok());
}

TEST_P(StoreConcurrencyTest, ManyConnectionsOpenAFreshFileAtOnce) {
  constexpr int kThreads = 6;
  std::vector<std::string> errors(kThreads);
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t) {
    threads.emplace_back([&, t] {
      try {
        Store s = Store::open(path);
        s.log_upload("m", std::nullopt, "hello", std::to_string(t), "");
      } catch (const std::exception& e) {
        errors[static_cast<std::size_t>(t)] = e.what();
      }
    });
  }
  for (auto& th : threads) th.join();
  for (const auto& e : errors) EXPECT_EQ(e, "");
  Store s = Store::open(path);
  EXPECT_EQ(s.schema_version(), Store::latest_schema_version());
  EXPECT_EQ(s.upload_log("m").size(), static_cast<std::size_t>(kThreads));
}

TEST_P(StoreConcurrencyTest, ConcurrentCreateVersionsGetDistinctNumbers) {
  {
    Store s = Store::open(path);
    s.create_map("m", kOrigin, 10, 0.2);
    s.create_version("m", std::nullopt, "base");
    for (int i = 0; i < 5; ++i) put_cell(s, "m", 1, i, 0, static_cast<std::uint32_t>(i));
    s.publish("m", 1);
  }
  constexpr int kThreads = 4, kEach = 6;
  std::vector<std::vector<std::int64_t>> numbers(kThreads);
  std::vector<std::string> errors(kThreads);
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t) {
    threads.emplace_back([&, t] {
      try {
        Store s = Store::open(path);  // a connection of its own
        for (int i = 0; i < kEach; ++i) {
          auto v = s.create_version("m", std::nullopt, "thread " + std::to_string(t));
          numbers[static_cast<std::size_t>(t)].push_back(v.number);
          EXPECT_EQ(v.tiles, 5);  // each a whole copy of the current version
        }
      } catch (const std::exception& e) {
        errors[static_cast<std::size_t>(t)] = e.what();
      }
    });
  }
  for (auto& th : threads) th.join();
  for (const auto& e : errors) EXPECT_EQ(e, "");
  std::set<std::int64_t> all;
  for (const auto& n : numbers) all.insert(n.begin(), n.end());
  EXPECT_EQ(all.size(), static_cast<std::size_t>(kThreads * kEach));  // none handed out twice
  EXPECT_EQ(*all.begin(), 2);
  EXPECT_EQ(*all.rbegin(), 1 + kThreads * kEach);  // and none skipped
  Store s = Store::open(path);
  EXPECT_EQ(s.list_versions("m").size(), static_cast<std::size_t>(1 + kThreads * kEach));
  EXPECT_EQ(count("tiles"), 5 * (1 + kThreads * kEach));
  EXPECT_TRUE(s.integrity_ok());
}

// Uploaders race to publish versions opened from the same current one: in each round exactly one
// conditional publish wins (whichever connection gets the map's write lock first), the others
// change nothing and their versions stay staged; an unconditional publish is not held back.
TEST_P(StoreConcurrencyTest, ConditionalPublishesOfOneMapHaveExactlyOneWinnerARound) {
  {
    Store s = Store::open(path);
    s.create_map("m", kOrigin, 10, 0.2);
    s.create_version("m", std::nullopt, "base");
    put_cell(s, "m", 1, 0, 0, 1);
    // Nothing is current yet: a condition naming a version fails, "none" holds.
    EXPECT_FALSE(s.publish_if_current("m", 1, 7));
    EXPECT_EQ(s.find_version("m", 1)->state, VersionState::Staged);
    EXPECT_TRUE(s.publish_if_current("m", 1, std::nullopt));
  }
  constexpr int kThreads = 4, kRounds = 5;
  std::vector<Store> conns;
  for (int t = 0; t < kThreads; ++t) conns.push_back(Store::open(path));
  for (int round = 0; round < kRounds; ++round) {
    const std::int64_t current = *conns[0].find_map("m")->current;
    std::vector<std::int64_t> mine(kThreads);
    for (int t = 0; t < kThreads; ++t) {
      auto v = conns[static_cast<std::size_t>(t)].create_version("m", std::nullopt, "");
      ASSERT_EQ(v.parent, current);
      put_cell(conns[static_cast<std::size_t>(t)], "m", v.number, t + 1, round, static_cast<std::uint32_t>(10 * round + t));
      mine[static_cast<std::size_t>(t)] = v.number;
    }
    std::vector<int> won(kThreads, -1);
    for (const auto& e : all_at_once(kThreads, [&](std::size_t i) { won[i] = conns[i].publish_if_current("m", mine[i], current) ? 1 : 0; }))
      EXPECT_EQ(e, "");
    ASSERT_EQ(std::count(won.begin(), won.end(), 1), 1) << "round " << round;
    const auto winner = static_cast<std::size_t>(std::find(won.begin(), won.end(), 1) - won.begin());
    Store s = Store::open(path);
    EXPECT_EQ(s.find_map("m")->current, mine[winner]);
    for (std::size_t t = 0; t < mine.size(); ++t)
      EXPECT_EQ(s.find_version("m", mine[t])->state, t == winner ? VersionState::Published : VersionState::Staged);
    EXPECT_EQ(s.find_version("m", current)->state, VersionState::Retired);
  }
  // A loser's version is published by the unconditional call (pl-map publish: the operator's choice).
  Store s = Store::open(path);
  const auto staged = s.list_versions("m");
  const auto loser = std::find_if(staged.begin(), staged.end(), [](const auto& v) { return v.state == VersionState::Staged; });
  ASSERT_NE(loser, staged.end());
  s.publish("m", loser->number);
  EXPECT_EQ(s.find_map("m")->current, loser->number);
  EXPECT_TRUE(s.integrity_ok());
}

// Vehicles that send one drive's report twice at once (a retry racing the first send, two server
// replicas): it is stored once. Same bytes: one Stored, the others AlreadyStored; other bytes: one
// Stored, the others Conflict, and the one stored is the winner's.
TEST_P(StoreConcurrencyTest, ConcurrentPutsOfOneDriveStoreItOnce) {
  {
    Store s = Store::open(path);
    s.create_map("m", kOrigin, 10, 0.2);
    s.create_version("m", std::nullopt, "");
    s.publish("m", 1);
  }
  constexpr int kThreads = 4, kRounds = 8;
  using Put = Store::ReportPut;
  std::vector<Store> conns;
  for (int t = 0; t < kThreads; ++t) conns.push_back(Store::open(path));
  for (int round = 0; round < kRounds; ++round) {
    const bool same = round % 2 == 0;
    const std::string drive = "drive-" + std::to_string(round);
    auto body = [&](int t) { return "{\"round\":" + std::to_string(round) + ",\"from\":" + std::to_string(same ? 0 : t) + "}"; };
    std::vector<Put> got(kThreads);
    for (const auto& e : all_at_once(kThreads, [&](std::size_t i) {
           got[i] = conns[i].put_report("m", 1, "car", drive, 0, 1, body(static_cast<int>(i)), "token " + std::to_string(i));
         }))
      ASSERT_EQ(e, "");
    ASSERT_EQ(std::count(got.begin(), got.end(), Put::Stored), 1) << "round " << round;
    EXPECT_EQ(std::count(got.begin(), got.end(), same ? Put::AlreadyStored : Put::Conflict), kThreads - 1) << "round " << round;
    const int winner = static_cast<int>(std::find(got.begin(), got.end(), Put::Stored) - got.begin());
    const auto reports = conns[0].list_reports("m");
    ASSERT_EQ(reports.size(), static_cast<std::size_t>(round + 1));
    EXPECT_EQ(reports.back().drive, drive);
    EXPECT_EQ(reports.back().who, "token " + std::to_string(winner));
    EXPECT_EQ(conns[0].report_body("m", reports.back().id), body(winner));
  }

  // A put that waits for another's uncommitted put of the drive (PostgreSQL: on the unique key;
  // SQLite: for the write lock) finds it once it commits and is told so; when it is rolled back
  // instead, the waiting put stores its own.
  for (const bool commit : {true, false}) {
    const std::string drive = commit ? "held" : "undone";
    std::optional<Put> second;
    std::string error;
    std::atomic<bool> done{false};
    std::thread other;
    {
      Store::Transaction tx(conns[0]);
      ASSERT_EQ(conns[0].put_report("m", 1, "car", drive, 0, 1, "first", "token 0"), Put::Stored);
      other = std::thread([&] {
        try {
          second = conns[1].put_report("m", 1, "car", drive, 0, 1, "second", "token 1");
        } catch (const std::exception& e) {
          error = e.what();
        }
        done = true;
      });
      std::this_thread::sleep_for(std::chrono::milliseconds(300));
      EXPECT_FALSE(done.load());  // still waiting
      if (commit) tx.commit();
    }
    other.join();
    EXPECT_EQ(error, "");
    EXPECT_EQ(second, commit ? Put::Conflict : Put::Stored);
    EXPECT_EQ(conns[2].report_body("m", conns[2].list_reports("m").back().id), commit ? "first" : "second") << drive;
  }
  EXPECT_EQ(count("change_reports"), kRounds + 2);
}

TEST_P(StoreConcurrencyTest, WritersOfOneMapTakeTurnsWithBlobsSharedAcrossMaps) {
  // Two maps whose tiles share blobs; threads replace and delete tiles of both at once, so blobs
  // keep losing their last user in one map while the other map takes them again.
  {
    Store s = Store::open(path);
    for (const char* m : {"a", "b"}) {
      s.create_map(m, kOrigin, 10, 0.2);
      s.create_version(m, std::nullopt, "");
    }
  }
  constexpr int kThreads = 4, kRounds = 30;
  std::vector<std::string> errors(kThreads);
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t) {
    threads.emplace_back([&, t] {
      try {
        Store s = Store::open(path);
        const std::string map = t % 2 ? "a" : "b";
        for (int i = 0; i < kRounds; ++i) {
          const int key = (t / 2) * 100 + i % 3;
          put_cell(s, map, 1, key, 0, static_cast<std::uint32_t>((i + t) % 4));  // 4 contents in all
          if (i % 3 == 2) s.delete_tile(map, 1, {key, 0});
        }
      } catch (const std::exception& e) {
        errors[static_cast<std::size_t>(t)] = e.what();
      }
    });
  }
  for (auto& th : threads) th.join();
  for (const auto& e : errors) EXPECT_EQ(e, "");
  Store s = Store::open(path);
  EXPECT_TRUE(s.integrity_ok());
  // Every blob used, every tile's blob there.
  EXPECT_EQ(raw_scalar("SELECT count(*) FROM blobs WHERE hash NOT IN (SELECT hash FROM tiles)"), 0);
  for (const char* m : {"a", "b"})
    for (const auto& tile : s.list_tiles(m, 1)) EXPECT_TRUE(s.has_blob(tile.hash));
}

// ---- crashes -------------------------------------------------------------------------------------

enum class Death { Kill9, Exit0 };

// Map "m": version 1 published with 10 tiles, version 2 staged (a copy). No connection stays open.
void prepare_two_versions(const std::string& path) {
  Store s = Store::open(path);
  s.create_map("m", kOrigin, 10, 0.2);
  s.create_version("m", std::nullopt, "v1");
  for (int i = 0; i < 10; ++i) put_cell(s, "m", 1, i, 0, static_cast<std::uint32_t>(i));
  s.publish("m", 1);
  s.create_version("m", std::nullopt, "v2");
}

// In a child process: opens the store and, in one Transaction, writes many tiles into version 2
// (enough to spill uncommitted pages into the WAL), publishes it halfway, creates version 3 and
// writes as many tiles into it, then dies before committing (or after, with `commit`). Returns the
// child's wait status.
int crash_child(const std::string& path, Death death, bool commit) {
  pid_t pid = fork();
  if (pid == 0) {
    try {
      Store s = Store::open(path);
      Store::Transaction tx(s);
      for (int i = 0; i < 200; ++i) put_cell(s, "m", 2, i, 1, static_cast<std::uint32_t>(1000 + i), 16384);
      s.publish("m", 2);
      s.create_version("m", std::nullopt, "v3");  // a copy of the just published 2
      for (int i = 0; i < 200; ++i) put_cell(s, "m", 3, i, 2, static_cast<std::uint32_t>(2000 + i), 16384);
      if (commit) tx.commit();
      if (death == Death::Kill9) kill(getpid(), SIGKILL);
      _exit(0);  // no destructors: the connection is never closed, nothing is rolled back
    } catch (const std::exception& e) {
      std::fprintf(stderr, "crash child failed: %s\n", e.what());
      _exit(3);
    } catch (...) {
      _exit(4);
    }
  }
  int status = 0;
  waitpid(pid, &status, 0);
  return status;
}

void expect_killed_as_asked(int status, Death death) {
  if (death == Death::Kill9) {
    ASSERT_TRUE(WIFSIGNALED(status)) << "child exited with " << WEXITSTATUS(status);
    EXPECT_EQ(WTERMSIG(status), SIGKILL);
  } else {
    ASSERT_TRUE(WIFEXITED(status));
    EXPECT_EQ(WEXITSTATUS(status), 0);
  }
}

TEST_P(StoreConcurrencyTest, CrashBeforeCommitKeepsThePublishedVersion) {
  for (Death death : {Death::Kill9, Death::Exit0}) {
    SCOPED_TRACE(death == Death::Kill9 ? "kill -9" : "_exit(0)");
    pl::test::TempDir d;
    std::string p = pl::test::fresh_store(GetParam(), d);
    prepare_two_versions(p);
    expect_killed_as_asked(crash_child(p, death, /*commit=*/false), death);
    // SQLite: the dead writer left uncommitted pages in the WAL (6 MB of tiles overflow SQLite's 2 MB
    // page cache), which the next open must ignore. PostgreSQL: the server rolls back the
    // transaction of a connection whose client died.
    if (sqlite()) {
      EXPECT_GT(std::filesystem::file_size(p + "-wal"), 1'000'000u);
    }

    Store s = Store::open(p);
    EXPECT_TRUE(s.integrity_ok());
    EXPECT_EQ(s.find_map("m")->current, 1);
    EXPECT_EQ(s.find_version("m", 1)->state, VersionState::Published);
    EXPECT_EQ(s.find_version("m", 2)->state, VersionState::Staged);
    EXPECT_EQ(s.list_tiles("m", 2).size(), 10u);
    EXPECT_FALSE(s.find_version("m", 3));
    EXPECT_EQ(pl::test::raw_scalar(GetParam(), p, "SELECT count(*) FROM blobs"), 10);
    // And the store works on: the staged version can still be published.
    put_cell(s, "m", 2, 0, 5, 5000);
    s.publish("m", 2);
    EXPECT_EQ(s.find_map("m")->current, 2);
    EXPECT_TRUE(s.integrity_ok());
  }
}

TEST_P(StoreConcurrencyTest, CrashAfterCommitKeepsTheCommit) {
  for (Death death : {Death::Kill9, Death::Exit0}) {
    SCOPED_TRACE(death == Death::Kill9 ? "kill -9" : "_exit(0)");
    pl::test::TempDir d;
    std::string p = pl::test::fresh_store(GetParam(), d);
    prepare_two_versions(p);
    expect_killed_as_asked(crash_child(p, death, /*commit=*/true), death);

    Store s = Store::open(p);
    EXPECT_TRUE(s.integrity_ok());
    EXPECT_EQ(s.find_map("m")->current, 2);
    EXPECT_EQ(s.find_version("m", 1)->state, VersionState::Retired);
    EXPECT_EQ(s.find_version("m", 2)->state, VersionState::Published);
    EXPECT_EQ(s.list_tiles("m", 2).size(), 210u);
    EXPECT_EQ(s.find_version("m", 3)->state, VersionState::Staged);
    EXPECT_EQ(s.list_tiles("m", 3).size(), 410u);
    EXPECT_EQ(pl::test::raw_scalar(GetParam(), p, "SELECT count(*) FROM blobs"), 410);
  }
}

}  // namespace
