// The one median and percentile of the project (reports, tools, benchmarks).
//
// Convention: linear interpolation between the closest ranks, numpy's default (method "linear",
// Hyndman & Fan's definition 7), which evo, the trajectory evaluation tool, uses for its median.
// For n values sorted ascending, x[0] <= ... <= x[n-1], and p in [0, 100]:
//   h = (n - 1) * p / 100,  k = floor(h),  percentile = x[k] + (h - k) * (x[k+1] - x[k])
// so p = 0 is the smallest value, p = 100 the largest, and the median (p = 50) is the middle value
// of an odd count and the mean of the two middle values of an even one: the median of {1, 2, 3, 4}
// is 2.5, its 90th percentile 3.7. The order of the values does not matter.
//
// Errors: each throws pl::Error when `values` is empty, when p is outside [0, 100] (or NaN), and
// when a value is not finite (NaN has no rank, and an interpolation next to an infinity is not a
// number). A caller that may have no values decides itself what to report for them.
#pragma once

#include <vector>

namespace pl {

// The p-th percentile (p in [0, 100]) of `values`, in any order. O(n): no full sort.
double percentile(std::vector<double> values, double p);

// percentile(values, 50).
double median(std::vector<double> values);

}  // namespace pl
