// A Velodyne packet's times from its microseconds past the hour and its receive stamp.
#include "velodyne_clock.hpp"

#include <algorithm>

namespace pl::lidar {
namespace {

constexpr std::int64_t kHourUs = 3'600'000'000;
constexpr std::int64_t kHourNs = kHourUs * 1000;
constexpr std::int64_t kSecondNs = 1'000'000'000;
// Far enough from the int64 limits for an hour either side and a few of arithmetic.
constexpr std::int64_t kStampLimit = std::int64_t{1} << 61;

std::int64_t floor_div(std::int64_t a, std::int64_t b) {
  std::int64_t q = a / b;
  if ((a % b != 0) && ((a < 0) != (b < 0))) --q;
  return q;
}

}  // namespace

VelodyneClock::Times VelodyneClock::packet(std::uint32_t toh_us, std::int64_t receive_ns) {
  receive_ns = std::clamp(receive_ns, -kStampLimit, kStampLimit);
  // The receive time's hour, or the one before or after, whichever puts the stamp nearest it.
  std::int64_t utc_ns = floor_div(receive_ns, kHourNs) * kHourNs + static_cast<std::int64_t>(toh_us) * 1000;
  if (utc_ns - receive_ns > kHourNs / 2) utc_ns -= kHourNs;
  if (receive_ns - utc_ns > kHourNs / 2) utc_ns += kHourNs;
  const bool synchronised = utc_ns - receive_ns <= kSecondNs && receive_ns - utc_ns <= kSecondNs;

  if (!have_last_) {
    sensor_ns_ = synchronised ? utc_ns : receive_ns;
  } else {
    // The sensor's microseconds since the previous packet, on the hour's circle.
    std::int64_t d_us = static_cast<std::int64_t>(toh_us) - last_toh_us_;
    if (d_us >= kHourUs / 2) d_us -= kHourUs;
    if (d_us < -kHourUs / 2) d_us += kHourUs;
    if (d_us > 0 && d_us < kSecondNs / 1000)
      sensor_ns_ += d_us * 1000;
    else
      sensor_ns_ += std::clamp(receive_ns - last_receive_ns_, std::int64_t{0}, 3600 * kSecondNs);
    sensor_ns_ = std::clamp(sensor_ns_, -kStampLimit, kStampLimit);
  }
  have_last_ = true;
  last_toh_us_ = toh_us;
  last_receive_ns_ = receive_ns;
  return {synchronised ? utc_ns : receive_ns, sensor_ns_};
}

}  // namespace pl::lidar
