#include "pl/eval/stats.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "pl/common/error.hpp"

namespace pl::eval {
namespace {

TEST(EvalStats, SummaryOfOneToFour) {
  const Summary s = summarize({3.0, 1.0, 4.0, 2.0});
  EXPECT_EQ(s.count, 4u);
  EXPECT_DOUBLE_EQ(s.mean, 2.5);
  EXPECT_DOUBLE_EQ(s.median, 2.5);
  EXPECT_DOUBLE_EQ(s.rmse, std::sqrt(7.5));
  EXPECT_DOUBLE_EQ(s.std, std::sqrt(1.25));
  EXPECT_DOUBLE_EQ(s.min, 1.0);
  EXPECT_DOUBLE_EQ(s.max, 4.0);
}

TEST(EvalStats, MedianOfOddCountIsTheMiddleValue) {
  EXPECT_DOUBLE_EQ(summarize({5.0, 1.0, 3.0}).median, 3.0);
  EXPECT_DOUBLE_EQ(summarize({7.0}).median, 7.0);
  EXPECT_DOUBLE_EQ(summarize({7.0}).std, 0.0);
}

TEST(EvalStats, StdHasNoCancellationForLargeOffsets) {
  // One pass (E[v^2] - mean^2) would lose every digit here.
  const Summary s = summarize({1e9 + 1.0, 1e9 + 2.0, 1e9 + 3.0, 1e9 + 4.0});
  EXPECT_NEAR(s.std, std::sqrt(1.25), 1e-6);
}

TEST(EvalStats, EmptyInputIsAnError) { EXPECT_THROW(summarize({}), pl::Error); }

TEST(EvalStats, HistogramCountsAndEdges) {
  const Histogram h = make_histogram({0.0, 1.0, 2.0, 3.0, 4.0, 0.5}, 4);
  ASSERT_EQ(h.counts.size(), 4u);
  EXPECT_DOUBLE_EQ(h.lo, 0.0);
  EXPECT_DOUBLE_EQ(h.hi, 4.0);
  EXPECT_DOUBLE_EQ(h.bin_width(), 1.0);
  // [0,1): 0, 0.5   [1,2): 1   [2,3): 2   [3,4]: 3, 4 (the maximum goes into the last bin)
  EXPECT_EQ(h.counts, (std::vector<std::size_t>{2, 1, 1, 2}));
}

TEST(EvalStats, HistogramOfEqualValuesHasWidth) {
  const Histogram h = make_histogram({2.0, 2.0, 2.0}, 3);
  EXPECT_LT(h.lo, 2.0);
  EXPECT_GT(h.hi, 2.0);
  std::size_t total = 0;
  for (auto c : h.counts) total += c;
  EXPECT_EQ(total, 3u);
}

TEST(EvalStats, DefaultBinCount) {
  EXPECT_EQ(default_bin_count(0), 1u);
  EXPECT_EQ(default_bin_count(10), 4u);
  EXPECT_EQ(default_bin_count(100), 10u);
  EXPECT_EQ(default_bin_count(100000), 20u);
}

}  // namespace
}  // namespace pl::eval
