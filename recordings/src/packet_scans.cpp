#include "packet_scans.hpp"

#include <algorithm>
#include <limits>

#include "pl/common/error.hpp"

namespace pl {

PacketScans::PacketScans(std::unique_ptr<PacketStream> stream, lidar::Vendor vendor, lidar::DecoderOptions options)
    : stream_(std::move(stream)), vendor_(vendor), options_(std::move(options)) {
  auto decoder = lidar::make_decoder(vendor_, options_);
  std::vector<lidar::Sweep> out;
  std::vector<std::size_t> points;  // of each sweep
  std::size_t begins = 0;           // the unit the next sweep begins in
  for (std::size_t u = 0; u < stream_->units(); ++u) {
    for (const ros::LidarPacket& p : stream_->packets(u)) {
      decoder->add(p.data, p.stamp_ns, out);
      for (const lidar::Sweep& s : out) {
        stamps_.push_back(s.stamp_ns);
        start_unit_.push_back(begins);
        points.push_back(s.points.size());
      }
      // The packet that closed these sweeps opens the next. (Several come at once where a decoder held
      // packets until it learnt its calibration: they all began at or after `begins`.)
      if (!out.empty()) begins = u;
      out.clear();
    }
  }
  decoder->finish(out);
  for (const lidar::Sweep& s : out) stamps_.push_back(s.stamp_ns), start_unit_.push_back(begins), points.push_back(s.points.size());
  sensor_ = decoder->info();
  counts_ = decoder->counts();
  // A recording starts and stops mid-rotation: a first or last sweep with less than half the points of
  // the median sweep is a part of one, left out.
  if (!points.empty()) {
    std::vector<std::size_t> sorted = points;
    std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
    median_points_ = sorted[sorted.size() / 2];
  }
  if (points.size() >= 3) {
    const std::size_t half = median_points_ / 2;
    if (points.back() < half) stamps_.pop_back(), start_unit_.pop_back(), ++partial_;
    if (points.front() < half) stamps_.erase(stamps_.begin()), start_unit_.erase(start_unit_.begin()), ++partial_;
  }
  for (std::size_t i = 1; i < stamps_.size(); ++i)
    if (stamps_[i] <= stamps_[i - 1])
      throw Error(stream_->where(start_unit_[i]) + ": sweep " + std::to_string(i) + " is stamped no later than the sweep before it (the " +
                  sensor_.model + "'s clock went back): the recording cannot be replayed in order");
}

void PacketScans::restart(std::size_t unit) {
  cursor_ = lidar::make_decoder(vendor_, options_);
  next_unit_ = unit;
  ready_.clear();
  emitted_ = std::numeric_limits<std::int64_t>::min();
}

lidar::Sweep PacketScans::sweep(std::size_t i) {
  if (i >= stamps_.size())
    throw Error("scan index " + std::to_string(i) + " out of range (" + std::to_string(stamps_.size()) + " sweeps)");
  const std::int64_t want = stamps_[i];
  // Go on with the decoder when it has not yet passed scan i and i lies near; else start a few sweeps before i.
  const bool waiting = std::any_of(ready_.begin(), ready_.end(), [&](const lidar::Sweep& s) { return s.stamp_ns == want; });
  if (!cursor_ || !(waiting || emitted_ < want) || start_unit_[i] > next_unit_ + 64) restart(start_unit_[i >= 3 ? i - 3 : 0]);
  for (;;) {
    while (!ready_.empty() && ready_.front().stamp_ns < want) ready_.erase(ready_.begin());
    if (!ready_.empty()) {
      if (ready_.front().stamp_ns != want) break;  // passed it: the packets decode otherwise now
      lidar::Sweep s = std::move(ready_.front());
      ready_.erase(ready_.begin());
      return s;
    }
    if (next_unit_ > stream_->units()) break;
    if (next_unit_ == stream_->units())
      cursor_->finish(ready_);
    else
      for (const ros::LidarPacket& p : stream_->packets(next_unit_)) cursor_->add(p.data, p.stamp_ns, ready_);
    ++next_unit_;
    if (!ready_.empty()) emitted_ = std::max(emitted_, ready_.back().stamp_ns);
  }
  throw Error(stream_->where(start_unit_[i]) + ": sweep " + std::to_string(i) + " did not decode again as it did when the recording was opened");
}

Frame PacketScans::frame(std::size_t i) { return frame_of_sweep(sweep(i), sensor_); }

Frame frame_of_sweep(const lidar::Sweep& sweep, const lidar::SensorInfo& sensor) {
  using lidar::ReturnType;
  bool strongest = false, last = false;
  for (const lidar::Point& p : sweep.points) {
    strongest |= p.return_type == ReturnType::Strongest;
    last |= p.return_type == ReturnType::Last;
  }
  // A firing whose strongest return is also its first or last is reported once, as FirstStrong or
  // LastStrong (Hesai's dual modes): kept with the strongest.
  auto keep = [&](ReturnType t) {
    if (t == ReturnType::Identical || t == ReturnType::FirstStrong || t == ReturnType::LastStrong) return true;
    if (strongest) return t == ReturnType::Strongest;
    if (last) return t == ReturnType::Last;
    return true;
  };
  Frame f;
  f.scan.reserve(sweep.points.size());
  f.rings.reserve(sweep.points.size());
  f.times.reserve(sweep.points.size());
  for (const lidar::Point& p : sweep.points) {
    if (!keep(p.return_type)) continue;
    f.scan.push_back({p.x, p.y, p.z, p.intensity});
    f.rings.push_back(p.channel < sensor.ring_of_channel.size() ? sensor.ring_of_channel[p.channel] : p.channel);
    f.times.push_back(static_cast<float>(p.time_s));
  }
  return f;
}

}  // namespace pl
