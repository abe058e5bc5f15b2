// Hesai sweeps, cut channel by channel: a laser's points go to the next sweep once its own corrected
// azimuth has passed the cut azimuth, so each sweep holds every channel's one turn, as the makers'
// driver cuts them. Two sweeps are open while the round's channels straddle the cut; the older is
// complete when its last channel has passed.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "pl/lidar/decoder.hpp"

namespace pl::lidar {

// An angle in degrees, into [0, 360).
double wrap_degrees(double deg);

class HesaiSweepCutter {
 public:
  HesaiSweepCutter(int channels, double cut_deg);

  // One firing round: each channel's azimuth (degrees, [0, 360)) and the time of the round's earliest
  // firing, which stamps a sweep the round opens. Sweeps the round completes are appended to `out`.
  // A channel passes the cut when it lies in [previous azimuth, this azimuth), a step forward of less
  // than half a turn; a channel on the cut still belongs to the sweep before.
  void step(const std::vector<double>& azimuth_deg, std::int64_t round_time_ns, std::vector<Sweep>& out);

  // The sweep the current round's points of `channel` belong to.
  Sweep& sweep_of(int channel) { return open_[static_cast<std::size_t>(ahead_[static_cast<std::size_t>(channel)] ? 1 - older_ : older_)]; }

  // Appends the open sweeps that have points, older first; the next round starts afresh.
  void finish(std::vector<Sweep>& out);

 private:
  double from_cut(double azimuth_deg) const;  // [0, 360) forward from the cut
  void start(const std::vector<double>& azimuth_deg, std::int64_t round_time_ns);
  void complete_older(std::vector<Sweep>& out);

  int channels_;
  double cut_deg_;
  bool started_ = false;
  std::array<Sweep, 2> open_;
  int older_ = 0;
  std::vector<std::uint8_t> ahead_;  // 1: the channel has passed the cut, its points go to the newer sweep
  int ahead_count_ = 0;
  std::vector<double> last_deg_;
};

}  // namespace pl::lidar
