// pl::percentile and pl::median (pl/common/stats.hpp): linear interpolation between the closest
// ranks, against values worked out by hand from h = (n - 1) * p / 100.
#include "pl/common/stats.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "pl/common/error.hpp"

namespace {

using pl::median;
using pl::percentile;

TEST(Stats, MedianOfAnOddCountIsTheMiddleValue) {
  EXPECT_EQ(median({7.0}), 7.0);
  EXPECT_EQ(median({3.0, 1.0, 2.0}), 2.0);
  EXPECT_EQ(median({9.0, -4.0, 0.5, 100.0, 2.0}), 2.0);
}

TEST(Stats, MedianOfAnEvenCountIsTheMeanOfTheTwoMiddleValues) {
  EXPECT_EQ(median({4.0, 1.0, 3.0, 2.0}), 2.5);
  EXPECT_EQ(median({-3.0, -1.0}), -2.0);
  EXPECT_EQ(median({5.0, 1.0, 5.0, 1.0}), 3.0);  // 1 1 5 5: the two middle values differ
  EXPECT_EQ(median({2.0, 2.0, 9.0, 1.0}), 2.0);  // 1 2 2 9: they are equal
}

TEST(Stats, EndsAreTheSmallestAndLargestValues) {
  const std::vector<double> v = {4.0, -2.5, 8.0, 3.0, 0.0};
  EXPECT_EQ(percentile(v, 0), -2.5);
  EXPECT_EQ(percentile(v, 100), 8.0);
  EXPECT_EQ(percentile({6.0}, 0), 6.0);
  EXPECT_EQ(percentile({6.0}, 37), 6.0);
  EXPECT_EQ(percentile({6.0}, 100), 6.0);
}

TEST(Stats, InterpolatesBetweenTheClosestRanks) {
  // 1 2 3 4: h = 3p/100.
  const std::vector<double> four = {3.0, 1.0, 4.0, 2.0};
  EXPECT_DOUBLE_EQ(percentile(four, 25), 1.75);  // h = 0.75
  EXPECT_DOUBLE_EQ(percentile(four, 90), 3.7);   // h = 2.7
  EXPECT_DOUBLE_EQ(percentile(four, 10), 1.3);   // h = 0.3
  // 15 20 35 40 50: h = 4p/100.
  const std::vector<double> five = {50.0, 15.0, 40.0, 20.0, 35.0};
  EXPECT_DOUBLE_EQ(percentile(five, 5), 16.0);   // h = 0.2: 15 + 0.2 * 5
  EXPECT_DOUBLE_EQ(percentile(five, 40), 29.0);  // h = 1.6: 20 + 0.6 * 15
  EXPECT_EQ(percentile(five, 50), 35.0);         // h = 2
  EXPECT_EQ(percentile(five, 75), 40.0);         // h = 3
  EXPECT_DOUBLE_EQ(percentile(five, 95), 48.0);  // h = 3.8: 40 + 0.8 * 10
  // 1 .. 10: h = 9p/100.
  std::vector<double> ten;
  for (int i = 10; i >= 1; --i) ten.push_back(i);
  EXPECT_DOUBLE_EQ(percentile(ten, 50), 5.5);   // h = 4.5
  EXPECT_DOUBLE_EQ(percentile(ten, 90), 9.1);   // h = 8.1
  EXPECT_DOUBLE_EQ(percentile(ten, 99), 9.91);  // h = 8.91
}

TEST(Stats, AWholeRankGivesThatValueExactly) {
  // 0 .. 10: h = p / 10. Computed as 0.9 * 10 the rank of p90 would be 9.000000000000002, a hair
  // above the value 9; p * (n - 1) / 100 keeps it at 9.
  std::vector<double> v;
  for (int i = 0; i <= 10; ++i) v.push_back(i);
  for (int p = 0; p <= 100; p += 10) EXPECT_EQ(percentile(v, p), p / 10.0) << "p" << p;
  EXPECT_EQ(percentile({0.1, 0.1, 0.1}, 70), 0.1);  // equal values: no rounding at all
}

TEST(Stats, OrderOfTheValuesDoesNotMatter) {
  std::vector<double> v = {0.31, 7.5, -2.0, 0.31, 12.25, 3.0, 3.5, -0.75, 9.0};
  std::vector<double> sorted = v;
  std::sort(sorted.begin(), sorted.end());
  std::mt19937 rng(11);
  for (int round = 0; round < 20; ++round) {
    std::shuffle(v.begin(), v.end(), rng);
    for (double p : {0.0, 12.5, 50.0, 62.0, 99.0, 100.0}) EXPECT_EQ(percentile(v, p), percentile(sorted, p)) << "p" << p;
    EXPECT_EQ(median(v), 3.0);  // 9 values: the 5th of them sorted
  }
}

TEST(Stats, AgreesWithTheFormulaOnSortedRandomValues) {
  // The formula of stats.hpp on a full sort, against the partial selection percentile() does.
  std::mt19937 rng(5);
  std::normal_distribution<double> noise(10.0, 4.0);
  for (std::size_t n : {2u, 3u, 10u, 101u, 1000u}) {
    std::vector<double> v(n);
    for (double& x : v) x = noise(rng);
    std::vector<double> s = v;
    std::sort(s.begin(), s.end());
    for (double p : {0.0, 1.0, 33.3, 50.0, 90.0, 99.9, 100.0}) {
      const double h = p * static_cast<double>(n - 1) / 100.0;
      const auto k = static_cast<std::size_t>(std::floor(h));
      const double want = k + 1 < n ? s[k] + (h - static_cast<double>(k)) * (s[k + 1] - s[k]) : s[k];
      EXPECT_DOUBLE_EQ(percentile(v, p), want) << "n " << n << " p " << p;
    }
  }
}

TEST(Stats, RisesWithP) {
  const std::vector<double> v = {5.0, 1.0, 1.0, 8.0, 2.0, 13.0, 3.0};
  double last = percentile(v, 0);
  for (double p = 0.5; p <= 100.0; p += 0.5) {
    const double now = percentile(v, p);
    EXPECT_GE(now, last) << "p" << p;
    last = now;
  }
  EXPECT_EQ(last, 13.0);
}

TEST(Stats, ValuesAtTheEndsOfTheDoubleRange) {
  // The span of the two middle values overflows; the median is still their mean.
  const double big = std::numeric_limits<double>::max();
  EXPECT_EQ(median({-big, big}), 0.0);
  EXPECT_EQ(median({big, big}), big);
}

TEST(Stats, EmptyInputIsAnError) {
  EXPECT_THROW(percentile({}, 50), pl::Error);
  EXPECT_THROW(median({}), pl::Error);
}

TEST(Stats, POutsideZeroToHundredIsAnError) {
  const std::vector<double> v = {1.0, 2.0};
  EXPECT_THROW(percentile(v, -0.001), pl::Error);
  EXPECT_THROW(percentile(v, 100.001), pl::Error);
  EXPECT_THROW(percentile(v, std::nan("")), pl::Error);
  EXPECT_THROW(percentile(v, std::numeric_limits<double>::infinity()), pl::Error);
  try {
    percentile(v, 101);
    FAIL() << "p = 101 accepted";
  } catch (const pl::Error& e) {
    EXPECT_NE(std::string(e.what()).find("101"), std::string::npos) << e.what();
  }
}

TEST(Stats, NonFiniteValuesAreAnError) {
  const double inf = std::numeric_limits<double>::infinity();
  EXPECT_THROW(median({1.0, std::nan(""), 3.0}), pl::Error);
  EXPECT_THROW(median({1.0, inf, 3.0}), pl::Error);
  EXPECT_THROW(percentile({-inf, 1.0}, 0), pl::Error);  // even where the answer would be a value
}

}  // namespace
