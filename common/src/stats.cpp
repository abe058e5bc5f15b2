#include "pl/common/stats.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdio>
#include <string>
#include <utility>

#include "pl/common/error.hpp"

namespace pl {

namespace {

std::string number(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

}  // namespace

double percentile(std::vector<double> values, double p) {
  if (values.empty()) throw Error("percentile of no values");
  if (!(p >= 0.0 && p <= 100.0)) throw Error("percentile " + number(p) + " is outside [0, 100]");
  for (double v : values)
    if (!std::isfinite(v)) throw Error("percentile of a value that is not finite (" + number(v) + ")");
  const std::size_t n = values.size();
  // p * (n - 1) first: exact for whole p, so a rank that is a whole number (0.9 * 10 = 9) stays one.
  const double h = p * static_cast<double>(n - 1) / 100.0;
  const std::size_t k = std::min(static_cast<std::size_t>(std::floor(h)), n - 1);
  const double t = h - static_cast<double>(k);
  auto at = values.begin() + static_cast<std::ptrdiff_t>(k);
  std::nth_element(values.begin(), at, values.end());
  const double lo = *at;
  if (t == 0.0 || k + 1 == n) return lo;
  // Everything after `at` is >= lo: the next value in order is the smallest of them.
  const double hi = *std::min_element(at + 1, values.end());
  const double span = hi - lo;
  // lo + t * span is exact at t = 0 and for equal values; the other form only where the span of two
  // finite values overflows (values near +-1.8e308).
  return std::isfinite(span) ? lo + t * span : (1.0 - t) * lo + t * hi;
}

double median(std::vector<double> values) { return percentile(std::move(values), 50.0); }

}  // namespace pl
