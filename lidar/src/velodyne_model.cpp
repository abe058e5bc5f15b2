// The Velodyne model table and each model's block layout and firing times. Timing facts, per model
// (microseconds; the makers' manuals, as the reference decoders tabulate them):
//   VLP-16     16 lasers one after another every 2.304, a firing sequence every 55.296, two sequences
//              per block; the block's azimuth is its first sequence's.
//   VLP-32C    lasers in pairs every 2.304, one sequence (a block) every 55.296.
//   HDL-32E    one laser every 1.152, one sequence (a block) every 46.080.
//   HDL-64E    an upper block (lasers 0-31) and a lower block (32-63) fire together, four lasers at a
//              time: S2 every 6.0 (within a group 0, 1.26, 2.46, 3.66), a column every 48.0; S3 every
//              7.2 (0, 1.3, 2.5, 3.7), a column every 57.6.
//   VLS-128    eight lasers at a time every 2.665, groups 0-7, one maintenance slot, groups 8-15; a
//              column (four blocks, banks 0xEEFF, 0xDDFF, 0xCCFF, 0xBBFF) every 53.3; the packet's
//              time stamp is 8.7 after its first firing.
// Dual return: each firing's two returns sit in partner blocks (VLP/HDL-32E: pairs; HDL-64E: upper
// and lower pairs two apart; VLS-128: pairs of one bank, one column per packet, four padding blocks).
#include "velodyne_model.hpp"

#include <cctype>
#include <cmath>

namespace pl::lidar {
namespace {

constexpr VelodyneModel kModels[] = {
    {"VLP-16", 0x22, 16, 0.002f, "VLP16.yaml", VelodyneFamily::Vlp16},
    {"VLP-16 Hi-Res", 0x24, 16, 0.002f, "VLP16_hires.yaml", VelodyneFamily::Vlp16},
    {"VLP-32C", 0x28, 32, 0.004f, "VLP32.yaml", VelodyneFamily::Vlp32C},
    {"HDL-32E", 0x21, 32, 0.002f, "HDL32.yaml", VelodyneFamily::Hdl32E},
    {"HDL-64E S2", 0, 64, 0.002f, "HDL64e_s2.yaml", VelodyneFamily::Hdl64E_S2},
    {"HDL-64E S3", 0, 64, 0.002f, "HDL64e_s3.yaml", VelodyneFamily::Hdl64E_S3},
    {"VLS-128", 0xA1, 128, 0.004f, "VLS128.yaml", VelodyneFamily::Vls128},
};

constexpr std::uint16_t kBankFlags[4] = {0xEEFF, 0xDDFF, 0xCCFF, 0xBBFF};

std::string squeezed(std::string_view name) {
  std::string out;
  for (char c : name)
    if (std::isalnum(static_cast<unsigned char>(c))) out += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

// One column of 32-laser blocks that fire one laser (or one pair) at a time.
void sequential(VelodyneLayout& l, float slot_us, bool pairs) {
  for (int b = 0; b < kVelodyneBlocks; ++b)
    for (int j = 0; j < kVelodyneSlots; ++j) {
      l.laser[b][j] = static_cast<std::uint16_t>(j);
      l.offset_us[b][j] = static_cast<float>(pairs ? j / 2 : j) * slot_us;
      l.interp_mul[b][j] = l.offset_us[b][j];
    }
}

void vlp16(VelodyneLayout& l) {
  for (int b = 0; b < kVelodyneBlocks; ++b)
    for (int j = 0; j < kVelodyneSlots; ++j) {
      const int sequence = j / 16, laser = j % 16;
      l.laser[b][j] = static_cast<std::uint16_t>(laser);
      l.offset_us[b][j] = static_cast<float>(laser) * 2.304f + static_cast<float>(sequence) * 55.296f;
      l.interp_mul[b][j] = l.offset_us[b][j];
    }
}

void hdl64e(VelodyneLayout& l, float group_us, const float (&within)[4]) {
  for (int b = 0; b < kVelodyneBlocks; ++b)
    for (int j = 0; j < kVelodyneSlots; ++j) {
      l.laser[b][j] = static_cast<std::uint16_t>(j + (b % 2) * 32);
      l.offset_us[b][j] = static_cast<float>(j / 4) * group_us + within[j % 4];
      l.interp_mul[b][j] = l.offset_us[b][j];
    }
}

void vls128(VelodyneLayout& l) {
  const float share_per_slot = 2.665f / 53.3f;
  for (int b = 0; b < kVelodyneBlocks; ++b) {
    const int bank = l.dual ? (b / 2) % 4 : b % 4;
    for (int j = 0; j < kVelodyneSlots; ++j) {
      const int laser = bank * 32 + j, group = laser / 8, slot = group + group / 8;
      l.laser[b][j] = static_cast<std::uint16_t>(laser);
      l.offset_us[b][j] = static_cast<float>(slot) * 2.665f;
      l.interp_mul[b][j] = share_per_slot * static_cast<float>(slot);
    }
  }
}

}  // namespace

const VelodyneModel* velodyne_model_by_product(std::uint8_t product_id) {
  if (product_id == 0) return nullptr;
  for (const auto& m : kModels)
    if (m.product_id == product_id) return &m;
  return nullptr;
}

const VelodyneModel* velodyne_model_by_name(std::string_view name) {
  std::string key = squeezed(name);
  if (key == "vlp32") key = "vlp32c";
  if (key == "alphaprime") key = "vls128";
  for (const auto& m : kModels)
    if (squeezed(m.name) == key) return &m;
  return nullptr;
}

std::string velodyne_model_names() {
  std::string out;
  for (const auto& m : kModels) out += (out.empty() ? "" : ", ") + std::string(m.name);
  return out;
}

const char* velodyne_other_product(std::uint8_t product_id) {
  switch (product_id) {
    case 0x23: return "VLP-32A/B";
    case 0x31: return "Velarray";
    default: return nullptr;
  }
}

VelodyneLayout velodyne_layout(const VelodyneModel& model, bool dual) {
  VelodyneLayout l;
  l.dual = dual;
  // Blocks per column in single-return mode, and how far apart partner blocks sit in dual mode.
  int per_column = 1, partner_step = 1;
  switch (model.family) {
    case VelodyneFamily::Vlp16: l.column_us = 110.592f; vlp16(l); break;
    case VelodyneFamily::Vlp32C: l.column_us = 55.296f; sequential(l, 2.304f, true); break;
    case VelodyneFamily::Hdl32E: l.column_us = 46.08f; sequential(l, 1.152f, false); break;
    case VelodyneFamily::Hdl64E_S2:
      l.column_us = 48.0f, per_column = 2, partner_step = 2;
      hdl64e(l, 6.0f, {0.0f, 1.26f, 2.46f, 3.66f});
      break;
    case VelodyneFamily::Hdl64E_S3:
      l.column_us = 57.6f, per_column = 2, partner_step = 2;
      hdl64e(l, 7.2f, {0.0f, 1.3f, 2.5f, 3.7f});
      break;
    case VelodyneFamily::Vls128: l.column_us = 53.3f, l.toh_lag_us = 8.7f, per_column = 4; vls128(l); break;
  }
  l.interp_div = model.family == VelodyneFamily::Vls128 ? 1.0f : l.column_us;
  const int blocks_per_column = dual ? 2 * per_column : per_column;
  const bool padded = dual && model.family == VelodyneFamily::Vls128;
  for (int b = 0; b < kVelodyneBlocks; ++b) {
    auto& block = l.blocks[b];
    block.used = !padded || b < 8;
    block.column = static_cast<std::uint8_t>(padded ? 0 : b / blocks_per_column);
    block.partner = static_cast<std::uint8_t>(dual ? b ^ partner_step : b);
    switch (model.family) {
      case VelodyneFamily::Hdl64E_S2:
      case VelodyneFamily::Hdl64E_S3: block.flag = kBankFlags[b % 2]; break;
      case VelodyneFamily::Vls128: block.flag = kBankFlags[dual ? (b / 2) % 4 : b % 4]; break;
      default: block.flag = kBankFlags[0];
    }
  }
  l.columns = padded ? 1 : kVelodyneBlocks / blocks_per_column;
  for (int b = 0; b < kVelodyneBlocks; ++b)
    for (int j = 0; j < kVelodyneSlots; ++j) {
      const double us = static_cast<double>(l.blocks[b].column) * l.column_us + l.offset_us[b][j] - l.toh_lag_us;
      l.firing_ns[b][j] = static_cast<std::int32_t>(std::lround(us * 1000));
    }
  return l;
}

}  // namespace pl::lidar
