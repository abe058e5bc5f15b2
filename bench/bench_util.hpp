// Timing helpers for the benchmarks: repeated runs, medians, and A/B interleaving so a ratio holds
// when the machine's speed drifts.
#pragma once

#include <algorithm>
#include <chrono>
#include <vector>

namespace pl::bench {

inline double now_ms() {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

inline double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  std::size_t m = v.size() / 2;
  return v.size() % 2 ? v[m] : 0.5 * (v[m - 1] + v[m]);
}

inline double percentile(std::vector<double> v, double p) {
  std::sort(v.begin(), v.end());
  std::size_t k = static_cast<std::size_t>(p / 100.0 * static_cast<double>(v.size() - 1) + 0.5);
  return v[std::min(k, v.size() - 1)];
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
