// A Velodyne packet's time from its microseconds past the hour and its receive stamp.
#include "velodyne_clock.hpp"

#include <algorithm>

namespace pl::lidar {
namespace {

constexpr std::int64_t kHourUs = 3'600'000'000;
constexpr std::int64_t kHourNs = kHourUs * 1000;
constexpr std::int64_t kSecondNs = 1'000'000'000;
// Far enough from the int64 limits for an hour either side and a few of arithmetic.
constexpr std::int64_t kStampLimit = std::int64_t{1} << 61;

// a - b on the hour's circle, in [-half an hour, half an hour).
std::int64_t hour_difference_us(std::uint32_t a, std::uint32_t b) {
  std::int64_t d = static_cast<std::int64_t>(a) - static_cast<std::int64_t>(b);
  if (d >= kHourUs / 2) d -= kHourUs;
  if (d < -kHourUs / 2) d += kHourUs;
  return d;
}

std::int64_t floor_div(std::int64_t a, std::int64_t b) {
  std::int64_t q = a / b;
  if ((a % b != 0) && ((a < 0) != (b < 0))) --q;
  return q;
}

}  // namespace

std::int64_t VelodyneClock::packet_ns(std::uint32_t toh_us, std::int64_t receive_ns) {
  receive_ns = std::clamp(receive_ns, -kStampLimit, kStampLimit);
  // A clock that does not advance between packets (zeros, a sensor without one) tells no time.
  const bool frozen = have_last_ && toh_us == last_toh_us_;
  have_last_ = true;
  last_toh_us_ = toh_us;
  if (frozen) {
    synchronised_ = false;
    anchored_ = false;
    return receive_ns;
  }

  // The receive time's hour, or the one before or after, whichever puts the stamp nearest it.
  std::int64_t sensor_ns = floor_div(receive_ns, kHourNs) * kHourNs + static_cast<std::int64_t>(toh_us) * 1000;
  if (sensor_ns - receive_ns > kHourNs / 2) sensor_ns -= kHourNs;
  if (receive_ns - sensor_ns > kHourNs / 2) sensor_ns += kHourNs;
  synchronised_ = sensor_ns - receive_ns <= kSecondNs && receive_ns - sensor_ns <= kSecondNs;
  if (synchronised_) {
    anchored_ = false;
    return sensor_ns;
  }

  std::int64_t t = anchor_ns_ + hour_difference_us(toh_us, anchor_toh_us_) * 1000;
  if (!anchored_ || t - receive_ns > kSecondNs || receive_ns - t > kSecondNs) {
    anchored_ = true;
    anchor_ns_ = receive_ns;
    anchor_toh_us_ = toh_us;
    t = receive_ns;
  }
  return t;
}

}  // namespace pl::lidar
