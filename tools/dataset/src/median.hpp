// The dataset reports' median: pl::median (pl/common/stats.hpp), 0 for no values (a drive without
// GPS, say, reports a median of 0 fixes' spread rather than failing).
#pragma once

#include <vector>

#include "pl/common/stats.hpp"

namespace pl::dataset {

inline double median_of(const std::vector<double>& v) { return v.empty() ? 0.0 : pl::median(v); }

}  // namespace pl::dataset
