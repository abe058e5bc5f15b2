// A progress bar for long jobs: drawn on stderr when it is a terminal, silent otherwise.
#pragma once

#include <chrono>
#include <cstddef>
#include <string>

namespace pl {

class Progress {
 public:
  Progress(std::string label, std::size_t total);
  ~Progress();
  void update(std::size_t done);
  void finish();
  static bool enabled();  // stderr is a terminal and PL_NO_PROGRESS is unset

 private:
  std::string label_;
  std::size_t total_;
  bool active_;
  bool finished_ = false;
  std::chrono::steady_clock::time_point start_, last_draw_;
};

}  // namespace pl
