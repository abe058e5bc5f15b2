// Per-channel sweep cutting of Hesai rounds.
#include "hesai_sweeps.hpp"

#include <cmath>

namespace pl::lidar {

double wrap_degrees(double deg) {
  if (deg < 0.0) deg += 360.0;
  else if (deg >= 360.0) deg -= 360.0;
  if (deg >= 0.0 && deg < 360.0) return deg;  // one step does for the sums and differences of angles
  deg = std::fmod(deg, 360.0);
  if (deg < 0.0) deg += 360.0;
  return deg >= 360.0 ? 0.0 : deg;
}

HesaiSweepCutter::HesaiSweepCutter(int channels, double cut_deg)
    : channels_(channels), cut_deg_(wrap_degrees(cut_deg)),
      ahead_(static_cast<std::size_t>(channels), 0), last_deg_(static_cast<std::size_t>(channels), 0.0) {}

double HesaiSweepCutter::from_cut(double azimuth_deg) const { return wrap_degrees(azimuth_deg - cut_deg_); }

// The first round: when its channels straddle the cut (all within a quarter turn of it, some past it),
// those past it open the second sweep at once.
void HesaiSweepCutter::start(const std::vector<double>& azimuth_deg, std::int64_t round_time_ns) {
  bool near_cut = true;
  int past = 0;
  for (int c = 0; c < channels_; ++c) {
    const double d = from_cut(azimuth_deg[static_cast<std::size_t>(c)]);
    near_cut = near_cut && (d <= 90.0 || d >= 270.0);
    past += d > 0.0 && d <= 180.0;
  }
  const bool straddles = near_cut && past > 0 && past < channels_;
  ahead_count_ = 0;
  for (int c = 0; c < channels_; ++c) {
    const double d = from_cut(azimuth_deg[static_cast<std::size_t>(c)]);
    ahead_[static_cast<std::size_t>(c)] = straddles && d > 0.0 && d <= 180.0;
    ahead_count_ += ahead_[static_cast<std::size_t>(c)];
  }
  open_[static_cast<std::size_t>(older_)].stamp_ns = round_time_ns;
  if (straddles) open_[static_cast<std::size_t>(1 - older_)].stamp_ns = round_time_ns;
  started_ = true;
}

void HesaiSweepCutter::step(const std::vector<double>& azimuth_deg, std::int64_t round_time_ns,
                            std::vector<Sweep>& out) {
  if (!started_) {
    start(azimuth_deg, round_time_ns);
  } else {
    for (int c = 0; c < channels_; ++c) {
      const std::size_t i = static_cast<std::size_t>(c);
      const double forward = wrap_degrees(azimuth_deg[i] - last_deg_[i]);
      const bool passed = forward > 0.0 && forward < 180.0 && wrap_degrees(cut_deg_ - last_deg_[i]) < forward;
      if (!passed || ahead_[i]) continue;
      ahead_[i] = 1;
      if (++ahead_count_ == 1) open_[static_cast<std::size_t>(1 - older_)].stamp_ns = round_time_ns;
    }
    if (ahead_count_ == channels_) complete_older(out);
  }
  last_deg_ = azimuth_deg;
}

void HesaiSweepCutter::complete_older(std::vector<Sweep>& out) {
  Sweep& done = open_[static_cast<std::size_t>(older_)];
  const std::size_t size = done.points.size();
  if (size > 0) out.push_back(std::move(done));
  done = Sweep{};
  done.points.reserve(size);
  older_ = 1 - older_;
  ahead_.assign(ahead_.size(), 0);
  ahead_count_ = 0;
}

void HesaiSweepCutter::finish(std::vector<Sweep>& out) {
  for (int k = 0; k < 2; ++k) {
    Sweep& s = open_[static_cast<std::size_t>(k == 0 ? older_ : 1 - older_)];
    if (!s.points.empty()) out.push_back(std::move(s));
    s = Sweep{};
  }
  ahead_.assign(ahead_.size(), 0);
  ahead_count_ = 0;
  started_ = false;
}

}  // namespace pl::lidar
