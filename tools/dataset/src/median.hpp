// The median shared by the dataset reports (the mean of the middle two for an even count).
#pragma once

#include <algorithm>
#include <vector>

namespace pl::dataset {

inline double median_of(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const std::size_t m = v.size() / 2;
  return v.size() % 2 ? v[m] : 0.5 * (v[m - 1] + v[m]);
}

}  // namespace pl::dataset
