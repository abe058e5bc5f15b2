// MSOP packets -> points. Azimuths stay in 0.01° integers as the sensor and its maker's driver give
// them: a slot's azimuth is its block's plus its share of the turn to the next block (truncated), plus
// its laser's offset; sines and cosines come from a table of every 0.01°.
#include "robosense_msop.hpp"

#include <cmath>
#include <cstring>

namespace pl::lidar::robosense {
namespace {

constexpr int kTurn = 36000;  // 0.01° in a turn

struct Trig {
  std::vector<float> sin, cos;
  Trig() : sin(kTurn), cos(kTurn) {
    for (int i = 0; i < kTurn; ++i) {
      const double r = i * 0.01 * M_PI / 180.0;
      sin[i] = static_cast<float>(std::sin(r));
      cos[i] = static_cast<float>(std::cos(r));
    }
  }
};
const Trig& trig() {
  static const Trig t;
  return t;
}

int wrapped(int a) { return ((a % kTurn) + kTurn) % kTurn; }

// Days from 1970-01-01 to a date of the proleptic Gregorian calendar.
std::int64_t days_since_1970(int y, int m, int d) {
  y -= m <= 2;
  const int era = y / 400;
  const int yoe = y - era * 400;
  const int doy = (153 * (m + (m > 2 ? -3 : 9)) + 2) / 5 + d - 1;
  const int doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
  return static_cast<std::int64_t>(era) * 146097 + doe - 719468;
}

double rotations_per_s(int rpm) { return rpm > 0 ? rpm / 60.0 : 10.0; }

}  // namespace

ReturnMode return_mode(Family family, std::uint8_t code) {
  ReturnMode r;
  if (code == 0x00) {
    r.dual = true;
    r.second = family == Family::Rs16 ? ReturnType::Last : ReturnType::SecondStrongest;
  } else if (family == Family::Rs16) {
    r.first = code == 0x02 ? ReturnType::Last : ReturnType::Strongest;
  } else {
    r.first = code == 0x05 ? ReturnType::Last : code == 0x06 ? ReturnType::First : ReturnType::Strongest;
  }
  return r;
}

Geometry make_geometry(const Model& m, const Angles& a, ReturnMode mode, int rpm, double min_m, double max_m) {
  Geometry g;
  g.model = &m;
  g.plan = plan_slots(m, mode.dual);
  g.first = mode.first;
  g.second = mode.second;
  g.rpm = rpm;
  g.min_m = static_cast<float>(min_m);
  g.max_m = static_cast<float>(max_m);
  const auto n = static_cast<std::size_t>(m.lasers);
  g.azimuth_offset = a.azimuth_offset;
  g.channel.resize(n);
  for (std::size_t l = 0; l < n; ++l) {
    const double e = a.elevation_deg[l];
    g.elevation_deg.push_back(static_cast<float>(e));
    g.cos_el.push_back(static_cast<float>(std::cos(e * M_PI / 180.0)));
    g.sin_el.push_back(static_cast<float>(std::sin(e * M_PI / 180.0)));
    std::size_t rank = 0;  // lasers below it, and those level with it that come before it
    for (std::size_t k = 0; k < n; ++k) rank += a.elevation_deg[k] < e || (a.elevation_deg[k] == e && k < l);
    g.channel[l] = static_cast<std::uint16_t>(rank);
  }
  // The maker's driver turns the rate into whole rotations a second before it takes the step.
  const int rps = rpm / 60 > 0 ? rpm / 60 : 10;
  g.nominal_step = static_cast<int>(std::lround(kTurn * rps * (static_cast<double>(m.firing_us) * 1e-6))) * g.plan.step_firings;
  return g;
}

const char* check_msop(std::string_view p, const Model& m) {
  const auto* b = reinterpret_cast<const unsigned char*>(p.data());
  if (m.family == Family::Rs16 ? std::memcmp(b, kRs16Magic, sizeof kRs16Magic) != 0
                               : std::memcmp(b, kHeliosMagic, sizeof kHeliosMagic) != 0)
    return m.family == Family::Rs16 ? "not an RS-LiDAR-16 MSOP packet (its header is not 55 AA 05 0A 5A A5 50 A0)"
                                    : "not a Helios MSOP packet (its header is not 55 AA 05 5A)";
  if (m.family == Family::Helios && b[kRangeUnitAt] > 1)
    return "a Helios MSOP packet with an unknown distance unit (byte 17 is neither 0 nor 1)";
  for (std::size_t k = 0; k < kBlocks; ++k) {
    const unsigned char* blk = b + kFirstBlock + k * kBlockBytes;
    if (blk[0] != 0xFF || blk[1] != 0xEE) return "an MSOP packet with a block that does not open with FF EE";
    if (be16(blk + 2) >= static_cast<std::uint32_t>(kTurn)) return "an MSOP packet with a block azimuth past 359.99°";
  }
  return nullptr;
}

std::int64_t packet_time_ns(std::string_view p, Family family, std::int64_t receive_ns) {
  const auto* b = reinterpret_cast<const unsigned char*>(p.data()) + kTimeAt;
  if (family == Family::Helios) {
    const std::uint64_t s = be16(b) << 16 | be16(b + 2), ws = s << 16 | be16(b + 4), us = be32(b + 6);
    if (ws > 4000000000ull || us >= 1000000) return receive_ns;  // not a time this side of 2096
    return static_cast<std::int64_t>(ws) * 1000000000 + static_cast<std::int64_t>(us) * 1000;
  }
  const int year = 2000 + b[0], month = b[1], day = b[2], hour = b[3], minute = b[4], second = b[5];
  const int ms = static_cast<int>(be16(b + 6)), us = static_cast<int>(be16(b + 8));
  if (month < 1 || month > 12 || day < 1 || day > 31 || hour > 23 || minute > 59 || second > 60 || ms > 999 || us > 999)
    return receive_ns;
  const std::int64_t s = days_since_1970(year, month, day) * 86400 + hour * 3600 + minute * 60 + second;
  return s * 1000000000 + ms * 1000000LL + us * 1000LL;
}

void decode_msop(std::string_view p, std::int64_t receive_ns, const Geometry& g, DecodedPacket& out) {
  const auto* b = reinterpret_cast<const unsigned char*>(p.data());
  const Model& m = *g.model;
  const SlotPlan& plan = g.plan;
  const Trig& t = trig();
  const float unit = m.family == Family::Helios && b[kRangeUnitAt] == 1 ? 0.0025f : 0.005f;
  const std::int64_t t0 = packet_time_ns(p, m.family, receive_ns);
  for (std::size_t k = 0; k < kBlocks; ++k) out.azimuth[k] = static_cast<int>(be16(b + kFirstBlock + k * kBlockBytes + 2));
  out.points.clear();
  out.point_ns.clear();
  const std::size_t group = plan.block_pairs ? 2 : 1;
  double t_us = 0;
  for (std::size_t k = 0; k < kBlocks; k += group) {
    // The turn to the next block (pair): measured, or the nominal one for the last and across a blind
    // section of a sensor with a narrowed field of view (there time runs at the rotation rate).
    int step = g.nominal_step;
    double next_us = plan.block_us;
    if (k + group < kBlocks) {
      int d = out.azimuth[k + group] - out.azimuth[k];
      if (d < 0) d += kTurn;
      if (d > 100)
        next_us = d / (kTurn * rotations_per_s(g.rpm)) * 1e6;
      else
        step = d;
    }
    for (std::size_t j = k; j < k + group; ++j) {
      out.time_ns[j] = t0 + std::llround(t_us * 1000);
      out.first_point[j] = out.points.size();
      const bool second_block = plan.block_pairs && j % 2 == 1;
      const unsigned char* slot = b + kFirstBlock + j * kBlockBytes + 4;
      for (std::size_t c = 0; c < kSlots; ++c, slot += 3) {
        const std::uint32_t raw = be16(slot);
        const float dist = static_cast<float>(raw) * unit;
        if (raw == 0 || dist < g.min_m || dist > g.max_m) continue;
        const std::size_t l = plan.laser[c];
        const int h = wrapped(out.azimuth[j] + static_cast<int>(static_cast<float>(step) * plan.fraction[c]));
        const int hf = wrapped(h + g.azimuth_offset[l]);
        const float flat = dist * g.cos_el[l];
        Point pt;
        pt.x = flat * t.cos[hf] + m.lens_offset_m * t.cos[h];
        pt.y = -flat * t.sin[hf] - m.lens_offset_m * t.sin[h];
        pt.z = dist * g.sin_el[l];
        pt.intensity = slot[2];
        pt.channel = g.channel[l];
        pt.return_type = second_block || plan.second_return[c] ? g.second : g.first;
        pt.azimuth_deg = static_cast<float>(hf) / 100.0f;
        pt.elevation_deg = g.elevation_deg[l];
        pt.distance_m = dist;
        out.points.push_back(pt);
        out.point_ns.push_back(out.time_ns[j] + std::llround(plan.time_us[c] * 1000.0f));
      }
    }
    t_us += next_us;
  }
  out.first_point[kBlocks] = out.points.size();
}

}  // namespace pl::lidar::robosense
