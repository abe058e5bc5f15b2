// Checked Velodyne packets -> sweeps: the azimuth and time of each firing, the return it reports,
// and the sweep it belongs to.
#include "velodyne_sweep.hpp"

#include <cmath>

namespace pl::lidar {
namespace {

constexpr double kTurn = 36000;  // azimuth steps of 0.01 degree
// A column's azimuth step beyond this (10 degrees) is no rotation: its firings get no share of it.
constexpr float kMaxStep = 1000;
// Packets further apart than this (microseconds) start afresh: the turns between cannot be told.
constexpr double kGapUs = 1e6;
// Rotation rates believed, 0.01 degree per microsecond (1.4 to 55 turns a second).
constexpr double kMinRate = 0.05, kMaxRate = 2;
bool believable(double rate) { return rate >= kMinRate && rate <= kMaxRate; }

std::uint16_t u16(const std::uint8_t* p) { return static_cast<std::uint16_t>(p[0] | p[1] << 8); }

// d on the turn's circle, in [-half a turn, half a turn).
double around(double d) { return d - kTurn * std::floor((d + kTurn / 2) / kTurn); }

// The reference decoder's codes for a dual-return pair: identical returns are reported once; else
// first/last by distance and strong/weak by intensity (equal intensities: the last is the strong one).
ReturnType dual_return(std::uint16_t raw, std::uint8_t intensity, std::uint16_t other_raw,
                       std::uint8_t other_intensity) {
  if (other_raw == 0 || other_raw == raw) return ReturnType::Identical;
  const bool first = raw < other_raw;
  const bool strong = intensity == other_intensity ? !first : intensity > other_intensity;
  if (first) return strong ? ReturnType::FirstStrong : ReturnType::FirstWeak;
  return strong ? ReturnType::LastStrong : ReturnType::LastWeak;
}

}  // namespace

VelodyneSweeper::VelodyneSweeper(const DecoderOptions& options)
    : min_range_m_(options.min_range_m), max_range_m_(options.max_range_m), cut_(options.cut_azimuth_deg * 100) {}

void VelodyneSweeper::start_at(double turned) {
  sweep_end_ = cut_ + kTurn * (std::floor((turned - cut_) / kTurn) + 1);
}

void VelodyneSweeper::emit(OpenSweep& s, std::vector<Sweep>& out, DecodeCounts& counts) {
  if (!s.sweep.points.empty()) {
    s.sweep.stamp_ns = s.earliest_ns;
    if (s.earliest_ns != s.first_ns) {
      const double shift = static_cast<double>(s.first_ns - s.earliest_ns) * 1e-9;
      for (Point& pt : s.sweep.points) pt.time_s += shift;
    }
    ++counts.sweeps;
    counts.points += s.sweep.points.size();
    out.push_back(std::move(s.sweep));
  }
  s = OpenSweep{};
}

void VelodyneSweeper::finish(std::vector<Sweep>& out, DecodeCounts& counts) {
  emit(current_, out, counts);
  emit(next_, out, counts);
  have_previous_ = false;
}

void VelodyneSweeper::unwrap_columns(const std::uint8_t* packet, const VelodyneLayout& layout,
                                     std::int64_t packet_ns, std::vector<Sweep>& out, DecodeCounts& counts) {
  const int columns = layout.columns;
  bool seen[12] = {};
  for (int b = 0; b < kVelodyneBlocks; ++b) {
    const int c = layout.blocks[b].column;
    if (!layout.blocks[b].used || seen[c]) continue;
    seen[c] = true;
    azimuth_[c] = u16(packet + 100 * b + 2);
  }
  const std::int64_t first_ns = packet_ns + layout.firing_ns[0][0];
  const double dt_us = static_cast<double>(first_ns - previous_ns_) / 1000;
  if (have_previous_ && std::abs(dt_us) >= kGapUs) {
    emit(current_, out, counts);
    emit(next_, out, counts);
    have_previous_ = false;
  }
  if (have_previous_) {
    // The turns since the previous column: as many as the rotation rate makes of the time between.
    const double d = azimuth_[0] - previous_azimuth_;
    const double expected = rate_ > 0 && dt_us > 0 ? rate_ * dt_us : 0;
    turned_[0] = previous_turned_ + d + kTurn * std::round((expected - d) / kTurn);
    const double rate = (turned_[0] - previous_turned_) / dt_us;
    if (columns == 1 && dt_us > 0 && dt_us < 1e4 && believable(rate)) rate_ = rate;
  } else {
    turned_[0] = azimuth_[0];
    start_at(turned_[0]);
  }
  // Within a packet the sensor only turns forward: a step back beyond jitter is a jump forward (a
  // sensor that sends only part of the turn fills its packet's last blocks after the gap).
  for (int c = 1; c < columns; ++c) {
    double d = around(azimuth_[c] - azimuth_[c - 1]);
    if (d < -kMaxStep) d += kTurn;
    turned_[c] = turned_[c - 1] + d;
  }
  double stepped = 0;
  int steps = 0;
  for (int c = 0; c + 1 < columns; ++c) {
    const double d = turned_[c + 1] - turned_[c];
    if (d >= 0 && d <= kMaxStep) stepped += d, ++steps;
  }
  if (steps > 0 && believable(stepped / (steps * static_cast<double>(layout.column_us))))
    rate_ = stepped / (steps * static_cast<double>(layout.column_us));
  float last_step = static_cast<float>(rate_ * layout.column_us);
  for (int c = 0; c < columns; ++c) {
    const double d = c + 1 < columns ? turned_[c + 1] - turned_[c] : -1;
    if (d >= 0 && d <= kMaxStep) last_step = static_cast<float>(d);
    step_[c] = last_step >= 0 && last_step <= kMaxStep ? last_step : 0;
  }
  // A column after a jump fired later than the table says: by the jump at the rotation rate.
  shift_ns_[0] = 0;
  for (int c = 1; c < columns; ++c) {
    const double d = turned_[c] - turned_[c - 1];
    shift_ns_[c] = shift_ns_[c - 1];
    if (d > kMaxStep && rate_ > 0) shift_ns_[c] += std::llround((d / rate_ - layout.column_us) * 1000);
  }
  // A whole turn or more without packets: the open sweeps end.
  if (turned_[0] >= sweep_end_ + kTurn) {
    emit(current_, out, counts);
    emit(next_, out, counts);
    start_at(turned_[0]);
  }
  have_previous_ = true;
  previous_azimuth_ = azimuth_[columns - 1];
  previous_turned_ = turned_[columns - 1];
  previous_ns_ = packet_ns + layout.firing_ns[0][0] + shift_ns_[columns - 1] +
                 static_cast<std::int64_t>(std::llround((columns - 1) * static_cast<double>(layout.column_us) * 1000));
}

void VelodyneSweeper::add(const std::uint8_t* packet, const VelodyneLayout& layout, ReturnType single,
                          std::int64_t packet_ns, const VelodyneGeometry& geometry, std::vector<Sweep>& out,
                          DecodeCounts& counts) {
  unwrap_columns(packet, layout, packet_ns, out, counts);
  for (int b = 0; b < kVelodyneBlocks; ++b) {
    const VelodyneLayout::Block& role = layout.blocks[b];
    if (!role.used) continue;
    const std::uint8_t* block = packet + 100 * b;
    const std::uint8_t* partner = packet + 100 * role.partner;
    const auto azimuth = static_cast<float>(u16(block + 2));
    const float step = step_[role.column];
    const double turned = turned_[role.column];
    for (int j = 0; j < kVelodyneSlots; ++j) {
      const float share = step * layout.interp_mul[b][j] / layout.interp_div;
      const std::int64_t t = packet_ns + layout.firing_ns[b][j] + shift_ns_[role.column];
      OpenSweep& s = turned + share < sweep_end_ ? current_ : next_;
      if (!s.fired) {
        s.fired = true;
        s.first_ns = s.earliest_ns = t;
      } else if (t < s.earliest_ns) {
        s.earliest_ns = t;
      }
      const std::uint8_t* ret = block + 4 + 3 * j;
      const std::uint16_t raw = u16(ret);
      if (raw == 0) continue;
      const std::uint8_t* other = partner + 4 + 3 * j;
      // A second return equal to the first is reported once, in the first block of the pair.
      if (layout.dual && role.partner < b && u16(other) == raw) continue;
      const int laser = layout.laser[b][j];
      const float distance = geometry.distance_m(laser, raw);
      if (!(distance >= min_range_m_ && distance <= max_range_m_)) continue;
      const int a = geometry.azimuth(laser, azimuth + share);
      Point pt;
      geometry.place(laser, distance, a, raw, ret[2], pt);
      pt.channel = static_cast<std::uint16_t>(laser);
      pt.return_type = layout.dual ? dual_return(raw, ret[2], u16(other), other[2]) : single;
      pt.azimuth_deg = static_cast<float>(a) * 0.01f;
      pt.elevation_deg = geometry.elevation_deg(laser);
      pt.distance_m = distance;
      pt.time_s = static_cast<double>(t - s.first_ns) * 1e-9;
      s.sweep.points.push_back(pt);
    }
  }
  if (next_.fired) {
    emit(current_, out, counts);
    current_ = std::move(next_);
    next_ = OpenSweep{};
    sweep_end_ += kTurn;
  }
}

}  // namespace pl::lidar
