#include "pl/common/progress.hpp"

#include <cstdio>
#include <cstdlib>
#include <unistd.h>

namespace pl {

bool Progress::enabled() { return ::isatty(STDERR_FILENO) && !std::getenv("PL_NO_PROGRESS"); }

Progress::Progress(std::string label, std::size_t total)
    : label_(std::move(label)), total_(total), active_(enabled()), start_(std::chrono::steady_clock::now()) {}

Progress::~Progress() { finish(); }

void Progress::update(std::size_t done) {
  if (!active_ || finished_) return;
  auto now = std::chrono::steady_clock::now();
  if (done < total_ && now - last_draw_ < std::chrono::milliseconds(100)) return;
  last_draw_ = now;
  double frac = total_ ? static_cast<double>(done) / static_cast<double>(total_) : 1.0;
  constexpr int kWidth = 30;
  int filled = static_cast<int>(frac * kWidth);
  char bar[kWidth + 1];
  for (int i = 0; i < kWidth; ++i) bar[i] = i < filled ? '#' : '.';
  bar[kWidth] = '\0';
  double elapsed = std::chrono::duration<double>(now - start_).count();
  double eta = frac > 0 ? elapsed * (1.0 - frac) / frac : 0.0;
  std::fprintf(stderr, "\r%s [%s] %zu/%zu %3.0f%%  %.0fs left ", label_.c_str(), bar, done, total_, 100.0 * frac, eta);
  std::fflush(stderr);
}

void Progress::finish() {
  if (!active_ || finished_) return;
  finished_ = true;
  std::fprintf(stderr, "\r\033[K");
  std::fflush(stderr);
}

void StageProgress::update(const std::string& stage, std::size_t done, std::size_t total) {
  if (!bar_ || stage != stage_) {
    finish();
    stage_ = stage;
    bar_ = std::make_unique<Progress>(stage, total);
  }
  bar_->update(done);
}

void StageProgress::finish() {
  if (bar_) bar_->finish();
  bar_.reset();
}

}  // namespace pl
