// Timing helpers for the benchmarks: repeated runs and A/B interleaving so a ratio holds when the
// machine's speed drifts. Medians and percentiles are pl::median and pl::percentile
// (pl/common/stats.hpp, included here for every benchmark).
#pragma once

#include <algorithm>
#include <chrono>
#include <vector>

#include "pl/common/stats.hpp"

namespace pl::bench {

inline double now_ms() {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

// Runs a and b alternately `runs` times (after one warm-up each); returns per-run milliseconds.
template <typename A, typename B>
void interleave(int runs, A&& a, B&& b, std::vector<double>& ms_a, std::vector<double>& ms_b) {
  a();
  b();
  for (int i = 0; i < runs; ++i) {
    double t0 = now_ms();
    a();
    double t1 = now_ms();
    b();
    double t2 = now_ms();
    ms_a.push_back(t1 - t0);
    ms_b.push_back(t2 - t1);
  }
}

}  // namespace pl::bench
