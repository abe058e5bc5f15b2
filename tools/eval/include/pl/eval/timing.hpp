// Per-scan processing time distribution from a CSV log.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "pl/eval/stats.hpp"

namespace pl::eval {

struct TimingColumn {
  std::string name;
  std::vector<double> values;
  std::vector<std::string> all_columns;
};

// Reads one numeric column of a CSV file whose first (non-blank, non-#) line is a header of
// comma-separated names. Without `column`: the column named registration_ms, else the only column
// whose name ends in _ms, else pl::Error listing the columns. Every row must have as many fields
// as the header and a number in the chosen column (errors name the file and line).
TimingColumn read_timing_csv(const std::string& path, const std::optional<std::string>& column);

struct TimingStats {
  std::size_t count = 0;
  double min = 0.0;
  double mean = 0.0;
  double p50 = 0.0;  // percentiles are pl::percentile (linear between the closest ranks)
  double p90 = 0.0;
  double p99 = 0.0;
  double max = 0.0;
};

TimingStats timing_stats(const std::vector<double>& values);

// One line a bin: "[lo, hi)  count  ####" with bars scaled to the fullest bin (`width` characters).
std::string text_histogram(const Histogram& histogram, std::size_t width = 40, int decimals = 2);

}  // namespace pl::eval
