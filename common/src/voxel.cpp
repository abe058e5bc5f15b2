#include "pl/common/voxel.hpp"

#include <cmath>
#include <array>
#include <cstdint>
#include <limits>
#include <unordered_map>

#include "pl/common/error.hpp"

namespace pl {
namespace {

struct Sums {
  double x, y, z, v;
  std::uint32_t n;
};

struct TripleHash {
  std::size_t operator()(const std::array<std::int64_t, 3>& k) const {
    std::uint64_t h = static_cast<std::uint64_t>(k[0]) * 0x9E3779B97F4A7C15ull;
    h ^= static_cast<std::uint64_t>(k[1]) * 0xC2B2AE3D27D4EB4Full + (h << 6) + (h >> 2);
    h ^= static_cast<std::uint64_t>(k[2]) * 0x165667B19E3779F9ull + (h << 6) + (h >> 2);
    return static_cast<std::size_t>(h);
  }
};

// Accumulates point i (x, y, z, value) of `get` into per-voxel sums, in first-seen voxel order.
template <typename Get>
std::vector<Sums> accumulate(std::size_t n, Get&& get, double voxel) {
  if (!(voxel > 0.0) || !std::isfinite(voxel)) throw Error("voxel size must be a positive number of metres");
  std::vector<Sums> sums;
  if (n == 0) return sums;
  const double inv = 1.0 / voxel;
  auto index = [inv](double c) {
    double f = std::floor(c * inv);
    if (!(std::abs(f) < 4.0e18)) throw Error("coordinate " + std::to_string(c) + " is too large or not finite for voxelization");
    return static_cast<std::int64_t>(f);
  };

  std::int64_t lo[3] = {std::numeric_limits<std::int64_t>::max(), std::numeric_limits<std::int64_t>::max(),
                        std::numeric_limits<std::int64_t>::max()};
  std::int64_t hi[3] = {std::numeric_limits<std::int64_t>::min(), std::numeric_limits<std::int64_t>::min(),
                        std::numeric_limits<std::int64_t>::min()};
  for (std::size_t i = 0; i < n; ++i) {
    double x, y, z, v;
    get(i, x, y, z, v);
    std::int64_t k[3] = {index(x), index(y), index(z)};
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], k[a]);
      hi[a] = std::max(hi[a], k[a]);
    }
  }
  constexpr std::uint64_t kSpan = 1ull << 21;
  bool packable = true;
  for (int a = 0; a < 3; ++a) packable &= static_cast<std::uint64_t>(hi[a] - lo[a]) < kSpan;

  sums.reserve(n / 2 + 16);
  auto add = [&sums](std::uint32_t slot, double x, double y, double z, double v) {
    Sums& s = sums[slot];
    s.x += x, s.y += y, s.z += z, s.v += v, ++s.n;
  };

  if (packable) {
    // Open addressing over 63-bit keys relative to the lowest voxel; capacity >= 2n keeps probes short.
    std::size_t cap = 16;
    while (cap < 2 * n) cap <<= 1;
    int shift = 64 - __builtin_ctzll(cap);
    const std::uint64_t kEmpty = ~0ull;
    std::vector<std::uint64_t> keys(cap, kEmpty);
    std::vector<std::uint32_t> slots(cap);
    for (std::size_t i = 0; i < n; ++i) {
      double x, y, z, v;
      get(i, x, y, z, v);
      std::uint64_t key = static_cast<std::uint64_t>(index(x) - lo[0]) | static_cast<std::uint64_t>(index(y) - lo[1]) << 21 |
                          static_cast<std::uint64_t>(index(z) - lo[2]) << 42;
      std::size_t h = static_cast<std::size_t>((key * 0x9E3779B97F4A7C15ull) >> shift);
      while (true) {
        if (keys[h] == key) {
          add(slots[h], x, y, z, v);
          break;
        }
        if (keys[h] == kEmpty) {
          keys[h] = key;
          slots[h] = static_cast<std::uint32_t>(sums.size());
          sums.push_back({x, y, z, v, 1});
          break;
        }
        h = (h + 1) & (cap - 1);
      }
    }
  } else {
    // Clouds wider than 2^21 voxels on an axis: full 64-bit indices in a general hash map.
    std::unordered_map<std::array<std::int64_t, 3>, std::uint32_t, TripleHash> map;
    map.reserve(n);
    for (std::size_t i = 0; i < n; ++i) {
      double x, y, z, v;
      get(i, x, y, z, v);
      auto [it, fresh] = map.try_emplace({index(x), index(y), index(z)}, static_cast<std::uint32_t>(sums.size()));
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
  auto sums = accumulate(
      scan.size(),
      [&scan](std::size_t i, double& x, double& y, double& z, double& v) {
        const PointXYZI& p = scan[i];
        x = p.x, y = p.y, z = p.z, v = p.intensity;
      },
      voxel_m);
  Scan out(sums.size());
  for (std::size_t i = 0; i < sums.size(); ++i) {
    double k = 1.0 / sums[i].n;
    out[i] = {static_cast<float>(sums[i].x * k), static_cast<float>(sums[i].y * k), static_cast<float>(sums[i].z * k),
              static_cast<float>(sums[i].v * k)};
  }
  return out;
}

Points3d voxel_downsample(const Points3d& points, const std::vector<float>& values, double voxel_m,
                          std::vector<float>& values_out) {
  if (!values.empty() && values.size() != points.size()) throw Error("voxel_downsample: one value per point expected");
  auto sums = accumulate(
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
