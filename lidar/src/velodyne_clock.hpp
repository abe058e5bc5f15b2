// A Velodyne packet's time. The sensor stamps each packet in microseconds past the hour (the top of
// the hour from GPS/PTP when synchronised, else from its own clock since power-on); the receive stamp
// supplies the hour. When the stamp then lies within a second of the receive time, the sensor's
// clock is UTC and its time is used as it is. Otherwise (a free-running clock, hours off) the time
// line is the receive time of an anchor packet plus the sensor's microseconds since it: intervals
// from the sensor, the epoch from the host, re-anchored when the two drift a second apart.
#pragma once

#include <cstdint>

namespace pl::lidar {

class VelodyneClock {
 public:
  // The packet's time stamp (ns) on the decoder's time line. toh_us < 3.6e9.
  std::int64_t packet_ns(std::uint32_t toh_us, std::int64_t receive_ns);
  bool synchronised() const { return synchronised_; }

 private:
  bool have_last_ = false;
  std::uint32_t last_toh_us_ = 0;
  bool anchored_ = false;
  std::int64_t anchor_ns_ = 0;
  std::uint32_t anchor_toh_us_ = 0;
  bool synchronised_ = false;
};

}  // namespace pl::lidar
