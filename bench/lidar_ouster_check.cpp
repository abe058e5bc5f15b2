// Do the Ouster captures decode to clouds whose ranges and beam angles agree with their metadata?
// No maker's cloud exists for them, so each point is taken back to its beam: out of the sensor frame
// (lidar_to_sensor), less the beam's origin at its column's encoder angle, then its elevation
// (atan2 of z over the horizontal range) is held against beam_altitude_angles and its azimuth
// against the column's encoder angle + beam_azimuth_angles. The column of a point comes from its
// time: this tool reads the column headers itself (timestamp, measurement id, LEGACY's encoder
// count) and the ranges of each pixel, and reads the metadata itself (both layouts), apart from the
// decoder it checks. Every return the packets hold must come out as a point with that range.
//   bench_lidar_ouster_check CAPTURE[=METADATA[=MODEL]]...
// CAPTURE is a pcap file (METADATA its JSON) or an ouster_ros ROS 1 bag (metadata from its topic).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "pl/common/error.hpp"
#include "pl/lidar/decoder.hpp"
#include "pl/lidar/pcap.hpp"
#include "pl/recordings/bag.hpp"

namespace {

using nlohmann::json;

struct Packet {
  std::string bytes;
  std::int64_t stamp_ns = 0;
};

// What this tool reads of the metadata: enough to find the columns and the beams.
struct Meta {
  std::string profile = "LEGACY";
  std::size_t pixels = 0, columns_per_packet = 16, columns = 0;
  int lidar_port = 0;
  std::vector<double> altitude, azimuth;
  double bx = 0, bz = 0;           // the beam origin's offsets, mm
  double rot[9] = {}, trans[3] = {};  // lidar_to_sensor
  // The packet layout: LEGACY has no packet header, a 16-byte column header and a 4-byte status.
  bool legacy = true;
  std::size_t pixel = 12, column_size = 0, header = 0;
};

const json* look(const json& root, const char* nested, const char* flat, const char* key) {
  for (const char* s : {nested, flat}) {
    if (!s) continue;
    auto it = root.find(s);
    if (it != root.end() && it->contains(key)) return &(*it)[key];
  }
  auto it = root.find(key);
  return it == root.end() ? nullptr : &*it;
}

Meta read_meta(const std::string& text) {
  const json root = json::parse(text);
  Meta m;
  m.altitude = look(root, "beam_intrinsics", nullptr, "beam_altitude_angles")->get<std::vector<double>>();
  m.azimuth = look(root, "beam_intrinsics", nullptr, "beam_azimuth_angles")->get<std::vector<double>>();
  m.pixels = m.altitude.size();
  if (auto* v = look(root, "lidar_data_format", "data_format", "udp_profile_lidar")) m.profile = v->get<std::string>();
  if (auto* v = look(root, "lidar_data_format", "data_format", "columns_per_packet")) m.columns_per_packet = v->get<std::size_t>();
  if (auto* v = look(root, "lidar_data_format", "data_format", "columns_per_frame")) m.columns = v->get<std::size_t>();
  else m.columns = std::stoul(look(root, "config_params", nullptr, "lidar_mode")->get<std::string>());
  if (auto* v = look(root, "config_params", nullptr, "udp_port_lidar")) m.lidar_port = v->get<int>();
  std::string line;
  if (auto* v = look(root, "sensor_info", nullptr, "prod_line")) line = v->get<std::string>();
  double origin = line.rfind("OS-0-", 0) == 0 ? 27.67 : line.rfind("OS-1-", 0) == 0 ? 15.806 : line.rfind("OS-2-", 0) == 0 ? 13.762 : 12.163;
  if (auto* v = look(root, "beam_intrinsics", nullptr, "lidar_origin_to_beam_origin_mm")) origin = v->get<double>();
  m.bx = origin;
  if (auto* v = look(root, "beam_intrinsics", nullptr, "beam_to_lidar_transform")) {
    m.bx = (*v)[3].get<double>();
    m.bz = (*v)[11].get<double>();
  }
  std::vector<double> t = {-1, 0, 0, 0, 0, -1, 0, 0, 0, 0, 1, 36.18, 0, 0, 0, 1};
  if (auto* v = look(root, "lidar_intrinsics", nullptr, "lidar_to_sensor_transform")) t = v->get<std::vector<double>>();
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) m.rot[r * 3 + c] = t[static_cast<std::size_t>(r * 4 + c)];
    m.trans[r] = t[static_cast<std::size_t>(r * 4 + 3)];
  }
  m.legacy = m.profile == "LEGACY";
  m.pixel = m.profile == "RNG19_RFL8_SIG16_NIR16_DUAL" ? 16 : m.profile == "RNG15_RFL8_NIR8" ? 4 : 12;
  m.column_size = (m.legacy ? 20 : 12) + m.pixels * m.pixel;
  m.header = m.legacy ? 0 : 32;
  return m;
}

std::string read_text(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw pl::Error(path + ": cannot read");
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// The packets of a pcap (all UDP; the decoder skips what is not a lidar packet) or of a bag's lidar
// packet topic; a bag's metadata topic fills `meta_text`.
std::vector<Packet> read_capture(const std::string& path, std::string& meta_text, int& port) {
  std::vector<Packet> out;
  if (pl::lidar::is_pcap(path)) {
    auto reader = pl::lidar::PcapReader::open_file(path);
    std::map<int, std::size_t> bytes_by_port;
    std::vector<std::pair<int, Packet>> all;
    for (pl::lidar::UdpDatagram d; reader.next(d);) {
      bytes_by_port[d.destination_port] += d.payload.size();
      all.push_back({d.destination_port, {std::string(d.payload), d.stamp_ns}});
    }
    if (port == 0)  // the metadata does not say: the port of the most bytes
      for (const auto& [p, n] : bytes_by_port)
        if (port == 0 || n > bytes_by_port[port]) port = p;
    for (auto& [p, pk] : all)
      if (p == port) out.push_back(std::move(pk));
    return out;
  }
  auto bag = pl::bag::open(path);
  for (const pl::bag::MessageRef& m : bag->messages()) {
    const pl::bag::Topic& t = bag->topics()[m.topic];
    const std::string_view data = bag->read(m);
    if (data.size() < 4) continue;
    const std::string_view body = data.substr(4);  // a uint8[] or string: its length, then its bytes
    if (t.type == "std_msgs/String" && t.name.find("metadata") != std::string::npos) meta_text = std::string(body);
    if (t.type == "ouster_ros/PacketMsg" && t.name.find("lidar") != std::string::npos) out.push_back({std::string(body), m.time_ns});
  }
  return out;
}

std::uint64_t le(const std::string& b, std::size_t at, int n) {
  std::uint64_t v = 0;
  for (int i = n - 1; i >= 0; --i) v = v << 8 | static_cast<unsigned char>(b[at + static_cast<std::size_t>(i)]);
  return v;
}

struct Column {
  std::size_t m = 0;
  double encoder_deg = 0;
  const std::string* packet = nullptr;
  std::size_t at = 0;  // where the column begins in its packet
};

// The range (mm) of return `k` of pixel `row` of a column, as the packet holds it.
std::uint64_t range_mm(const Column& c, const Meta& meta, std::size_t row, int k) {
  const std::size_t p = c.at + (meta.legacy ? 16 : 12) + row * meta.pixel;
  if (meta.legacy) return le(*c.packet, p, 4) & 0xFFFFF;
  if (meta.pixel == 4) return (le(*c.packet, p, 2) & 0x7FFF) * 8;
  return le(*c.packet, p + static_cast<std::size_t>(4 * k), 4) & 0x7FFFF;
}

// Per frame (in order of first packet): column timestamp -> the column.
std::vector<std::map<std::uint64_t, Column>> columns_of(const std::vector<Packet>& packets, const Meta& meta) {
  std::vector<std::map<std::uint64_t, Column>> frames;
  std::vector<std::uint64_t> ids;
  for (const Packet& p : packets) {
    if (p.bytes.size() < meta.header + meta.columns_per_packet * meta.column_size) continue;
    const std::uint64_t fid = meta.legacy ? le(p.bytes, 10, 2) : le(p.bytes, 2, 2);
    if (ids.empty() || ids.back() != fid) ids.push_back(fid), frames.emplace_back();
    for (std::size_t c = 0; c < meta.columns_per_packet; ++c) {
      const std::size_t at = meta.header + c * meta.column_size;
      const bool valid = meta.legacy ? le(p.bytes, at + meta.column_size - 4, 4) & 1 : le(p.bytes, at + 10, 2) & 1;
      if (!valid) continue;
      Column col;
      col.m = le(p.bytes, at + 8, 2);
      col.encoder_deg = meta.legacy ? le(p.bytes, at + 12, 4) * 360.0 / 90112.0 : 360.0 * col.m / meta.columns;
      col.packet = &p.bytes;
      col.at = at;
      frames.back()[le(p.bytes, at, 8)] = col;
    }
  }
  return frames;
}

// Time to decode a frame in a decoder that has run a while: the capture's packets fed again and
// again, their frame id one more each time; the median of 20 frames after one to warm up.
double steady_decode_ms(const std::vector<Packet>& packets, const Meta& meta, const pl::lidar::DecoderOptions& o) {
  auto decoder = pl::lidar::make_decoder(pl::lidar::Vendor::Ouster, o);
  std::vector<Packet> copy = packets;
  std::vector<double> ms;
  std::vector<pl::lidar::Sweep> sweeps;
  for (int run = 1; run <= 21; ++run) {
    for (Packet& p : copy) {  // the frame id: in each LEGACY column, else in the packet header
      if (p.bytes.size() < meta.header + meta.columns_per_packet * meta.column_size) continue;
      for (std::size_t c = 0; c < (meta.legacy ? meta.columns_per_packet : 1); ++c) {
        const std::size_t at = meta.legacy ? c * meta.column_size + 10 : 2;
        const auto id = static_cast<std::uint16_t>(le(p.bytes, at, 2) + 1);
        p.bytes[at] = static_cast<char>(id & 0xFF);
        p.bytes[at + 1] = static_cast<char>(id >> 8);
      }
    }
    sweeps.clear();
    const auto t0 = std::chrono::steady_clock::now();
    for (const Packet& p : copy) decoder->add(p.bytes, p.stamp_ns, sweeps);
    if (run > 1) ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
  }
  std::nth_element(ms.begin(), ms.begin() + 10, ms.end());
  return ms[10];
}

double wrap180(double a) {
  a = std::fmod(a, 360.0);
  if (a > 180) a -= 360;
  if (a < -180) a += 360;
  return a;
}

void check(const std::string& capture, const std::string& meta_path, const std::string& model) {
  std::string meta_text = meta_path.empty() ? std::string() : read_text(meta_path);
  Meta meta;
  int port = 0;
  if (!meta_text.empty()) port = read_meta(meta_text).lidar_port;
  const std::vector<Packet> packets = read_capture(capture, meta_text, port);
  meta = read_meta(meta_text);

  pl::lidar::DecoderOptions o;
  o.calibration_text = meta_text;
  o.model = model;
  o.min_range_m = 0;
  o.max_range_m = 1000;  // every return the packets hold
  auto decoder = pl::lidar::make_decoder(pl::lidar::Vendor::Ouster, o);
  std::vector<pl::lidar::Sweep> sweeps;
  for (const Packet& p : packets) decoder->add(p.bytes, p.stamp_ns, sweeps);
  decoder->finish(sweeps);
  const double decode_ms = steady_decode_ms(packets, meta, o);
  const auto frames = columns_of(packets, meta);

  std::size_t points = 0, unmatched = 0, other_range = 0, returns = 0;
  double max_elev = 0, max_az = 0, max_az_field = 0, max_range = 0, lo = 1e9, hi = 0;
  std::vector<char> column_seen(meta.columns, 0);
  for (std::size_t s = 0; s < sweeps.size() && s < frames.size(); ++s) {
    const auto& cols = frames[s];
    const std::uint64_t first = cols.begin()->first;
    for (const pl::lidar::Point& p : sweeps[s].points) {
      ++points;
      auto it = cols.find(first + static_cast<std::uint64_t>(std::llround(p.time_s * 1e9)));
      if (it == cols.end()) {
        ++unmatched;
        continue;
      }
      const Column& c = it->second;
      column_seen[c.m] = 1;
      const int k = p.return_type == pl::lidar::ReturnType::SecondStrongest ? 1 : 0;
      if (std::abs(p.distance_m * 1e3 - static_cast<double>(range_mm(c, meta, p.channel, k))) > 0.5) ++other_range;
      // Out of the sensor frame (mm), then less the beam origin at the encoder angle.
      const double q[3] = {p.x * 1e3 - meta.trans[0], p.y * 1e3 - meta.trans[1], p.z * 1e3 - meta.trans[2]};
      double l[3];
      for (int r = 0; r < 3; ++r) l[r] = meta.rot[r] * q[0] + meta.rot[3 + r] * q[1] + meta.rot[6 + r] * q[2];
      const double te = -c.encoder_deg * M_PI / 180.0;
      const double v[3] = {l[0] - std::cos(te) * meta.bx, l[1] - std::sin(te) * meta.bx, l[2] - meta.bz};
      const double elev = std::atan2(v[2], std::hypot(v[0], v[1])) * 180.0 / M_PI;
      const double az_lidar = std::atan2(v[1], v[0]) * 180.0 / M_PI;  // counter-clockwise
      const double beam_az = c.encoder_deg + meta.azimuth[p.channel];  // clockwise
      max_elev = std::max(max_elev, std::abs(elev - meta.altitude[p.channel]));
      max_az = std::max(max_az, std::abs(wrap180(-az_lidar - beam_az)));
      max_az_field = std::max(max_az_field, std::abs(wrap180(p.azimuth_deg - beam_az)));
      const double n = meta.bz != 0 ? std::hypot(meta.bx, meta.bz) : meta.bx;
      const double along = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
      max_range = std::max(max_range, std::abs(along - (p.distance_m * 1e3 - n)));
      lo = std::min(lo, static_cast<double>(p.distance_m));
      hi = std::max(hi, static_cast<double>(p.distance_m));
    }
  }
  for (const auto& cols : frames)
    for (const auto& [ts, c] : cols)
      for (std::size_t row = 0; row < meta.pixels; ++row)
        for (int k = 0; k < (meta.pixel == 16 ? 2 : 1); ++k) returns += range_mm(c, meta, row, k) > 0;
  const auto counts = decoder->counts();
  const auto name = capture.substr(capture.find_last_of('/') + 1);
  std::printf("| %s | %s | %s | %zu/%zu | %zu/%zu | %zu | %zu | %.2g | %.2g | %.2g | %.2g | %.3f-%.2f | %zu/%zu | %.2f |\n", name.c_str(),
              decoder->info().model.c_str(), meta.profile.c_str(), static_cast<std::size_t>(std::count(column_seen.begin(), column_seen.end(), 1)),
              meta.columns, points, returns, other_range, sweeps.size(), max_elev, max_az, max_az_field, max_range / 1e3, lo, hi, counts.skipped,
              counts.packets, decode_ms);
  if (unmatched) std::printf("  %zu points without a column of their time\n", unmatched);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: bench_lidar_ouster_check CAPTURE[=METADATA[=MODEL]]...\n");
    return 2;
  }
  std::printf("| capture | model | profile | columns | points/returns | range != packet | sweeps | elevation err deg | azimuth err deg | "
              "azimuth_deg err | range err m | range m | skipped/packets | ms a frame |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  int failed = 0;
  for (int i = 1; i < argc; ++i) {
    std::string arg = argv[i], meta, model;
    if (auto eq = arg.find('='); eq != std::string::npos) {
      meta = arg.substr(eq + 1);
      arg.resize(eq);
      if (auto eq2 = meta.find('='); eq2 != std::string::npos) model = meta.substr(eq2 + 1), meta.resize(eq2);
    }
    try {
      check(arg, meta, model);
    } catch (const std::exception& e) {
      std::printf("| %s | error: %s |\n", arg.c_str(), e.what());
      ++failed;
    }
  }
  return failed ? 1 : 0;
}
