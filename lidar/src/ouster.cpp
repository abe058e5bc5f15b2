// Ouster OS-0 / OS-1 / OS-2 lidar packets -> sweeps, one per frame as the Ouster SDK batches them.
//   A frame is the packets of one frame id: it ends when every packet of its column window has come
// (emitted at once) or when a packet of another frame (or another initialization) comes; a late
// packet of a frame already ended is skipped. cut_azimuth_deg is not used: the sensor cuts its
// frames itself, at encoder angle 0 (facing its connector).
//   Points: channel = the pixel row (0 = the top beam, as ouster_ros's "ring"); intensity = the
// calibrated reflectivity (0-255: every profile has it and it does not fall with range; ouster_ros's
// "intensity" is the signal photon count, 16 bits, which the low-data profile does not send); x y z
// in the sensor frame as the SDK's XYZ table gives them (ouster_geometry.hpp); time_s from the
// column's timestamp.
//   Sweep::stamp_ns = the timestamp of the frame's earliest column when the sensor's clock is an
// epoch time (PTP or GPS synchronised: after 2001-09-09), else the receive time of the packet that
// carried it (an unsynchronised sensor counts from its power-up).
#include <algorithm>
#include <fstream>
#include <sstream>

#include "decoders.hpp"
#include "ouster_geometry.hpp"
#include "ouster_packet.hpp"
#include "pl/common/error.hpp"

namespace pl::lidar {

namespace {

using namespace ouster;

constexpr std::uint64_t kEpochClockNs = 1'000'000'000'000'000'000ull;  // 2001-09-09: below, a clock since power-up
constexpr int kStaleFrames = 16;  // a frame id at most this many behind the current one is a late packet

std::string metadata_text(const DecoderOptions& o, std::string& name) {
  if (!o.calibration_text.empty()) {
    name = "Ouster metadata text";
    return o.calibration_text;
  }
  if (o.calibration_path.empty())
    throw Error("Ouster packets need the sensor's metadata: pass --lidar-calibration METADATA.json (the JSON the "
                "sensor, ouster_ros or the Ouster SDK wrote beside the recording; an ouster_ros bag carries it on "
                "its metadata topic)");
  name = o.calibration_path;
  std::ifstream in(o.calibration_path, std::ios::binary);
  if (!in) throw Error(o.calibration_path + ": cannot read the Ouster metadata (--lidar-calibration)");
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// The model: the metadata's product line; else the one the options name; else the beams alone.
std::string model_of(const Metadata& m, const std::string& wanted, const std::string& name) {
  if (!m.prod_line.empty()) {
    if (!wanted.empty() && m.prod_line.rfind(wanted, 0) != 0 && wanted.rfind(m.prod_line, 0) != 0)
      throw Error(name + ": the metadata is of an " + m.prod_line + ", not an " + wanted + " (--model)");
    return m.prod_line;
  }
  if (!wanted.empty()) {
    const int beams = beams_of(wanted);
    if (wanted.rfind("OS-", 0) != 0 || (beams && beams != m.pixels_per_column))
      throw Error(name + ": the metadata describes an Ouster sensor of " + std::to_string(m.pixels_per_column) +
                  " beams, not an " + wanted + " (--model)");
    return wanted;
  }
  return "OS-?-" + std::to_string(m.pixels_per_column);
}

class OusterDecoder final : public PacketDecoder {
 public:
  OusterDecoder(const DecoderOptions& o, const std::string& name, const Metadata& m)
      : o_(o), m_(m), layout_(m.profile, m.pixels_per_column, m.columns_per_packet), geometry_(m) {
    if (layout_.packet_size() > 65507)
      throw Error(name + ": pixels_per_column " + std::to_string(m.pixels_per_column) + " and columns_per_packet " +
                  std::to_string(m.columns_per_packet) + " make " + std::to_string(layout_.packet_size()) + "-byte " +
                  profile_name(m.profile) + " packets, more than a UDP datagram holds");
    info_.vendor = "Ouster";
    info_.model = model_of(m, o.model, name);
    info_.channels = m.pixels_per_column;
    info_.rotation_hz = m.fps;
    info_.elevation_deg = m.beam_altitude_deg;
    std::vector<std::uint16_t> order(m.beam_altitude_deg.size());
    for (std::size_t i = 0; i < order.size(); ++i) order[i] = static_cast<std::uint16_t>(i);
    std::stable_sort(order.begin(), order.end(), [&](std::uint16_t a, std::uint16_t b) {
      return m.beam_altitude_deg[a] < m.beam_altitude_deg[b] || (m.beam_altitude_deg[a] == m.beam_altitude_deg[b] && a > b);
    });
    info_.ring_of_channel.resize(order.size());
    for (std::size_t r = 0; r < order.size(); ++r) info_.ring_of_channel[order[r]] = static_cast<std::uint16_t>(r);

    const auto cpp = static_cast<std::size_t>(m.columns_per_packet);
    const auto w = static_cast<std::size_t>(m.columns_per_frame);
    wanted_slot_.assign((w + cpp - 1) / cpp, 0);
    for (std::size_t c = 0; c < w; ++c)
      if (in_window(static_cast<int>(c))) wanted_slot_[c / cpp] = 1;
    slots_wanted_ = static_cast<int>(std::count(wanted_slot_.begin(), wanted_slot_.end(), 1));
    column_ts_.assign(w, 0);
    if (m.profile == Profile::Dual) {
      if (m.return_order == ReturnOrder::NearestFirst) return_types_ = {ReturnType::First, ReturnType::Second};
      else if (m.return_order == ReturnOrder::FarthestFirst) return_types_ = {ReturnType::Last, ReturnType::Unknown};
      else return_types_ = {ReturnType::Strongest, ReturnType::SecondStrongest};
    }
  }

  void add(std::string_view packet, std::int64_t stamp_ns, std::vector<Sweep>& out) override {
    ++counts_.packets;
    const auto* p = reinterpret_cast<const std::uint8_t*>(packet.data());
    if (!well_formed(packet)) return;
    const std::uint16_t fid = layout_.frame_id(p);
    const std::uint32_t init = layout_.init_id(p);
    if (open_) {
      if (fid != frame_id_ || init != init_id_) {
        if (init == init_id_ && behind(fid, frame_id_)) return skip(late(fid));
        close_frame(out);
      }
    } else if (ended_ && init == init_id_ && (fid == frame_id_ || behind(fid, frame_id_))) {
      return skip(late(fid));
    }
    if (!open_) start_frame(fid, init);

    const std::size_t slot = layout_.column_header(layout_.column(p, 0)).measurement_id / layout_.columns();
    if (slot_seen_[slot]) return skip("a second packet for columns from " + std::to_string(slot * layout_.columns()) +
                                      " of frame " + std::to_string(fid));
    slot_seen_[slot] = 1;
    for (std::size_t i = 0; i < layout_.columns(); ++i) add_column(layout_.column(p, i), stamp_ns);
    if (wanted_slot_[slot] && --slots_left_ == 0) {
      close_frame(out);
      ended_ = true;
    }
  }

  void finish(std::vector<Sweep>& out) override {
    if (open_) close_frame(out);
  }

  SensorInfo info() const override { return info_; }

 private:
  void skip(const std::string& why) {
    ++counts_.skipped;
    counts_.last_problem = why;
  }

  std::string late(std::uint16_t fid) const {
    return "a late packet of frame " + std::to_string(fid) + " (frame " + std::to_string(frame_id_) +
           (open_ ? " has begun)" : " has ended)");
  }

  static bool behind(std::uint16_t fid, std::uint16_t current) {
    const int d = static_cast<std::uint16_t>(current - fid);
    return d > 0 && d <= kStaleFrames;
  }

  std::size_t beams() const { return static_cast<std::size_t>(m_.pixels_per_column); }

  bool in_window(int c) const {
    const int a = m_.column_window_first, b = m_.column_window_last;
    return a <= b ? (c >= a && c <= b) : (c >= a || c <= b);
  }

  bool well_formed(std::string_view packet) {
    const std::size_t want = layout_.packet_size();
    // Older ouster_ros drivers recorded one byte more than the packet: it is left alone.
    if (packet.size() != want && packet.size() != want + 1) {
      std::string why = std::to_string(packet.size()) + " bytes, not a " + std::to_string(want) + "-byte " +
                        profile_name(m_.profile) + " lidar packet of " + std::to_string(m_.pixels_per_column) +
                        " beams x " + std::to_string(m_.columns_per_packet) + " columns";
      if (packet.size() == 48 || packet.size() == 49) why += " (an IMU packet)";
      for (Profile other : {Profile::Legacy, Profile::Single, Profile::Dual, Profile::LowData}) {
        const std::size_t size = PacketLayout(other, m_.pixels_per_column, m_.columns_per_packet).packet_size();
        if (other != m_.profile && (packet.size() == size || packet.size() == size + 1))
          why += std::string(" (the size of ") + profile_name(other) + " packets: is the metadata's udp_profile_lidar the sensor's?)";
      }
      skip(why);
      return false;
    }
    const auto* p = reinterpret_cast<const std::uint8_t*>(packet.data());
    if (layout_.packet_type(p) != 1) {
      skip("packet type " + std::to_string(layout_.packet_type(p)) + ", not 1 (lidar)");
      return false;
    }
    for (std::size_t i = 0; i < layout_.columns(); ++i) {
      const std::uint16_t id = layout_.column_header(layout_.column(p, i)).measurement_id;
      if (id >= column_ts_.size()) {
        skip("measurement id " + std::to_string(id) + " beyond the frame's " + std::to_string(column_ts_.size()) + " columns");
        return false;
      }
    }
    return true;
  }

  void start_frame(std::uint16_t fid, std::uint32_t init) {
    open_ = true;
    ended_ = false;
    frame_id_ = fid;
    init_id_ = init;
    slot_seen_.assign(wanted_slot_.size(), 0);
    slots_left_ = slots_wanted_;
    earliest_ts_ = UINT64_MAX;
    earliest_receive_ns_ = 0;
    // As many points as the last frame had (before one: a return a pixel, up to 256 Ki points).
    const std::size_t expect = last_size_ ? last_size_ : std::min<std::size_t>(column_ts_.size() * beams(), 1u << 18);
    sweep_.points.clear();
    sweep_.points.reserve(expect);
    point_column_.clear();
    point_column_.reserve(expect);
  }

  void add_column(const std::uint8_t* col, std::int64_t receive_ns) {
    const ColumnHeader h = layout_.column_header(col);
    if (!h.valid) return;
    const std::size_t m = h.measurement_id;
    column_ts_[m] = h.timestamp_ns;
    if (h.timestamp_ns < earliest_ts_) {
      earliest_ts_ = h.timestamp_ns;
      earliest_receive_ns_ = receive_ns;
    }
    Return r[2];
    const int returns = layout_.returns();
    for (std::size_t row = 0; row < static_cast<std::size_t>(m_.pixels_per_column); ++row) {
      layout_.pixel(col, row, r);
      for (int k = 0; k < returns; ++k) {
        if (r[k].range_mm == 0) continue;
        const double d = r[k].range_mm * 1e-3;
        if (d < o_.min_range_m || d > o_.max_range_m) continue;
        const auto xyz = geometry_.point(row, m, r[k].range_mm);
        Point pt;
        pt.x = static_cast<float>(xyz[0]);
        pt.y = static_cast<float>(xyz[1]);
        pt.z = static_cast<float>(xyz[2]);
        pt.intensity = r[k].reflectivity;
        pt.channel = static_cast<std::uint16_t>(row);
        pt.return_type = return_types_[static_cast<std::size_t>(k)];
        pt.azimuth_deg = static_cast<float>(geometry_.azimuth_deg(row, m));
        pt.elevation_deg = static_cast<float>(m_.beam_altitude_deg[row]);
        pt.distance_m = static_cast<float>(d);
        sweep_.points.push_back(pt);
        point_column_.push_back(static_cast<std::uint16_t>(m));
      }
    }
  }

  void close_frame(std::vector<Sweep>& out) {
    open_ = false;
    ended_ = true;
    if (sweep_.points.empty()) return;
    sweep_.stamp_ns = earliest_ts_ >= kEpochClockNs ? static_cast<std::int64_t>(earliest_ts_) : earliest_receive_ns_;
    for (std::size_t i = 0; i < sweep_.points.size(); ++i)
      sweep_.points[i].time_s = static_cast<double>(column_ts_[point_column_[i]] - earliest_ts_) * 1e-9;
    last_size_ = sweep_.points.size();
    ++counts_.sweeps;
    counts_.points += sweep_.points.size();
    out.push_back(std::move(sweep_));
    sweep_ = Sweep{};
  }

  DecoderOptions o_;
  Metadata m_;
  PacketLayout layout_;
  BeamGeometry geometry_;
  SensorInfo info_;
  std::array<ReturnType, 2> return_types_{ReturnType::Strongest, ReturnType::Strongest};
  std::vector<std::uint8_t> wanted_slot_;  // by packet (first measurement id / columns_per_packet): in the window
  int slots_wanted_ = 0;

  // The frame being gathered.
  bool open_ = false;
  bool ended_ = false;  // the last frame (frame_id_) has ended and none is open
  std::uint16_t frame_id_ = 0;
  std::uint32_t init_id_ = 0;
  std::vector<std::uint8_t> slot_seen_;
  int slots_left_ = 0;
  std::vector<std::uint64_t> column_ts_;  // by measurement id
  std::uint64_t earliest_ts_ = 0;
  std::int64_t earliest_receive_ns_ = 0;
  Sweep sweep_;
  std::vector<std::uint16_t> point_column_;  // the measurement id of each point of sweep_
  std::size_t last_size_ = 0;
};

}  // namespace

std::unique_ptr<PacketDecoder> make_ouster_decoder(const DecoderOptions& options) {
  std::string name;
  const std::string text = metadata_text(options, name);
  return std::make_unique<OusterDecoder>(options, name, parse_metadata(text, name));
}

}  // namespace pl::lidar
