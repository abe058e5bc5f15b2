// Per-key token buckets: each key (a bearer token's id) may make `rate` requests a second on
// average and `burst` at once. Private to pl_server.
#pragma once

#include <chrono>
#include <cmath>
#include <mutex>
#include <string>
#include <unordered_map>

namespace pl::server {

class RateLimiter {
 public:
  using Clock = std::chrono::steady_clock;
  RateLimiter(double rate, double burst) : rate_(rate), burst_(std::max(burst, 1.0)) {}

  // Takes one request's worth for `key`: 0 when allowed, else the seconds until one would be.
  // A rate of 0 or below allows everything.
  double take(const std::string& key, Clock::time_point now = Clock::now()) {
    if (!(rate_ > 0)) return 0;
    std::lock_guard<std::mutex> lock(mutex_);
    if (buckets_.size() > kMaxKeys) buckets_.clear();  // bounded: keys are tokens, few; a flood of them starts afresh
    auto [it, fresh] = buckets_.try_emplace(key, Bucket{burst_, now});
    Bucket& b = it->second;
    if (!fresh) {
      b.tokens = std::min(burst_, b.tokens + std::chrono::duration<double>(now - b.at).count() * rate_);
      b.at = now;
    }
    if (b.tokens >= 1.0) {
      b.tokens -= 1.0;
      return 0;
    }
    return (1.0 - b.tokens) / rate_;
  }

 private:
  static constexpr std::size_t kMaxKeys = 100000;
  struct Bucket {
    double tokens;
    Clock::time_point at;
  };
  double rate_, burst_;
  std::mutex mutex_;
  std::unordered_map<std::string, Bucket> buckets_;
};

}  // namespace pl::server
