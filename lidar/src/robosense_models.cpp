// The RoboSense models this decoder knows, with their firing tables (the makers' user manuals and
// drivers), and how a block's slots map to lasers and returns in each return mode.
#include <cctype>

#include "pl/common/error.hpp"
#include "robosense_format.hpp"

namespace pl::lidar::robosense {
namespace {

// clang-format off
// RS-LiDAR-16: 16 lasers 2.8 µs apart, a firing every 55.5 µs, two firings a block (user manual, app. A).
constexpr Model kRs16{
    "RS-LiDAR-16", Family::Rs16, 16, 55.5f, 0.03825f, true, 111.0f,
    {0.00f,  2.80f,  5.60f,  8.40f,  11.20f, 14.00f, 16.80f, 19.60f, 22.40f, 25.20f, 28.00f,
     30.80f, 33.60f, 36.40f, 39.20f, 42.00f, 55.50f, 58.30f, 61.10f, 63.90f, 66.70f, 69.50f,
     72.30f, 75.10f, 77.90f, 80.70f, 83.50f, 86.30f, 89.10f, 91.90f, 94.70f, 97.50f}};

// Helios-16P: the Helios's even lasers, two firings a 55.56 µs block (its packets come 12 blocks,
// 666.7 µs, apart). The table is the reference decoder's: each firing on the Helios's clock, the second
// 55.56 µs after the first, so a slot's share of the block is its time over 111.12 µs.
constexpr Model kHelios16P{
    "Helios-16P", Family::Helios, 16, 55.56f, 0.03498f, true, 55.56f,
    {0.00f,  3.15f,  6.30f,  9.45f,  13.26f, 17.08f, 20.56f, 23.71f, 26.53f, 27.77f, 31.49f,
     32.73f, 36.46f, 38.94f, 41.42f, 43.91f, 55.56f, 58.70f, 61.85f, 65.00f, 68.82f, 72.64f,
     76.12f, 79.27f, 82.08f, 83.32f, 87.05f, 88.29f, 92.01f, 94.50f, 96.98f, 99.46f}};

// Helios (32 beams): one firing of 32 lasers a 55.56 µs block.
constexpr Model kHelios32{
    "Helios-32", Family::Helios, 32, 55.56f, 0.03498f, false, 55.56f,
    {0.00f,  1.57f,  3.15f,  4.72f,  6.30f,  7.87f,  9.45f,  11.36f, 13.26f, 15.17f, 17.08f,
     18.99f, 20.56f, 22.14f, 23.71f, 25.29f, 26.53f, 29.01f, 27.77f, 30.25f, 31.49f, 33.98f,
     32.73f, 35.22f, 36.46f, 37.70f, 38.94f, 40.18f, 41.42f, 42.67f, 43.91f, 45.15f}};
// clang-format on

// "RS-Helios-16P", "helios_16p", "RSHELIOS_16P" -> "helios16p".
std::string folded(std::string_view name) {
  std::string s;
  for (char c : name)
    if (std::isalnum(static_cast<unsigned char>(c))) s += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (s.rfind("robosense", 0) == 0) s.erase(0, 9);
  if (s.rfind("rs", 0) == 0 && s.size() > 2 && !std::isdigit(static_cast<unsigned char>(s[2]))) s.erase(0, 2);
  return s;
}

}  // namespace

const Model* find_model(std::string_view name) {
  const std::string s = folded(name);
  if (s == "lidar16" || s == "rs16") return &kRs16;
  if (s == "helios16p") return &kHelios16P;
  if (s == "helios32" || s == "helios") return &kHelios32;
  return nullptr;
}

const Model& model_for(Family family, int lasers) {
  if (family == Family::Rs16) return kRs16;
  return lasers == 16 ? kHelios16P : kHelios32;
}

std::string model_names() { return "RS-LiDAR-16, Helios-16P, Helios-32"; }

SlotPlan plan_slots(const Model& m, bool dual) {
  SlotPlan p;
  for (std::size_t c = 0; c < kSlots; ++c) {
    const std::size_t in_firing = m.two_firings ? c % 16 : c;
    p.laser[c] = static_cast<std::uint8_t>(in_firing);
    if (dual) {
      // One firing a block: a 16-laser model's halves are its two returns; the Helios-32 pairs blocks.
      p.second_return[c] = m.two_firings && c >= 16;
      p.time_us[c] = m.slot_us[in_firing];
      p.fraction[c] = m.slot_us[in_firing] / m.firing_us;
    } else {
      const float span = m.two_firings ? m.firing_us * 2 : m.firing_us;
      p.fraction[c] = m.slot_us[c] / span;
      p.time_us[c] = p.fraction[c] * m.single_block_us;
    }
  }
  p.block_us = dual ? m.firing_us : m.single_block_us;
  p.step_firings = dual ? 1 : static_cast<int>(m.single_block_us / m.firing_us + 0.5f);
  p.block_pairs = dual && !m.two_firings;
  return p;
}

}  // namespace pl::lidar::robosense
