// Exponential backoff with +-20 % jitter, for the tile client's requests while the server is down or
// erroring: each failure doubles the delay (from min_s, at most max_s), a success resets it. The
// jitter keeps a fleet of vehicles from retrying in step. Times are passed in (defaulting to now), so
// that the schedule is tested without waiting. Private to pl_client.
#pragma once

#include <algorithm>
#include <chrono>
#include <random>

namespace pl::client {

class Backoff {
 public:
  using Clock = std::chrono::steady_clock;

  Backoff(double min_s, double max_s, unsigned seed = std::random_device{}()) : min_(min_s), max_(max_s), rng_(seed) {}

  // Whether a request may go at `now` (no delay running, or it has ended).
  bool allowed(Clock::time_point now = Clock::now()) const { return now >= until_; }
  // Whether the last request failed: the next one is a retry.
  bool backing_off() const { return delay_ > 0; }
  // When the running delay ends (the epoch when none runs).
  Clock::time_point until() const { return until_; }

  // A request failed at `now`: starts the next delay and returns it in seconds (with its jitter).
  double failed(Clock::time_point now = Clock::now()) {
    delay_ = delay_ == 0 ? min_ : std::min(2 * delay_, max_);
    double d = delay_ * std::uniform_real_distribution<double>(0.8, 1.2)(rng_);
    until_ = now + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(d));
    return d;
  }

  void succeeded() {
    delay_ = 0;
    until_ = Clock::time_point{};
  }

 private:
  double min_, max_, delay_ = 0;
  Clock::time_point until_{};
  std::minstd_rand rng_;
};

}  // namespace pl::client
