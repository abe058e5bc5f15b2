#include "pl/eval/stats.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "pl/common/error.hpp"
#include "pl/common/stats.hpp"

namespace pl::eval {

Summary summarize(const std::vector<double>& values) {
  if (values.empty()) throw Error("no values to summarise");
  Summary s;
  s.count = values.size();
  const double n = static_cast<double>(values.size());
  double sum = 0.0, sum_sq = 0.0;
  for (double v : values) {
    sum += v;
    sum_sq += v * v;
  }
  s.mean = sum / n;
  s.rmse = std::sqrt(sum_sq / n);
  // Two passes for the deviation: no cancellation when the spread is small against the mean.
  double dev_sq = 0.0;
  for (double v : values) dev_sq += (v - s.mean) * (v - s.mean);
  s.std = std::sqrt(dev_sq / n);

  s.median = median(values);
  auto [mn, mx] = std::minmax_element(values.begin(), values.end());
  s.min = *mn;
  s.max = *mx;
  return s;
}

Histogram make_histogram(const std::vector<double>& values, std::size_t bins) {
  Histogram h;
  if (bins == 0) bins = 1;
  h.counts.assign(bins, 0);
  if (values.empty()) return h;
  auto [mn, mx] = std::minmax_element(values.begin(), values.end());
  h.lo = *mn;
  h.hi = *mx;
  if (!(h.hi > h.lo)) {
    h.lo -= 0.5;
    h.hi += 0.5;
  }
  const double width = h.bin_width();
  for (double v : values) {
    double k = std::floor((v - h.lo) / width);
    std::size_t i = k <= 0.0 ? 0 : static_cast<std::size_t>(k);
    if (i >= bins) i = bins - 1;
    ++h.counts[i];
  }
  return h;
}

std::size_t default_bin_count(std::size_t n) {
  auto b = static_cast<std::size_t>(std::ceil(std::sqrt(static_cast<double>(n))));
  return std::clamp<std::size_t>(b, 1, 20);
}

}  // namespace pl::eval
