// The tile client's retry schedule (client/src/backoff.hpp): delays double from the minimum up to the
// maximum, each within +-20 % jitter, a success resets them. Times are passed in: nothing waits.
#include <gtest/gtest.h>

#include <chrono>
#include <set>

#include "backoff.hpp"

using pl::client::Backoff;
using Clock = Backoff::Clock;

namespace {

double seconds_between(Clock::time_point a, Clock::time_point b) { return std::chrono::duration<double>(b - a).count(); }

}  // namespace

TEST(Backoff, DoublesUpToTheMaximumWithJitterAndResetsOnSuccess) {
  Backoff b(1.0, 4.0, 42);
  const Clock::time_point t0 = Clock::time_point{} + std::chrono::hours(1);
  EXPECT_TRUE(b.allowed(t0));
  EXPECT_FALSE(b.backing_off());
  const double nominal[] = {1, 2, 4, 4, 4};
  Clock::time_point t = t0;
  for (double n : nominal) {
    double d = b.failed(t);
    EXPECT_GE(d, 0.8 * n);
    EXPECT_LE(d, 1.2 * n);
    EXPECT_TRUE(b.backing_off());
    EXPECT_NEAR(seconds_between(t, b.until()), d, 1e-6);
    EXPECT_FALSE(b.allowed(t));
    EXPECT_FALSE(b.allowed(b.until() - std::chrono::milliseconds(1)));
    EXPECT_TRUE(b.allowed(b.until()));
    t = b.until();
  }
  b.succeeded();
  EXPECT_FALSE(b.backing_off());
  EXPECT_TRUE(b.allowed(t0));
  double d = b.failed(t);  // from the minimum again
  EXPECT_GE(d, 0.8);
  EXPECT_LE(d, 1.2);
}

TEST(Backoff, JitterSpreadsAFleet) {
  std::set<double> first;
  for (unsigned seed = 1; seed <= 10; ++seed) first.insert(Backoff(1.0, 4.0, seed).failed(Clock::time_point{}));
  EXPECT_GT(first.size(), 5u);  // vehicles that failed together do not retry together
}
