// Hesai packets -> sweeps: PandarXT16, XT32, XT32M, QT64, QT128, Pandar40P and Pandar64.
//
// The packets name their model (hesai_packet.hpp); the sensor's angle file gives each laser's
// elevation and azimuth offset (hesai_calibration.hpp); firing times come from the manuals
// (hesai_firing.hpp); sweeps are cut channel by channel (hesai_sweeps.hpp).
// Sweep::stamp_ns is the sensor's clock (the packet tail's UTC date and microseconds) at the sweep's
// earliest firing, not the packet's receive time. Points are in the makers' driver frame: azimuth
// clockwise from +y, x = r cos(el) sin(az), y = r cos(el) cos(az), z = r sin(el).
// Multi-return firings keep each distinct return once: of two identical returns, or of two within
// 0.1 m of each other, the later block's is kept (as the makers' driver does).
#include <algorithm>
#include <cmath>
#include <numeric>
#include <optional>

#include "decoders.hpp"
#include "hesai_calibration.hpp"
#include "hesai_firing.hpp"
#include "hesai_packet.hpp"
#include "hesai_sweeps.hpp"
#include "pl/common/error.hpp"
#include "pl/common/text.hpp"

namespace pl::lidar {
namespace {

constexpr double kSameTargetM = 0.1;  // returns of one firing nearer than this are one target
constexpr double kDegToRad = 3.14159265358979323846 / 180.0;

struct SinCos {
  double sin = 0, cos = 1;
};

// sin and cos of every packet azimuth (hundredths of a degree).
const std::vector<SinCos>& azimuth_table() {
  static const std::vector<SinCos> table = [] {
    std::vector<SinCos> t(36000);
    for (std::size_t i = 0; i < t.size(); ++i) t[i] = {std::sin(i * 0.01 * kDegToRad), std::cos(i * 0.01 * kDegToRad)};
    return t;
  }();
  return table;
}

class HesaiDecoder final : public PacketDecoder {
 public:
  explicit HesaiDecoder(const DecoderOptions& options)
      : options_(options), calibration_(load_hesai_calibration(options)) {
    if (options.model.empty()) return;
    const HesaiLayout* layout = find_hesai_layout(options.model);
    if (!layout) throw Error("Hesai model '" + options.model + "' is none of " + hesai_model_names());
    use(*layout);
  }

  void add(std::string_view packet, std::int64_t /*stamp_ns: the sensor's clock is used*/,
           std::vector<Sweep>& out) override {
    ++counts_.packets;
    const std::size_t before = out.size();
    std::string problem;
    const HesaiLayout* layout = layout_ ? layout_ : identify_hesai_packet(packet, problem);
    HesaiPacket p;
    if (!layout || !read_hesai_packet(*layout, packet, p, problem)) {
      ++counts_.skipped;
      counts_.last_problem = problem;
      return;
    }
    if (!layout_) use(*layout);
    if (p.motor_rpm > 0) rotation_hz_ = p.motor_rpm / 60.0;
    decode(p, out);
    count(out, before);
  }

  void finish(std::vector<Sweep>& out) override {
    const std::size_t before = out.size();
    if (cutter_) cutter_->finish(out);
    count(out, before);
  }

  SensorInfo info() const override {
    SensorInfo s;
    s.vendor = "Hesai";
    s.model = layout_ ? layout_->name : "";
    s.channels = layout_ ? layout_->channels : calibration_.channels();
    s.rotation_hz = rotation_hz_;
    s.elevation_deg = calibration_.elevation_deg;
    s.elevation_deg.resize(static_cast<std::size_t>(s.channels), 0.0);
    std::vector<std::uint16_t> order(s.elevation_deg.size());
    std::iota(order.begin(), order.end(), std::uint16_t{0});
    std::stable_sort(order.begin(), order.end(),
                     [&](std::uint16_t a, std::uint16_t b) { return s.elevation_deg[a] < s.elevation_deg[b]; });
    s.ring_of_channel.resize(order.size());
    for (std::size_t rank = 0; rank < order.size(); ++rank) s.ring_of_channel[order[rank]] = static_cast<std::uint16_t>(rank);
    return s;
  }

 private:
  // The model is known: check that the calibration fits it and table its angles.
  void use(const HesaiLayout& layout) {
    const std::string name = layout.name;
    if (calibration_.channels() == 0)
      throw Error(name + " packets need the sensor's angle calibration: pass --lidar-calibration " + name +
                  ".csv (the maker's angle-correction file of that sensor: laser id, elevation, azimuth)");
    if (calibration_.channels() != layout.channels)
      throw Error(format_text("%s packets have %d channels, but %s has %d lasers: pass the %s's own angle file "
                              "(--lidar-calibration)", layout.name, layout.channels, calibration_.source.c_str(),
                              calibration_.channels(), layout.name));
    layout_ = &layout;
    const std::size_t n = static_cast<std::size_t>(layout.channels);
    elevation_.resize(n);
    offset_.resize(n);
    for (std::size_t c = 0; c < n; ++c) {
      elevation_[c] = {std::sin(calibration_.elevation_deg[c] * kDegToRad), std::cos(calibration_.elevation_deg[c] * kDegToRad)};
      offset_[c] = {std::sin(calibration_.azimuth_offset_deg[c] * kDegToRad),
                    std::cos(calibration_.azimuth_offset_deg[c] * kDegToRad)};
    }
    round_deg_.resize(n);
    firing_.emplace(layout);
    cutter_.emplace(layout.channels, options_.cut_azimuth_deg);
    min_m_ = std::max(layout.min_range_m, options_.min_range_m);
    max_m_ = std::min(layout.max_range_m, options_.max_range_m);
  }

  void decode(const HesaiPacket& p, std::vector<Sweep>& out) {
    const std::vector<std::int32_t>& offsets = firing_->offsets(p);
    const std::vector<SinCos>& block_trig = azimuth_table();
    const int channels = layout_->channels;
    for (int first = 0; first < layout_->blocks; first += p.returns) {
      const std::uint16_t azimuth = p.azimuth_cdeg(first);
      for (int c = 0; c < channels; ++c)
        round_deg_[static_cast<std::size_t>(c)] = wrap_degrees(azimuth * 0.01 + calibration_.azimuth_offset_deg[static_cast<std::size_t>(c)]);
      cutter_->step(round_deg_, p.time_ns + firing_->earliest(p, first), out);
      const SinCos& b = block_trig[azimuth];
      for (int c = 0; c < channels; ++c) {
        const SinCos& o = offset_[static_cast<std::size_t>(c)];
        const SinCos& e = elevation_[static_cast<std::size_t>(c)];
        const double sin_az = b.sin * o.cos + b.cos * o.sin, cos_az = b.cos * o.cos - b.sin * o.sin;
        Sweep& sweep = cutter_->sweep_of(c);
        for (int r = 0; r < p.returns; ++r) {
          const int block = first + r;
          const std::uint16_t raw = p.distance(block, c);
          const float d = static_cast<float>(raw * p.unit_m);
          if (raw == 0 || d < min_m_ || d > max_m_) continue;
          const ReturnType type = return_type(p, first, c, r);
          if (r != p.returns - 1 && (type == ReturnType::Identical || near_another_return(p, first, c, r, d))) continue;
          Point& pt = sweep.points.emplace_back();
          pt.x = static_cast<float>(d * e.cos * sin_az);
          pt.y = static_cast<float>(d * e.cos * cos_az);
          pt.z = static_cast<float>(d * e.sin);
          pt.intensity = p.reflectivity(block, c);
          pt.channel = static_cast<std::uint16_t>(c);
          pt.return_type = type;
          pt.azimuth_deg = static_cast<float>(round_deg_[static_cast<std::size_t>(c)]);
          pt.elevation_deg = static_cast<float>(calibration_.elevation_deg[static_cast<std::size_t>(c)]);
          pt.distance_m = d;
          const std::int64_t t = p.time_ns + offsets[static_cast<std::size_t>(block * channels + c)] - sweep.stamp_ns;
          pt.time_s = static_cast<double>(t) * 1e-9;
        }
      }
    }
  }

  bool near_another_return(const HesaiPacket& p, int first, int channel, int r, float d) const {
    for (int o = 0; o < p.returns; ++o) {
      if (o == r) continue;
      const float other = static_cast<float>(p.distance(first + o, channel) * p.unit_m);
      if (std::fabs(other - d) < kSameTargetM) return true;
    }
    return false;
  }

  // What return `r` of a firing is, from the packet's return mode (the manuals' "Return Mode" table).
  ReturnType return_type(const HesaiPacket& p, int first, int channel, int r) const {
    bool strongest = true;
    for (int o = 0; o < p.returns; ++o) {
      if (o == r) continue;
      const std::uint16_t dist = p.distance(first + o, channel);
      const std::uint8_t refl = p.reflectivity(first + o, channel);
      if (dist == p.distance(first + r, channel) && refl == p.reflectivity(first + r, channel)) return ReturnType::Identical;
      strongest = strongest && p.reflectivity(first + r, channel) >= refl;
    }
    const bool first_block = r == 0;
    switch (p.return_mode) {
      case 0x33: return ReturnType::First;
      case 0x34: return ReturnType::Second;
      case 0x37: return ReturnType::Strongest;
      case 0x38: return ReturnType::Last;
      case 0x39:  // last, strongest (or second strongest when the last is the strongest)
        if (strongest) return first_block ? ReturnType::LastStrong : ReturnType::Strongest;
        return first_block ? ReturnType::Last : ReturnType::SecondStrongest;
      case 0x3a: return first_block ? ReturnType::First : ReturnType::Second;
      case 0x3b: {  // first, last; the XT16 and XT32 send the last return first
        const bool swapped = layout_->model == HesaiModel::PandarXT16 || layout_->model == HesaiModel::PandarXT32;
        return first_block != swapped ? ReturnType::First : ReturnType::Last;
      }
      case 0x3c:  // first, strongest (or second strongest when the first is the strongest)
        if (strongest) return first_block ? ReturnType::FirstStrong : ReturnType::Strongest;
        return first_block ? ReturnType::First : ReturnType::SecondStrongest;
      case 0x3e: return first_block ? ReturnType::Strongest : ReturnType::SecondStrongest;
      case 0x3d: return r == 0 ? ReturnType::First : r == 1 ? ReturnType::Last : ReturnType::Strongest;
      default: return ReturnType::Unknown;
    }
  }

  void count(const std::vector<Sweep>& out, std::size_t before) {
    for (std::size_t i = before; i < out.size(); ++i) {
      ++counts_.sweeps;
      counts_.points += out[i].points.size();
    }
  }

  DecoderOptions options_;
  HesaiCalibration calibration_;
  const HesaiLayout* layout_ = nullptr;
  std::vector<SinCos> elevation_, offset_;  // by channel
  std::vector<double> round_deg_;           // the current round's azimuth of each channel
  std::optional<HesaiFiringTable> firing_;
  std::optional<HesaiSweepCutter> cutter_;
  double min_m_ = 0, max_m_ = 0;
  double rotation_hz_ = 0;
};

}  // namespace

std::unique_ptr<PacketDecoder> make_hesai_decoder(const DecoderOptions& options) {
  return std::make_unique<HesaiDecoder>(options);
}

}  // namespace pl::lidar
