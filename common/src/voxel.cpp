#include "pl/common/voxel.hpp"

#include <cmath>
#include <array>
#include <cstdint>
#include <limits>
#include <unordered_map>

#include "pl/common/error.hpp"

namespace pl {
namespace {

// Per-voxel sums: float for sensor-frame scans (tens of metres, a few points a voxel), double for
// map clouds whose coordinates may be hundreds of kilometres.
template <typename Real>
struct Sums {
  Real x, y, z, v;
  std::uint32_t n;
};


// floor() for |v| < 2^62 without a libm call (baseline x86-64 has no rounding instruction).
inline std::int64_t fast_floor(double v) {
  auto i = static_cast<std::int64_t>(v);
  return i - (v < static_cast<double>(i));
}

// Accumulates point i (x, y, z, value) of `get` into per-voxel sums, in first-seen voxel order.
template <typename Real, typename Get>
std::vector<Sums<Real>> accumulate(std::size_t n, Get&& get, double voxel) {
  if (!(voxel > 0.0) || !std::isfinite(voxel)) throw Error("voxel size must be a positive number of metres");
  std::vector<Sums<Real>> sums;
  if (n == 0) return sums;
  const double inv = 1.0 / voxel;

  // Bounds first: floor is monotonic, so the lowest voxel index is floor(min * inv).
  Real lx = INFINITY, ly = INFINITY, lz = INFINITY, hx = -INFINITY, hy = -INFINITY, hz = -INFINITY;
  for (std::size_t i = 0; i < n; ++i) {
    Real x, y, z, v;
    get(i, x, y, z, v);
    lx = std::min(lx, x), ly = std::min(ly, y), lz = std::min(lz, z);
    hx = std::max(hx, x), hy = std::max(hy, y), hz = std::max(hz, z);
  }
  const Real lo_c[3] = {lx, ly, lz}, hi_c[3] = {hx, hy, hz};
  std::int64_t lo[3], span[3];
  for (int a = 0; a < 3; ++a) {
    if (!(std::abs(lo_c[a] * inv) < 4.0e18 && std::abs(hi_c[a] * inv) < 4.0e18))
      throw Error("coordinates of " + std::to_string(lo_c[a]) + " to " + std::to_string(hi_c[a]) +
                  " m are too large or not finite for " + std::to_string(voxel) + " m voxels");
    lo[a] = fast_floor(lo_c[a] * inv);
    span[a] = fast_floor(hi_c[a] * inv) - lo[a] + 1;
  }
  // Mixed-radix key over the cloud's own box of voxels: fits 40 bits for any box of up to 2^40
  // voxels (a 2 km x 2 km x 100 m map at 0.1 m), leaving 24 bits of the table entry for the slot.
  constexpr std::uint64_t kKeyBits = 40, kSlotBits = 24;
  double cells = static_cast<double>(span[0]) * static_cast<double>(span[1]) * static_cast<double>(span[2]);
  bool packable = cells < static_cast<double>(1ull << kKeyBits) && n < (1ull << kSlotBits);

  sums.reserve(n / 3 + 16);
  auto add = [&sums](std::uint32_t slot, Real x, Real y, Real z, Real v) {
    Sums<Real>& s = sums[slot];
    s.x += x, s.y += y, s.z += z, s.v += v, ++s.n;
  };

  if (packable) {
    // Open addressing; an entry is key << 24 | slot. The table is scratch memory reused by the next
    // call on this thread (a fresh allocation per scan costs more in page faults than the hashing)
    // and doubles whenever it is two-thirds full.
    constexpr std::uint64_t kEmpty = ~0ull, kSlotMask = (1ull << kSlotBits) - 1;
    std::size_t cap = 1024;
    while (cap < n / 2) cap <<= 1;
    thread_local std::vector<std::uint64_t> table;
    table.assign(cap, kEmpty);
    int shift = 64 - __builtin_ctzll(cap);
    auto home = [&](std::uint64_t key) { return static_cast<std::size_t>((key * 0x9E3779B97F4A7C15ull) >> shift); };
    const std::uint64_t sy = static_cast<std::uint64_t>(span[2]), sx = sy * static_cast<std::uint64_t>(span[1]);
    // Scans are stored ring by ring, so neighbouring points mostly share a voxel: remember the last one.
    std::uint64_t last_key = kEmpty;
    std::uint32_t last_slot = 0;
    // x * inv >= lo, so x * inv - lo >= 0 and truncation is the floor: no compare, no libm call.
    const double lox = static_cast<double>(lo[0]), loy = static_cast<double>(lo[1]), loz = static_cast<double>(lo[2]);
    for (std::size_t i = 0; i < n; ++i) {
      Real x, y, z, v;
      get(i, x, y, z, v);
      std::uint64_t key = static_cast<std::uint64_t>(x * inv - lox) * sx + static_cast<std::uint64_t>(y * inv - loy) * sy +
                          static_cast<std::uint64_t>(z * inv - loz);
      if (key == last_key) {
        add(last_slot, x, y, z, v);
        continue;
      }
      last_key = key;
      for (std::size_t h = home(key);; h = (h + 1) & (cap - 1)) {
        std::uint64_t e = table[h];
        if (e == kEmpty) {
          last_slot = static_cast<std::uint32_t>(sums.size());
          table[h] = key << kSlotBits | last_slot;
          sums.push_back({x, y, z, v, 1});
          if (3 * sums.size() > 2 * cap) {  // grow and re-insert
            cap <<= 1;
            shift = 64 - __builtin_ctzll(cap);
            std::vector<std::uint64_t> old(cap, kEmpty);
            old.swap(table);
            for (std::uint64_t o : old) {
              if (o == kEmpty) continue;
              std::size_t g = home(o >> kSlotBits);
              while (table[g] != kEmpty) g = (g + 1) & (cap - 1);
              table[g] = o;
            }
          }
          break;
        }
        if (e >> kSlotBits == key) {
          last_slot = static_cast<std::uint32_t>(e & kSlotMask);
          add(last_slot, x, y, z, v);
          break;
        }
      }
    }
  } else {
    // Clouds of more than 2^40 voxels or 2^24 points: full 64-bit indices in a general hash map.
    std::unordered_map<VoxelIndex, std::uint32_t, VoxelIndexHash> map;
    map.reserve(n);
    for (std::size_t i = 0; i < n; ++i) {
      Real x, y, z, v;
      get(i, x, y, z, v);
      auto [it, fresh] = map.try_emplace({fast_floor(x * inv), fast_floor(y * inv), fast_floor(z * inv)},
                                         static_cast<std::uint32_t>(sums.size()));
      if (fresh)
        sums.push_back({x, y, z, v, 1});
      else
        add(it->second, x, y, z, v);
    }
  }
  return sums;
}

}  // namespace

Scan voxel_downsample(const Scan& scan, double voxel_m) {
  auto sums = accumulate<float>(
      scan.size(),
      [&scan](std::size_t i, float& x, float& y, float& z, float& v) {
        const PointXYZI& p = scan[i];
        x = p.x, y = p.y, z = p.z, v = p.intensity;
      },
      voxel_m);
  Scan out(sums.size());
  for (std::size_t i = 0; i < sums.size(); ++i) {
    float k = 1.0f / static_cast<float>(sums[i].n);
    out[i] = {sums[i].x * k, sums[i].y * k, sums[i].z * k, sums[i].v * k};
  }
  return out;
}

Points3d voxel_downsample(const Points3d& points, const std::vector<float>& values, double voxel_m,
                          std::vector<float>& values_out) {
  if (!values.empty() && values.size() != points.size()) throw Error("voxel_downsample: one value per point expected");
  auto sums = accumulate<double>(
      points.size(),
      [&](std::size_t i, double& x, double& y, double& z, double& v) {
        x = points[i].x(), y = points[i].y(), z = points[i].z();
        v = values.empty() ? 0.0 : values[i];
      },
      voxel_m);
  Points3d out(sums.size());
  values_out.resize(values.empty() ? 0 : sums.size());
  for (std::size_t i = 0; i < sums.size(); ++i) {
    double k = 1.0 / sums[i].n;
    out[i] = Eigen::Vector3d(sums[i].x * k, sums[i].y * k, sums[i].z * k);
    if (!values.empty()) values_out[i] = static_cast<float>(sums[i].v * k);
  }
  return out;
}

Points3d voxel_downsample(const Points3d& points, double voxel_m) {
  std::vector<float> none;
  return voxel_downsample(points, {}, voxel_m, none);
}

}  // namespace pl
