// A Velodyne packet's times. The sensor stamps each packet in microseconds past the hour (the top of
// the hour from GPS/PTP when synchronised, else from its own clock since power-on); the receive stamp
// supplies the hour. Two times come of it:
//  - stamp: when that puts the packet within a second of its receive time, the sensor's clock is UTC
//    and its time is the stamp; otherwise (a free-running clock, minutes or hours off) the receive
//    time is. Each packet's stamp depends on that packet alone, so a decoder started anywhere in a
//    recording stamps its sweeps alike.
//  - sensor: a steady time line for intervals, advanced by the sensor's microseconds between
//    packets (by the receive times where the sensor's clock stands still or jumps a second or more).
#pragma once

#include <cstdint>

namespace pl::lidar {

class VelodyneClock {
 public:
  struct Times {
    std::int64_t stamp_ns;
    std::int64_t sensor_ns;
  };
  // toh_us < 3.6e9.
  Times packet(std::uint32_t toh_us, std::int64_t receive_ns);

 private:
  bool have_last_ = false;
  std::uint32_t last_toh_us_ = 0;
  std::int64_t last_receive_ns_ = 0;
  std::int64_t sensor_ns_ = 0;
};

}  // namespace pl::lidar
