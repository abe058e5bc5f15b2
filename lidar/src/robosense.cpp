// RoboSense packets -> sweeps: the RS-LiDAR-16, Helios-16P and Helios-32.
//   The model: an RS-LiDAR-16's MSOP header differs from a Helios's; a Helios-16P and a Helios-32 send
//   the same header, so there the model comes from DecoderOptions::model or the angle file's length.
//   The angles: the angle file when one is given (as in the maker's driver, it wins over the DIFOP's),
//   else the DIFOP packet's table. Without a file, MSOP packets are held until a DIFOP packet brings
//   the angles, then decoded; none in kHoldPackets (2.6 s or more), or none by finish(), is a
//   pl::Error naming the fix. The return mode and rotation rate come from the DIFOP packets too: until
//   the first, single return (strongest) at 600 rpm, as the maker's driver assumes.
//   Sweeps end where a block's azimuth passes cut_azimuth_deg (the maker's driver's rule);
//   Sweep::stamp_ns is the sensor's time of the sweep's first block (the MSOP header's clock; the
//   receive time only where an RS-LiDAR-16's calendar time is no date).
#include <cmath>
#include <cstring>
#include <fstream>
#include <numeric>
#include <optional>
#include <sstream>
#include <utility>

#include "decoders.hpp"
#include "pl/common/error.hpp"
#include "robosense_calibration.hpp"
#include "robosense_msop.hpp"

namespace pl::lidar {
namespace {

using namespace robosense;

std::string read_text(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path + ": cannot read the RoboSense angle file");
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

class RoboSenseDecoder final : public PacketDecoder {
 public:
  explicit RoboSenseDecoder(const DecoderOptions& o);
  void add(std::string_view packet, std::int64_t stamp_ns, std::vector<Sweep>& out) override;
  void finish(std::vector<Sweep>& out) override;
  SensorInfo info() const override;

 private:
  static constexpr std::size_t kHoldPackets = 4000;  // MSOP packets: 2.6 s at the fastest rate (1500 a second)
  void skip(const char* why);
  void learn_model(Family f);
  void take_difop(std::string_view p);
  void start(std::vector<Sweep>& out);
  void decode(std::string_view p, std::int64_t stamp_ns, std::vector<Sweep>& out);
  void close_sweep(std::vector<Sweep>& out);
  [[noreturn]] void no_angles() const;

  DecoderOptions opt_;
  std::string angle_file_;  // its name in errors
  std::optional<Angles> file_angles_;
  const Model* model_ = nullptr;
  std::string early_difop_;       // one that came before the model was known
  std::optional<Difop> difop_;    // the latest
  std::optional<Angles> angles_;  // in use
  bool holding_ = true;           // MSOP packets, until the model and its angles are known
  std::vector<std::pair<std::string, std::int64_t>> held_;
  Geometry geometry_;
  DecodedPacket packet_;
  Sweep sweep_;
  bool sweep_open_ = false;
  int cut_ = 0;  // 0.01°
  int prev_azimuth_ = 0;
  std::int64_t last_stamp_ = 0;
  double measured_hz_ = 0;
  std::size_t last_points_ = 0;  // of the last sweep: the next one's reserve
};

RoboSenseDecoder::RoboSenseDecoder(const DecoderOptions& o) : opt_(o) {
  cut_ = static_cast<int>(std::lround(o.cut_azimuth_deg * 100)) % 36000;
  prev_azimuth_ = cut_;
  if (!o.model.empty()) {
    model_ = find_model(o.model);
    if (!model_) throw Error("RoboSense model \"" + o.model + "\" is not one this decoder knows (" + model_names() + ")");
  }
  if (o.calibration_text.empty() && o.calibration_path.empty()) return;
  angle_file_ = o.calibration_path.empty() ? "the RoboSense angle text" : o.calibration_path;
  file_angles_ = parse_angle_file(o.calibration_text.empty() ? read_text(o.calibration_path) : o.calibration_text, angle_file_);
  const std::size_t n = file_angles_->elevation_deg.size();
  if (n != 16 && n != 32)
    fail_at(angle_file_, 0, "one line a laser: 16 (RS-LiDAR-16, Helios-16P) or 32 (Helios-32)", std::to_string(n) + " lines");
  if (model_ && n != static_cast<std::size_t>(model_->lasers))
    fail_at(angle_file_, 0,
            "one line a laser of the " + std::string(model_->name) + ": " + std::to_string(model_->lasers) + " lines",
            std::to_string(n) + " lines");
  if (model_) angles_ = file_angles_;
}

void RoboSenseDecoder::skip(const char* why) {
  ++counts_.skipped;
  counts_.last_problem = why;
}

// From the first MSOP packet's header (and the angle file's length, for a Helios).
void RoboSenseDecoder::learn_model(Family f) {
  if (model_) return;
  std::size_t lasers = 16;
  if (f == Family::Helios) {
    if (!file_angles_)
      throw Error(
          "RoboSense Helios packets do not tell a Helios-16P from a Helios-32: give the model (--lidar-model Helios-16P or Helios-32) "
          "or the sensor's angle file (--lidar-calibration angle.csv, 16 or 32 lines)");
    lasers = file_angles_->elevation_deg.size();
  } else if (file_angles_ && file_angles_->elevation_deg.size() != 16) {
    fail_at(angle_file_, 0, "one line a laser of the RS-LiDAR-16 the packets come from: 16 lines",
            std::to_string(file_angles_->elevation_deg.size()) + " lines");
  }
  model_ = &model_for(f, static_cast<int>(lasers));
  if (file_angles_) angles_ = file_angles_;
  if (!early_difop_.empty()) take_difop(early_difop_);
  early_difop_.clear();
}

void RoboSenseDecoder::take_difop(std::string_view p) {
  if (!model_) {
    early_difop_.assign(p);
    return;
  }
  Difop d = read_difop(p, *model_);
  if (!angles_ && d.angles) angles_ = std::move(d.angles);
  const bool changed = !difop_ || difop_->rpm != d.rpm || difop_->return_mode != d.return_mode;
  difop_ = std::move(d);
  if (changed && !holding_)
    geometry_ = make_geometry(*model_, *angles_, return_mode(model_->family, difop_->return_mode), difop_->rpm, opt_.min_range_m,
                              opt_.max_range_m);
}

// The angles are known: decode what was held.
void RoboSenseDecoder::start(std::vector<Sweep>& out) {
  holding_ = false;
  const ReturnMode mode = difop_ ? return_mode(model_->family, difop_->return_mode) : ReturnMode{};
  geometry_ = make_geometry(*model_, *angles_, mode, difop_ ? difop_->rpm : 600, opt_.min_range_m, opt_.max_range_m);
  for (const auto& [p, stamp] : held_) decode(p, stamp, out);
  held_.clear();
  held_.shrink_to_fit();
}

void RoboSenseDecoder::add(std::string_view packet, std::int64_t stamp_ns, std::vector<Sweep>& out) {
  ++counts_.packets;
  if (packet.size() != kPacketBytes) return skip("not a RoboSense packet (MSOP and DIFOP packets are 1248 bytes)");
  const auto* b = reinterpret_cast<const unsigned char*>(packet.data());
  if (std::memcmp(b, kDifopMagic, sizeof kDifopMagic) == 0) {
    take_difop(packet);
    if (holding_ && model_ && angles_) start(out);
    return;
  }
  Family f;
  if (std::memcmp(b, kRs16Magic, sizeof kRs16Magic) == 0)
    f = Family::Rs16;
  else if (std::memcmp(b, kHeliosMagic, sizeof kHeliosMagic) == 0)
    f = Family::Helios;
  else
    return skip("not a RoboSense MSOP or DIFOP packet (its first bytes are neither header)");
  learn_model(f);
  if (f != model_->family)
    return skip(f == Family::Rs16 ? "an RS-LiDAR-16 MSOP packet among Helios packets"
                                  : "a Helios MSOP packet among RS-LiDAR-16 packets");
  if (const char* why = check_msop(packet, *model_)) return skip(why);
  if (holding_ && angles_) start(out);
  if (!holding_) return decode(packet, stamp_ns, out);
  held_.emplace_back(std::string(packet), stamp_ns);
  if (held_.size() >= kHoldPackets) no_angles();
}

void RoboSenseDecoder::decode(std::string_view p, std::int64_t stamp_ns, std::vector<Sweep>& out) {
  decode_msop(p, stamp_ns, geometry_, packet_);
  for (std::size_t k = 0; k < kBlocks; ++k) {
    const int a = packet_.azimuth[k];
    const int prev = a < prev_azimuth_ ? prev_azimuth_ - 36000 : prev_azimuth_;
    prev_azimuth_ = a;
    if (sweep_open_ && prev < cut_ && cut_ <= a) close_sweep(out);
    if (!sweep_open_) {
      sweep_ = Sweep{};
      sweep_.points.reserve(last_points_);
      sweep_.stamp_ns = packet_.time_ns[k];
      sweep_open_ = true;
    }
    for (std::size_t i = packet_.first_point[k]; i < packet_.first_point[k + 1]; ++i) {
      Point pt = packet_.points[i];
      pt.time_s = static_cast<double>(packet_.point_ns[i] - sweep_.stamp_ns) * 1e-9;
      sweep_.points.push_back(pt);
    }
  }
}

void RoboSenseDecoder::close_sweep(std::vector<Sweep>& out) {
  sweep_open_ = false;
  if (sweep_.points.empty()) return;
  if (last_stamp_ != 0 && sweep_.stamp_ns > last_stamp_) measured_hz_ = 1e9 / static_cast<double>(sweep_.stamp_ns - last_stamp_);
  last_stamp_ = sweep_.stamp_ns;
  ++counts_.sweeps;
  counts_.points += sweep_.points.size();
  last_points_ = sweep_.points.size();
  out.push_back(std::move(sweep_));
}

void RoboSenseDecoder::finish(std::vector<Sweep>& out) {
  if (!held_.empty()) no_angles();
  if (sweep_open_) close_sweep(out);
}

void RoboSenseDecoder::no_angles() const {
  const std::string why = difop_ ? "its DIFOP packets carry no angle table" : "no DIFOP packet came with them";
  throw Error("RoboSense " + std::string(model_->name) + " packets need the sensor's laser angles, and " + why + " (" +
              std::to_string(held_.size()) +
              " MSOP packets): record the DIFOP packets too (port 7788) or pass --lidar-calibration " +
              "angle.csv (the maker's angle file: one line a laser, \"elevation,azimuth offset\" in degrees)");
}

SensorInfo RoboSenseDecoder::info() const {
  SensorInfo s;
  s.vendor = "RoboSense";
  if (!model_) return s;
  s.model = std::string(model_->name);
  s.channels = model_->lasers;
  s.rotation_hz = difop_ && difop_->rpm > 0 ? difop_->rpm / 60.0 : measured_hz_;
  if (!angles_) return s;
  const Geometry g = holding_ ? make_geometry(*model_, *angles_, {}, 600, opt_.min_range_m, opt_.max_range_m) : geometry_;
  s.elevation_deg.resize(g.channel.size());
  for (std::size_t l = 0; l < g.channel.size(); ++l) s.elevation_deg[g.channel[l]] = g.elevation_deg[l];
  s.ring_of_channel.resize(g.channel.size());
  std::iota(s.ring_of_channel.begin(), s.ring_of_channel.end(), std::uint16_t{0});  // channels are ranked by elevation
  return s;
}

}  // namespace

std::unique_ptr<PacketDecoder> make_robosense_decoder(const DecoderOptions& options) {
  return std::make_unique<RoboSenseDecoder>(options);
}

}  // namespace pl::lidar
