// A progress bar for long jobs: drawn on stderr when it is a terminal, silent otherwise.
#pragma once

#include <chrono>
#include <cstddef>
#include <memory>
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

// The bars of a job of several stages, fed by a library's progress(stage, done, total) callback: a
// new bar each time the stage changes; finish() (or the destructor) ends the last one.
class StageProgress {
 public:
  void update(const std::string& stage, std::size_t done, std::size_t total);
  void finish();

 private:
  std::string stage_;
  std::unique_ptr<Progress> bar_;
};

}  // namespace pl
