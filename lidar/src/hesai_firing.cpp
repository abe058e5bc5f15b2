// Hesai firing times. The channel offsets are the manuals' tables (microseconds); the QT64's channel 56
// is 129.6 us as its neighbours' 2.06 us steps give (the makers' driver has 12.96). The XT32M counts its
// rounds over its own 6 blocks in every return mode (the driver counts 8 in single and dual modes).
#include "hesai_firing.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace pl::lidar {
namespace {

constexpr double k40pUs[40] = {
    -42.22, -28.47, -16.04, -3.62, -45.49, -31.74, -47.46, -54.67, -20.62, -33.71,
    -40.91, -8.19, -20.62, -27.16, -50.73, -8.19, -14.74, -36.98, -45.49, -52.7,
    -23.89, -31.74, -38.95, -11.47, -18.65, -25.19, -48.76, -6.23, -12.77, -35.01,
    -21.92, -9.5, -43.52, -29.77, -17.35, -4.92, -42.22, -28.47, -16.04, -3.62,
};

constexpr double k64Us[64] = {
    -23.18, -21.876, -20.572, -19.268, -17.964, -16.66, -11.444, -46.796, -7.532, -36.956, -50.732,
    -54.668, -40.892, -44.828, -31.052, -34.988, -48.764, -52.7, -38.924, -42.86, -29.084, -33.02,
    -46.796, -25.148, -36.956, -50.732, -27.116, -40.892, -44.828, -31.052, -34.988, -48.764, -25.148,
    -38.924, -42.86, -29.084, -33.02, -52.7, -6.228, -54.668, -15.356, -27.116, -10.14, -23.18,
    -4.924, -21.876, -14.052, -17.964, -8.836, -19.268, -3.62, -20.572, -12.748, -16.66, -7.532,
    -11.444, -6.228, -15.356, -10.14, -4.924, -3.62, -14.052, -8.836, -12.748,
};

constexpr double kQt64Us[64] = {
    12.31, 14.37, 16.43, 18.49, 20.54, 22.6, 24.66, 26.71, 29.16, 31.22, 33.28,
    35.34, 37.39, 39.45, 41.5, 43.56, 46.61, 48.67, 50.73, 52.78, 54.84, 56.9,
    58.95, 61.01, 63.45, 65.52, 67.58, 69.63, 71.69, 73.74, 75.8, 77.86, 80.9,
    82.97, 85.02, 87.08, 89.14, 91.19, 93.25, 95.3, 97.75, 99.82, 101.87, 103.93,
    105.98, 108.04, 110.1, 112.15, 115.2, 117.26, 119.32, 121.38, 123.43, 125.49, 127.54,
    129.6, 132.05, 134.11, 136.17, 138.22, 140.28, 142.34, 144.39, 146.45,
};

// The QT128 fires its channels in two sequences; 0: the channel does not fire in that sequence.
constexpr double kQt128Sequence1Us[128] = {
    0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0,
    0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0,
    0, 0, 0, 0, 0, 0, 27.656, 53, 2.312, 78.344, 81.512, 5.48, 56.168,
    30.824, 33.992, 59.336, 8.648, 84.68, 87.848, 11.816, 62.504, 37.16, 40.328, 65.672, 14.984, 91.016,
    94.184, 18.152, 68.84, 43.496, 46.664, 72.008, 21.32, 97.352, 100.52, 24.488, 75.176, 49.832, 1.456,
    77.488, 26.8, 52.144, 55.312, 29.968, 80.656, 4.624, 7.792, 83.824, 33.136, 58.48, 61.648, 36.304,
    86.992, 10.96, 14.128, 90.16, 39.472, 64.816, 67.984, 42.64, 93.328, 17.296, 20.464, 96.496, 45.808,
    71.152, 74.32, 48.976, 99.664, 23.632, 25.944, 51.288, 0.6, 76.632, 79.8, 3.768, 54.456, 29.112,
    32.28, 57.624, 6.936, 82.968, 86.136, 10.104, 60.792, 35.448, 38.616, 63.96, 13.272, 89.304, 92.472,
    16.44, 67.128, 41.784, 44.952, 70.296, 19.608, 95.64, 98.808, 22.776, 73.464, 48.12,
};
constexpr double kQt128Sequence2Us[128] = {
    2.312, 78.344, 27.656, 53, 56.168, 30.824, 81.512, 5.48, 8.648, 84.68, 33.992, 59.336, 62.504,
    37.16, 87.848, 11.816, 14.984, 91.016, 40.328, 65.672, 68.84, 43.496, 94.184, 18.152, 21.32, 97.352,
    46.664, 72.008, 75.176, 49.832, 100.52, 24.488, 0, 0, 0, 0, 0, 0, 0,
    0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0,
    0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0.6,
    76.632, 25.944, 51.288, 54.456, 29.112, 79.8, 3.768, 6.936, 82.968, 32.28, 57.624, 60.792, 35.448,
    86.136, 10.104, 13.272, 89.304, 38.616, 63.96, 67.128, 41.784, 92.472, 16.44, 19.608, 95.64, 44.952,
    70.296, 73.464, 48.12, 98.808, 22.776, 26.8, 52.144, 1.456, 77.488, 80.656, 4.624, 55.312, 29.968,
    33.136, 58.48, 7.792, 83.824, 86.992, 10.96, 61.648, 36.304, 39.472, 64.816, 14.128, 90.16, 93.328,
    17.296, 67.984, 42.64, 45.808, 71.152, 20.464, 96.496, 99.664, 23.632, 74.32, 48.976,
};

std::int32_t ns(double us) { return static_cast<std::int32_t>(std::lround(us * 1000)); }

}  // namespace

std::int32_t hesai_firing_offset_ns(HesaiModel model, int block, int channel, int returns, int loop) {
  const int blocks = hesai_layout(model).blocks;
  // Firing rounds before the packet's last one and after its first: the packet's time is near its last
  // round on the Pandar40P, Pandar64 and XT, before its first on the QT64 and QT128.
  const int rounds_before_last = (blocks - 1 - block) / returns;
  const int rounds_after_first = block / returns;
  switch (model) {
    case HesaiModel::Pandar40P: return ns(-28.58 - 55.56 * rounds_before_last + k40pUs[channel]);
    case HesaiModel::Pandar64: return ns(-42.58 - 55.56 * rounds_before_last + k64Us[channel]);
    case HesaiModel::PandarQT64: return 25710 + 500000 * rounds_after_first / 3 + ns(kQt64Us[channel]);
    case HesaiModel::PandarXT16: return ns(5.632 - 50.0 * rounds_before_last + 0.368 + 3.024 * channel);
    case HesaiModel::PandarXT32: return ns(5.632 - 50.0 * rounds_before_last + 0.368 + 1.512 * channel);
    case HesaiModel::PandarXT32M: return ns(5.632 - 50.0 * rounds_before_last + 0.368 + 2.888 * (channel % 16));
    case HesaiModel::PandarQT128: {
      // Rounds 111.11 us apart after the packet's time. Single return: block 1 holds sequence 1, block 2
      // sequence 2; dual return: both blocks hold one round, of the sequence the tail's mode flag names.
      // (The makers' driver times block 1 after block 2, against their azimuths, and in dual return
      // 55.6 us apart, by operator precedence.)
      const bool first_sequence = returns == 1 ? block % 2 == 0 : loop == 1;
      const double round_us = 9.0 + 111.11 * rounds_after_first;
      return ns(round_us + (first_sequence ? kQt128Sequence1Us[channel] : kQt128Sequence2Us[channel]));
    }
  }
  return 0;
}

HesaiFiringTable::Entry& HesaiFiringTable::entry(const HesaiPacket& packet) {
  Entry& e = entries_[static_cast<std::size_t>((packet.returns - 1) * 2 + packet.loop)];
  if (!e.offsets.empty()) return e;
  const int blocks = layout_->blocks, channels = layout_->channels;
  e.offsets.resize(static_cast<std::size_t>(blocks * channels));
  e.earliest.assign(static_cast<std::size_t>(blocks), std::numeric_limits<std::int32_t>::max());
  for (int b = 0; b < blocks; ++b) {
    const std::size_t first = static_cast<std::size_t>(b - b % packet.returns);
    for (int c = 0; c < channels; ++c) {
      const std::int32_t t = hesai_firing_offset_ns(layout_->model, b, c, packet.returns, packet.loop);
      e.offsets[static_cast<std::size_t>(b * channels + c)] = t;
      e.earliest[first] = std::min(e.earliest[first], t);
    }
  }
  return e;
}

const std::vector<std::int32_t>& HesaiFiringTable::offsets(const HesaiPacket& packet) { return entry(packet).offsets; }

std::int32_t HesaiFiringTable::earliest(const HesaiPacket& packet, int first_block) {
  return entry(packet).earliest[static_cast<std::size_t>(first_block)];
}

}  // namespace pl::lidar
