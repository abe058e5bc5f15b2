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

TEST(EvalStats, NearestRankPercentiles) {
  std::vector<double> v;
  for (int i = 1; i <= 10; ++i) v.push_back(i);
  EXPECT_DOUBLE_EQ(percentile_nearest_rank(v, 0), 1.0);
  EXPECT_DOUBLE_EQ(percentile_nearest_rank(v, 50), 5.0);
  EXPECT_DOUBLE_EQ(percentile_nearest_rank(v, 90), 9.0);  // 0.9 * 10 must not round up to rank 10
  EXPECT_DOUBLE_EQ(percentile_nearest_rank(v, 91), 10.0);
  EXPECT_DOUBLE_EQ(percentile_nearest_rank(v, 99), 10.0);
  EXPECT_DOUBLE_EQ(percentile_nearest_rank(v, 100), 10.0);

  const std::vector<double> w = {15, 20, 35, 40, 50};
  EXPECT_DOUBLE_EQ(percentile_nearest_rank(w, 5), 15.0);
  EXPECT_DOUBLE_EQ(percentile_nearest_rank(w, 30), 20.0);
  EXPECT_DOUBLE_EQ(percentile_nearest_rank(w, 40), 20.0);
  EXPECT_DOUBLE_EQ(percentile_nearest_rank(w, 50), 35.0);
  EXPECT_DOUBLE_EQ(percentile_nearest_rank(w, 100), 50.0);

  EXPECT_THROW(percentile_nearest_rank(w, 101), pl::Error);
  EXPECT_THROW(percentile_nearest_rank(w, -1), pl::Error);
  EXPECT_THROW(percentile_nearest_rank({}, 50), pl::Error);
}

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
