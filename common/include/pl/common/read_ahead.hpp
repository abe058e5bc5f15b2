// Items 0..n-1 made in order on a second thread, one ahead of the caller: while the caller works on
// item i, item i+1 is being read (a scan loaded and decoded, say). The results are the same as a
// plain loop's; only the wall time differs. `make` must be safe to run beside the caller's work.
#pragma once

#include <cstddef>
#include <functional>
#include <future>
#include <utility>

namespace pl {

template <typename T>
class ReadAhead {
 public:
  ReadAhead(std::size_t n, std::function<T(std::size_t)> make) : n_(n), make_(std::move(make)) { launch(); }
  ~ReadAhead() {
    if (next_.valid()) next_.wait();
  }
  ReadAhead(const ReadAhead&) = delete;
  ReadAhead& operator=(const ReadAhead&) = delete;

  bool done() const { return taken_ >= n_; }
  // The next item; rethrows what `make` threw for it.
  T next() {
    T item = next_.get();
    ++taken_;
    launch();
    return item;
  }

 private:
  void launch() {
    if (taken_ < n_) next_ = std::async(std::launch::async, make_, taken_);
  }
  std::size_t n_, taken_ = 0;
  std::function<T(std::size_t)> make_;
  std::future<T> next_;
};

}  // namespace pl
