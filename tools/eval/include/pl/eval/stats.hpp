// Summary statistics of a list of values (errors, timings) and fixed-width histograms. Medians and
// percentiles are pl::median and pl::percentile (pl/common/stats.hpp: linear interpolation between
// the closest ranks).
#pragma once

#include <cstddef>
#include <vector>

namespace pl::eval {

struct Summary {
  std::size_t count = 0;
  double mean = 0.0;
  double median = 0.0;  // pl::median: the middle value; the mean of the two middle values when count is even
  double rmse = 0.0;    // sqrt(mean of squares)
  double std = 0.0;     // population standard deviation: sqrt(mean of (v - mean)^2)
  double min = 0.0;
  double max = 0.0;
};

// Throws pl::Error when `values` is empty.
Summary summarize(const std::vector<double>& values);

// `bins` equal-width bins over [lo, hi]; a value equal to hi goes into the last bin.
struct Histogram {
  double lo = 0.0;
  double hi = 1.0;
  std::vector<std::size_t> counts;

  double bin_width() const { return counts.empty() ? 0.0 : (hi - lo) / static_cast<double>(counts.size()); }
  double edge(std::size_t i) const { return lo + bin_width() * static_cast<double>(i); }
};

// Bins span [min, max] of the values (a unit-wide range around the value when they are all equal).
Histogram make_histogram(const std::vector<double>& values, std::size_t bins);
// ceil(sqrt(n)), clamped to [1, 20].
std::size_t default_bin_count(std::size_t n);

}  // namespace pl::eval
