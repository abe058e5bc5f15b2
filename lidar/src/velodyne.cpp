// Velodyne packets -> sweeps (make_decoder(Vendor::Velodyne)): VLP-16 (and Hi-Res), VLP-32C, HDL-32E,
// HDL-64E S2/S3 and VLS-128, single and dual return.
//
// Parts, each in its own file: the models and their packet layouts (velodyne_model), the calibration
// YAML (velodyne_calibration), the packet's time (velodyne_clock), a return to a point
// (velodyne_geometry), firings to sweeps (velodyne_sweep). Here: telling the model and checking a
// packet against it.
//
// The model is told by the packet's product id (factory byte 1205); the HDL-64E sends none, so its
// model comes from DecoderOptions::model. Each firing's azimuth is its block's plus its share of the
// step to the next column (by its firing time); a sweep holds every firing from one crossing of
// cut_azimuth_deg by that azimuth to the next. Sweep::stamp_ns is the time of its first firing by the
// sensor's clock (UTC when the sensor is synchronised, else anchored to the receive stamps: see
// velodyne_clock.hpp); a point's time_s is its firing's time after that, from the model's firing table.
#include <optional>

#include "decoders.hpp"
#include "pl/common/error.hpp"
#include "pl/common/text.hpp"
#include "velodyne_calibration.hpp"
#include "velodyne_clock.hpp"
#include "velodyne_geometry.hpp"
#include "velodyne_model.hpp"
#include "velodyne_sweep.hpp"

namespace pl::lidar {
namespace {

constexpr double kTurn = 36000;  // azimuth steps of 0.01 degree in a turn

std::uint16_t u16(const std::uint8_t* p) { return static_cast<std::uint16_t>(p[0] | p[1] << 8); }
std::uint32_t u32(const std::uint8_t* p) {
  return static_cast<std::uint32_t>(p[0]) | static_cast<std::uint32_t>(p[1]) << 8 |
         static_cast<std::uint32_t>(p[2]) << 16 | static_cast<std::uint32_t>(p[3]) << 24;
}
const std::uint8_t* block_at(const std::uint8_t* packet, int b) { return packet + 100 * b; }

bool known_flag(std::uint16_t f) { return f == 0xEEFF || f == 0xDDFF || f == 0xCCFF || f == 0xBBFF; }

// What a packet says of itself once checked.
struct PacketFacts {
  bool dual = false;
  ReturnType single = ReturnType::Unknown;  // the return of single-return packets
  std::uint32_t toh_us = 0;
};

class VelodyneDecoder final : public PacketDecoder {
 public:
  explicit VelodyneDecoder(const DecoderOptions& options) : sweeper_(options) {
    calibration_ = load_velodyne_calibration(options);
    if (options.model.empty()) return;
    const VelodyneModel* m = velodyne_model_by_name(options.model);
    if (!m)
      throw Error("lidar decoder: \"" + options.model + "\" is no Velodyne model decoded here: one of " +
                  velodyne_model_names());
    lock(*m);
  }

  void add(std::string_view packet, std::int64_t stamp_ns, std::vector<Sweep>& out) override {
    ++counts_.packets;
    if (packet.size() != kVelodynePacketBytes)
      return skip(format_text("%zu bytes, not the 1206 of a Velodyne data packet", packet.size()));
    const auto* p = reinterpret_cast<const std::uint8_t*>(packet.data());
    if (!model_) {
      const VelodyneModel* m = identify(p);
      if (!m) return;
      lock(*m);
    }
    PacketFacts facts;
    std::string problem;
    if (!check(p, facts, problem)) return skip(problem);
    sweeper_.add(p, layouts_[facts.dual], facts.single, clock_.packet_ns(facts.toh_us, stamp_ns), *geometry_, out,
                 counts_);
  }

  void finish(std::vector<Sweep>& out) override { sweeper_.finish(out, counts_); }

  SensorInfo info() const override {
    SensorInfo s;
    s.vendor = "Velodyne";
    if (!model_) return s;
    s.model = model_->name;
    s.channels = model_->channels;
    s.rotation_hz = sweeper_.rate() * 1e6 / kTurn;
    for (int l = 0; l < model_->channels; ++l) s.elevation_deg.push_back(geometry_->elevation_deg(l));
    s.ring_of_channel = rings_;
    return s;
  }

 private:
  void lock(const VelodyneModel& m) {
    const std::size_t n = calibration_.lasers.size();
    if (n == 0)
      throw Error(std::string(m.name) + " packets need the sensor's calibration: pass --lidar-calibration " +
                  m.calibration_file + " (its maker's file)");
    if (n != static_cast<std::size_t>(m.channels))
      throw Error(calibration_.source + ": " + std::to_string(n) + " lasers, but " + m.name + " packets carry " +
                  std::to_string(m.channels) + ": pass this sensor's calibration (its maker's " +
                  m.calibration_file + ")");
    model_ = &m;
    geometry_.emplace(calibration_, m.distance_unit_m);
    layouts_[0] = velodyne_layout(m, false);
    layouts_[1] = velodyne_layout(m, true);
    rings_ = velodyne_rings(calibration_);
  }

  void skip(std::string problem) {
    ++counts_.skipped;
    counts_.last_problem = std::move(problem);
  }

  // The model a packet names; nullptr (the packet skipped) when it is not a Velodyne data packet.
  const VelodyneModel* identify(const std::uint8_t* p) {
    const std::uint8_t product = p[kVelodyneProductOffset];
    if (const VelodyneModel* m = velodyne_model_by_product(product)) return m;
    for (int b = 0; b < kVelodyneBlocks; ++b) {
      const std::uint8_t* block = block_at(p, b);
      if (!known_flag(u16(block)) || u16(block + 2) >= kTurn) {
        skip(format_text("block %d: flag 0x%04X, azimuth %u: not a Velodyne data packet", b, u16(block),
                         u16(block + 2)));
        return nullptr;
      }
    }
    if (const char* other = velodyne_other_product(product))
      throw Error(format_text("%s packets (product id 0x%02X) are not decoded here; Velodyne models decoded: %s",
                              other, product, velodyne_model_names().c_str()));
    throw Error(format_text("Velodyne packets whose product id (byte 1205 = 0x%02X) names no model: set the "
                            "model (HDL-64E S2, HDL-64E S3, or HDL-32E of firmware before 2.2.20)",
                            product));
  }

  bool check(const std::uint8_t* p, PacketFacts& facts, std::string& problem) const {
    const std::uint8_t product = p[kVelodyneProductOffset], mode = p[kVelodyneReturnModeOffset];
    const bool hdl64e = model_->product_id == 0;
    const bool old_hdl32e = model_->family == VelodyneFamily::Hdl32E && product == 0 && mode == 0;
    if (!hdl64e && product != model_->product_id && !old_hdl32e) {
      const VelodyneModel* other = velodyne_model_by_product(product);
      problem = other ? format_text("a %s packet (product id 0x%02X) among %s packets", other->name, product,
                                    model_->name)
                      : format_text("product id 0x%02X is not the %s's 0x%02X", product, model_->name,
                                    model_->product_id);
      return false;
    }
    if (hdl64e) {
      facts.dual = u16(block_at(p, 0) + 2) == u16(block_at(p, 2) + 2);
    } else if (!old_hdl32e) {
      if (mode != kVelodyneStrongest && mode != kVelodyneLast && mode != kVelodyneDual) {
        problem = format_text("return mode 0x%02X is none of 0x37 (strongest), 0x38 (last), 0x39 (dual)", mode);
        return false;
      }
      facts.dual = mode == kVelodyneDual;
      facts.single = mode == kVelodyneLast ? ReturnType::Last : ReturnType::Strongest;
    }
    facts.toh_us = u32(p + kVelodyneTimeOffset);
    if (facts.toh_us >= 3'600'000'000u) {
      problem = format_text("time stamp %u us is past an hour", facts.toh_us);
      return false;
    }
    const VelodyneLayout& layout = layouts_[facts.dual];
    for (int b = 0; b < kVelodyneBlocks; ++b) {
      if (!layout.blocks[b].used) continue;
      const std::uint8_t* block = block_at(p, b);
      if (u16(block) != layout.blocks[b].flag) {
        problem = format_text("block %d: flag 0x%04X, expected 0x%04X", b, u16(block), layout.blocks[b].flag);
        return false;
      }
      if (u16(block + 2) >= kTurn) {
        problem = format_text("block %d: azimuth %u is past 35999", b, u16(block + 2));
        return false;
      }
    }
    return true;
  }

  VelodyneCalibration calibration_;
  const VelodyneModel* model_ = nullptr;
  std::optional<VelodyneGeometry> geometry_;
  VelodyneLayout layouts_[2];
  std::vector<std::uint16_t> rings_;
  VelodyneClock clock_;

  VelodyneSweeper sweeper_;
};

}  // namespace

std::unique_ptr<PacketDecoder> make_velodyne_decoder(const DecoderOptions& options) {
  return std::make_unique<VelodyneDecoder>(options);
}

}  // namespace pl::lidar
