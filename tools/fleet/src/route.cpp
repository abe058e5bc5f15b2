// Routes: a street grid over the map's extent, driven with a random turn at each crossing.
#include "route.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

namespace pl::fleet {

Route::Route(const double extent[4], double block, double length, std::mt19937_64& rng) {
  auto lines = [&](double lo, double hi) {
    const double w = hi - lo, inset = std::min(block / 2, w / 4);
    const int n = std::max(2, static_cast<int>(std::floor((w - 2 * inset) / block)) + 1);
    std::vector<double> out;
    for (int i = 0; i < n; ++i) out.push_back(lo + inset + (w - 2 * inset) * i / (n - 1));
    return out;
  };
  const std::vector<double> xs = lines(extent[0], extent[2]), ys = lines(extent[1], extent[3]);
  auto pick = [&](int n) { return static_cast<int>(std::uniform_int_distribution<int>(0, n - 1)(rng)); };
  int i = pick(static_cast<int>(xs.size())), j = pick(static_cast<int>(ys.size())), pi = -1, pj = -1;
  pts_.emplace_back(xs[i], ys[j]);
  cum_.push_back(0);
  while (cum_.back() < length) {
    std::vector<std::pair<int, int>> next;
    for (auto [di, dj] : {std::pair{1, 0}, {-1, 0}, {0, 1}, {0, -1}}) {
      const int ni = i + di, nj = j + dj;
      if (ni < 0 || nj < 0 || ni >= static_cast<int>(xs.size()) || nj >= static_cast<int>(ys.size())) continue;
      if (ni == pi && nj == pj) continue;
      next.emplace_back(ni, nj);
    }
    if (next.empty()) next.emplace_back(pi, pj);  // a dead end: back the way it came
    const auto [ni, nj] = next[static_cast<std::size_t>(pick(static_cast<int>(next.size())))];
    pi = i, pj = j, i = ni, j = nj;
    const Eigen::Vector2d p(xs[i], ys[j]);
    cum_.push_back(cum_.back() + (p - pts_.back()).norm());
    pts_.push_back(p);
  }
}

Eigen::Vector2d Route::at(double s) {
  s = std::min(s, cum_.back());
  while (cursor_ + 2 < cum_.size() && cum_[cursor_ + 1] < s) ++cursor_;
  const double len = cum_[cursor_ + 1] - cum_[cursor_];
  const double f = len > 0 ? (s - cum_[cursor_]) / len : 0.0;
  return pts_[cursor_] + f * (pts_[cursor_ + 1] - pts_[cursor_]);
}

}  // namespace pl::fleet
