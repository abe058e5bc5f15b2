// Polar height grid (Scan Context style) and its shift-searched comparison.
#include "pl/registration/place_descriptor.hpp"

#include <algorithm>
#include <cmath>

#include "pl/common/error.hpp"

namespace pl::registration {

PlaceDescriptor make_place_descriptor(const std::vector<Eigen::Vector3f>& points, const PlaceDescriptorConfig& cfg) {
  if (cfg.rings < 1 || cfg.sectors < 4 || !(cfg.max_range_m > 0)) throw Error("place descriptor: needs rings >= 1, sectors >= 4, a positive range");
  PlaceDescriptor d;
  d.rings = cfg.rings;
  d.sectors = cfg.sectors;
  d.cells.assign(static_cast<std::size_t>(cfg.rings * cfg.sectors), 0.0f);
  const double ring_w = cfg.max_range_m / cfg.rings, sector_w = 2.0 * M_PI / cfg.sectors;
  for (const Eigen::Vector3f& p : points) {
    const double r = std::hypot(p.x(), p.y());
    if (!(r < cfg.max_range_m) || r < 1e-3) continue;
    double phi = std::atan2(p.y(), p.x());
    if (phi < 0) phi += 2.0 * M_PI;
    const int ring = std::min(static_cast<int>(r / ring_w), cfg.rings - 1);
    const int sector = std::min(static_cast<int>(phi / sector_w), cfg.sectors - 1);
    // Heights below the offset floor count as a small positive value: the bin is still occupied.
    const float h = std::max(static_cast<float>(p.z() + cfg.height_offset_m), 1e-3f);
    float& cell = d.cells[static_cast<std::size_t>(ring * cfg.sectors + sector)];
    cell = std::max(cell, h);
  }
  d.ring_key.assign(static_cast<std::size_t>(cfg.rings), 0.0f);
  for (int r = 0; r < cfg.rings; ++r) {
    double sum = 0;
    for (int s = 0; s < cfg.sectors; ++s) sum += d.cells[static_cast<std::size_t>(r * cfg.sectors + s)];
    d.ring_key[static_cast<std::size_t>(r)] = static_cast<float>(sum / cfg.sectors);
  }
  return d;
}

DescriptorMatch compare_descriptors(const PlaceDescriptor& a, const PlaceDescriptor& b) {
  if (a.rings != b.rings || a.sectors != b.sectors || a.cells.size() != b.cells.size())
    throw Error("place descriptors of different sizes cannot be compared");
  const int nr = a.rings, ns = a.sectors;
  // Column norms, once.
  std::vector<double> na(static_cast<std::size_t>(ns), 0.0), nb(static_cast<std::size_t>(ns), 0.0);
  for (int s = 0; s < ns; ++s)
    for (int r = 0; r < nr; ++r) {
      const double va = a.cells[static_cast<std::size_t>(r * ns + s)], vb = b.cells[static_cast<std::size_t>(r * ns + s)];
      na[static_cast<std::size_t>(s)] += va * va;
      nb[static_cast<std::size_t>(s)] += vb * vb;
    }
  for (double& v : na) v = std::sqrt(v);
  for (double& v : nb) v = std::sqrt(v);
  DescriptorMatch best;
  for (int shift = 0; shift < ns; ++shift) {
    // Sector s of `a` against sector s + shift of `b`.
    double sum = 0;
    int both = 0;
    for (int s = 0; s < ns; ++s) {
      const int t = (s + shift) % ns;
      const double ma = na[static_cast<std::size_t>(s)], mb = nb[static_cast<std::size_t>(t)];
      if (ma <= 0 || mb <= 0) continue;
      double dot = 0;
      for (int r = 0; r < nr; ++r)
        dot += static_cast<double>(a.cells[static_cast<std::size_t>(r * ns + s)]) * b.cells[static_cast<std::size_t>(r * ns + t)];
      // A column against itself can round to just below 0: the distance of a cosine is never negative.
      sum += std::max(0.0, 1.0 - dot / (ma * mb));
      ++both;
    }
    if (both * 4 < ns) continue;
    const double d = sum / both;
    if (d < best.distance) {
      best.distance = d;
      // a's sector s sees what b's sector s + shift sees: b's azimuth phi is a's phi - shift * width.
      double yaw = shift * 2.0 * M_PI / ns;
      if (yaw > M_PI) yaw -= 2.0 * M_PI;
      best.yaw_rad = yaw;
    }
  }
  return best;
}

double ring_key_distance(const PlaceDescriptor& a, const PlaceDescriptor& b) {
  if (a.ring_key.size() != b.ring_key.size()) throw Error("place descriptors of different sizes cannot be compared");
  double d = 0;
  for (std::size_t i = 0; i < a.ring_key.size(); ++i) d += static_cast<double>(a.ring_key[i] - b.ring_key[i]) * (a.ring_key[i] - b.ring_key[i]);
  return d;
}

}  // namespace pl::registration
