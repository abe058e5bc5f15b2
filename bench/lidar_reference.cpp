// Our LiDAR decoders against the makers' decoder: every packet of a recording decoded into sweeps
// (pl/lidar/decoder.hpp), the sweep that best matches a reference cloud (a PCD the reference decoder
// made of the same packets) chosen, and one table row printed: points on each side, reference points
// with one of ours within 1 mm, the largest position and azimuth errors of those pairs, and how many of
// them agree on channel and return type.
//   bench_lidar_reference --vendor velodyne|hesai|robosense|ouster --recording BAG --reference FILE.pcd
//                         [--model M] [--lidar-calibration F] [--min-range M] [--max-range M] [--cut-azimuth DEG]
#include <CLI/CLI.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string>
#include <unordered_map>
#include <vector>

#include "pl/common/error.hpp"
#include "pl/lidar/decoder.hpp"
#include "pl/recordings/bag.hpp"
#include "pl/recordings/packet_msgs.hpp"

namespace {

struct RefPoint {
  double x = 0, y = 0, z = 0, azimuth = 0;
  int channel = -1, return_type = -1;
};

// Which of the optional fields the reference has (the Hesai and some Velodyne references are x y z only).
struct RefFields {
  bool azimuth = false, channel = false, return_type = false;
};

// A PCD of the reference decoder (binary or ascii), by field name.
std::vector<RefPoint> read_reference(const std::string& path, RefFields& has) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw pl::Error(path + ": cannot open");
  std::vector<std::string> fields, types;
  std::vector<int> sizes;
  std::size_t points = 0;
  std::string data, line;
  while (data.empty() && std::getline(in, line)) {
    std::istringstream ls(line);
    std::string key, v;
    ls >> key;
    if (key == "FIELDS") while (ls >> v) fields.push_back(v);
    else if (key == "SIZE") while (ls >> v) sizes.push_back(std::stoi(v));
    else if (key == "TYPE") while (ls >> v) types.push_back(v);
    else if (key == "POINTS") ls >> points;
    else if (key == "DATA") ls >> data;
  }
  if (fields.empty() || fields.size() != sizes.size() || fields.size() != types.size()) throw pl::Error(path + ": not a PCD header");
  auto index = [&](const char* name) {
    for (std::size_t i = 0; i < fields.size(); ++i)
      if (fields[i] == name) return static_cast<int>(i);
    return -1;
  };
  const int ix = index("x"), iy = index("y"), iz = index("z"), ia = index("azimuth"), ic = index("channel"), ir = index("return_type");
  if (ix < 0 || iy < 0 || iz < 0) throw pl::Error(path + ": no x y z fields");
  has = {ia >= 0, ic >= 0, ir >= 0};
  std::vector<RefPoint> out(points);
  std::vector<double> v(fields.size());
  std::vector<std::size_t> offset(fields.size());
  std::size_t step = 0;
  for (std::size_t i = 0; i < fields.size(); ++i) offset[i] = step, step += static_cast<std::size_t>(sizes[i]);
  std::vector<char> rec(step);
  for (std::size_t k = 0; k < points; ++k) {
    if (data == "ascii") {
      for (auto& x : v) in >> x;
    } else if (data == "binary") {
      if (!in.read(rec.data(), static_cast<std::streamsize>(step))) throw pl::Error(path + ": ends at point " + std::to_string(k));
      for (std::size_t i = 0; i < fields.size(); ++i) {
        const char* p = rec.data() + offset[i];
        const char t = types[i][0];
        const int s = sizes[i];
        if (t == 'F' && s == 4) { float f; std::memcpy(&f, p, 4); v[i] = f; }
        else if (t == 'F' && s == 8) { double d; std::memcpy(&d, p, 8); v[i] = d; }
        else if (t == 'U' && s == 1) v[i] = static_cast<unsigned char>(*p);
        else if (t == 'U' && s == 2) { std::uint16_t u; std::memcpy(&u, p, 2); v[i] = u; }
        else if (t == 'U' && s == 4) { std::uint32_t u; std::memcpy(&u, p, 4); v[i] = u; }
        else if (t == 'I' && s == 4) { std::int32_t u; std::memcpy(&u, p, 4); v[i] = u; }
        else v[i] = 0;
      }
    } else {
      throw pl::Error(path + ": DATA " + data + " (expected binary or ascii)");
    }
    RefPoint& r = out[k];
    r.x = v[ix], r.y = v[iy], r.z = v[iz];
    if (ia >= 0) r.azimuth = v[ia];
    if (ic >= 0) r.channel = static_cast<int>(v[ic]);
    if (ir >= 0) r.return_type = static_cast<int>(v[ir]);
  }
  if (!in && data == "ascii") throw pl::Error(path + ": fewer points than POINTS says");
  // The reference decoder gives azimuths in radians (older versions in degrees; its RoboSense decoder
  // of 2023 in 0.01° integers, some past 360° or below 0°).
  double most = 0;
  for (const auto& r : out) most = std::max(most, std::abs(r.azimuth));
  if (most <= 2 * M_PI + 0.01)
    for (auto& r : out) r.azimuth *= 180.0 / M_PI;
  else if (most > 720)
    for (auto& r : out) r.azimuth *= 0.01;
  return out;
}

struct Row {
  std::size_t ours = 0, matched = 0, channel_ok = 0, return_ok = 0;
  double max_error_m = 0, max_azimuth_deg = 0;
};

// Reference points matched to the nearest of the sweep's points (a 5 cm grid; a pair counts within 1 mm).
// Without a reference azimuth, the azimuth error is the angle between the pair's horizontal bearings.
Row compare(const pl::lidar::Sweep& sweep, const std::vector<RefPoint>& ref, const RefFields& has) {
  constexpr double kCell = 0.05;
  auto key = [](long x, long y, long z) { return (x * 73856093) ^ (y * 19349663) ^ (z * 83492791); };
  std::unordered_multimap<long, std::size_t> grid;
  grid.reserve(sweep.points.size());
  for (std::size_t i = 0; i < sweep.points.size(); ++i) {
    const auto& p = sweep.points[i];
    grid.emplace(key(std::lround(std::floor(p.x / kCell)), std::lround(std::floor(p.y / kCell)), std::lround(std::floor(p.z / kCell))), i);
  }
  Row row;
  row.ours = sweep.points.size();
  for (const RefPoint& r : ref) {
    const long cx = std::lround(std::floor(r.x / kCell)), cy = std::lround(std::floor(r.y / kCell)), cz = std::lround(std::floor(r.z / kCell));
    double best = 1e9;
    const pl::lidar::Point* near = nullptr;
    for (long dx = -1; dx <= 1; ++dx)
      for (long dy = -1; dy <= 1; ++dy)
        for (long dz = -1; dz <= 1; ++dz) {
          auto [a, b] = grid.equal_range(key(cx + dx, cy + dy, cz + dz));
          for (auto it = a; it != b; ++it) {
            const auto& p = sweep.points[it->second];
            const double d = std::sqrt((p.x - r.x) * (p.x - r.x) + (p.y - r.y) * (p.y - r.y) + (p.z - r.z) * (p.z - r.z));
            // Ties (a dual return reported twice at one place) prefer the same return type.
            if (d < best - 1e-9 || (d < best + 1e-9 && near && static_cast<int>(p.return_type) == r.return_type)) best = d, near = &p;
          }
        }
    if (!near || best > 0.001) continue;
    ++row.matched;
    row.max_error_m = std::max(row.max_error_m, best);
    double da = has.azimuth ? std::abs(near->azimuth_deg - r.azimuth)
                            : std::abs(std::atan2(near->y, near->x) - std::atan2(r.y, r.x)) * 180.0 / M_PI;
    da = std::fmod(da, 360.0);
    da = std::min(da, 360.0 - da);
    row.max_azimuth_deg = std::max(row.max_azimuth_deg, da);
    row.channel_ok += near->channel == r.channel;
    row.return_ok += static_cast<int>(near->return_type) == r.return_type;
  }
  return row;
}

pl::lidar::Vendor vendor_of(const std::string& name) {
  if (name == "velodyne") return pl::lidar::Vendor::Velodyne;
  if (name == "hesai") return pl::lidar::Vendor::Hesai;
  if (name == "robosense") return pl::lidar::Vendor::RoboSense;
  if (name == "ouster") return pl::lidar::Vendor::Ouster;
  throw pl::Error("--vendor " + name + ": expected velodyne, hesai, robosense or ouster");
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Compare a LiDAR decoder's sweeps with the makers' reference cloud"};
  std::string vendor, recording, reference;
  pl::lidar::DecoderOptions opt;
  app.add_option("--vendor", vendor)->required();
  app.add_option("--recording", recording)->required();
  app.add_option("--reference", reference)->required();
  app.add_option("--model", opt.model);
  app.add_option("--lidar-calibration", opt.calibration_path);
  app.add_option("--min-range", opt.min_range_m);
  app.add_option("--max-range", opt.max_range_m);
  app.add_option("--cut-azimuth", opt.cut_azimuth_deg);
  CLI11_PARSE(app, argc, argv);
  try {
    auto decoder = pl::lidar::make_decoder(vendor_of(vendor), opt);
    auto reader = pl::bag::open(recording);
    std::vector<pl::lidar::Sweep> sweeps;
    std::size_t messages = 0;
    for (const auto& m : reader->messages()) {
      const auto& topic = reader->topics()[m.topic];
      if (!pl::ros::packet_vendor(topic.type)) continue;
      ++messages;
      const std::string name = recording + ": " + topic.name;
      const auto scan = pl::ros::decode_packet_scan(reader->read(m), topic.encoding, topic.type, name);
      for (const auto& p : scan.packets) decoder->add(p.data, p.stamp_ns ? p.stamp_ns : m.time_ns, sweeps);
    }
    decoder->finish(sweeps);
    // The reference decoder numbers a Velodyne's lasers by elevation (its rings), ours by laser id.
    if (vendor == "velodyne") {
      const auto rings = decoder->info().ring_of_channel;
      for (auto& sweep : sweeps)
        for (auto& p : sweep.points) p.channel = rings.at(p.channel);
    }
    RefFields has;
    const std::vector<RefPoint> ref = read_reference(reference, has);
    Row best;
    std::size_t best_index = 0;
    for (std::size_t i = 0; i < sweeps.size(); ++i) {
      const Row r = compare(sweeps[i], ref, has);
      if (i == 0 || r.matched > best.matched) best = r, best_index = i;
    }
    const auto info = decoder->info();
    const auto& c = decoder->counts();
    std::fprintf(stderr, "%s: %zu messages, %zu packets (%zu skipped%s%s), %zu sweeps; best sweep %zu of %zu\n", recording.c_str(), messages,
                 c.packets, c.skipped, c.last_problem.empty() ? "" : ": ", c.last_problem.c_str(), sweeps.size(), best_index,
                 sweeps.size());
    if (!has.azimuth || !has.channel || !has.return_type)
      std::fprintf(stderr, "%s has no%s%s%s field: %s\n", reference.c_str(), has.azimuth ? "" : " azimuth",
                   has.channel ? "" : " channel", has.return_type ? "" : " return_type",
                   "azimuth compared as the pair's bearings, channel and return not compared (n/a)");
    auto agreeing = [](bool present, std::size_t n) { return present ? std::to_string(n) : std::string("n/a"); };
    std::printf("| %s | %zu | %zu | %zu | %.3f mm | %.4f° | %s | %s |\n", info.model.c_str(), best.ours, ref.size(), best.matched,
                best.max_error_m * 1e3, best.max_azimuth_deg, agreeing(has.channel, best.channel_ok).c_str(),
                agreeing(has.return_type, best.return_ok).c_str());
    const bool channels_agree = !has.channel || best.channel_ok == ref.size();
    const bool returns_agree = !has.return_type || best.return_ok == ref.size();
    return best.matched == ref.size() && channels_agree && returns_agree ? 0 : 1;
  } catch (const pl::Error& e) {
    std::fprintf(stderr, "bench_lidar_reference: %s\n", e.what());
    return 2;
  }
}
