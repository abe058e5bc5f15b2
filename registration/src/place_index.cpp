// Places of a map: their encoding and the proposals for a new scan.
#include "pl/registration/place_index.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>

#include "pl/common/error.hpp"

namespace pl::registration {
namespace {

// "PLPL", a format number, the grid, then one record per place.
constexpr char kMagic[4] = {'P', 'L', 'P', 'L'};
constexpr std::uint32_t kFormat = 1;
constexpr std::size_t kHeader = 4 + 4 + 4 + 4 + 8 + 8 + 4;
constexpr std::size_t kPoseBytes = 4 * 8;
constexpr double kHeightStep = 0.1;  // a cell's height in steps of this (1..255; 0: empty)
constexpr int kMaxCells = 100000;

void put_u32(std::string& out, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) out.push_back(static_cast<char>((v >> (8 * i)) & 0xff));
}

void put_f64(std::string& out, double v) {
  std::uint64_t bits;
  std::memcpy(&bits, &v, sizeof bits);
  for (int i = 0; i < 8; ++i) out.push_back(static_cast<char>((bits >> (8 * i)) & 0xff));
}

class Reader {
 public:
  Reader(std::string_view bytes, const std::string& source) : b_(bytes), source_(source) {}
  [[noreturn]] void fail(const std::string& what) const {
    throw Error(source_ + ": places damaged at byte " + std::to_string(at_) + ": " + what +
                " (rebuild them with pl-map build, then pl-map tile)");
  }
  void need(std::size_t n) const {
    if (b_.size() - at_ < n) fail("the file ends early (" + std::to_string(b_.size()) + " bytes)");
  }
  std::uint32_t u32() {
    need(4);
    std::uint32_t v = 0;
    for (int i = 0; i < 4; ++i) v |= static_cast<std::uint32_t>(static_cast<unsigned char>(b_[at_ + i])) << (8 * i);
    at_ += 4;
    return v;
  }
  double f64() {
    need(8);
    std::uint64_t bits = 0;
    for (int i = 0; i < 8; ++i) bits |= static_cast<std::uint64_t>(static_cast<unsigned char>(b_[at_ + i])) << (8 * i);
    at_ += 8;
    double v;
    std::memcpy(&v, &bits, sizeof v);
    return v;
  }
  double finite(const char* what) {
    const double v = f64();
    if (!std::isfinite(v)) {
      at_ -= 8;
      fail(std::string(what) + " is not a finite number");
    }
    return v;
  }
  unsigned char byte() {
    need(1);
    return static_cast<unsigned char>(b_[at_++]);
  }
  std::size_t at() const { return at_; }
  std::size_t left() const { return b_.size() - at_; }

 private:
  std::string_view b_;
  const std::string& source_;
  std::size_t at_ = 0;
};

void fill_ring_key(PlaceDescriptor& d) {
  d.ring_key.assign(static_cast<std::size_t>(d.rings), 0.0f);
  for (int r = 0; r < d.rings; ++r) {
    double sum = 0;
    for (int s = 0; s < d.sectors; ++s) sum += d.cells[static_cast<std::size_t>(r * d.sectors + s)];
    d.ring_key[static_cast<std::size_t>(r)] = static_cast<float>(sum / d.sectors);
  }
}

}  // namespace

double heading_of(const Eigen::Isometry3d& pose) {
  const Eigen::Vector3d x = pose.linear().col(0);
  return std::atan2(x.y(), x.x());
}

Eigen::Matrix3d levelling(const Eigen::Isometry3d& pose) {
  return Eigen::AngleAxisd(-heading_of(pose), Eigen::Vector3d::UnitZ()).toRotationMatrix() * pose.linear();
}

PlaceDescriptor levelled_descriptor(const std::vector<Eigen::Vector3f>& points, const Eigen::Isometry3d& pose,
                                    const PlaceDescriptorConfig& cfg) {
  const Eigen::Matrix3d level = levelling(pose);
  std::vector<Eigen::Vector3f> levelled;
  levelled.reserve(points.size());
  for (const auto& p : points) levelled.push_back((level * p.cast<double>()).cast<float>());
  return make_place_descriptor(levelled, cfg);
}

PlaceIndex::PlaceIndex(const PlaceDescriptorConfig& cfg, std::vector<Place> places) : cfg_(cfg), places_(std::move(places)) {
  const std::size_t cells = static_cast<std::size_t>(cfg.rings) * static_cast<std::size_t>(std::max(cfg.sectors, 0));
  for (const Place& p : places_) {
    if (p.descriptor.rings != cfg.rings || p.descriptor.sectors != cfg.sectors || p.descriptor.cells.size() != cells)
      throw Error("place index: a descriptor is not of the index's " + std::to_string(cfg.rings) + " x " +
                  std::to_string(cfg.sectors) + " grid");
    if (!p.position.allFinite() || !std::isfinite(p.yaw)) throw Error("place index: a place's pose is not finite");
  }
}

std::string PlaceIndex::encode() const {
  std::string out;
  const std::size_t cells = static_cast<std::size_t>(cfg_.rings * cfg_.sectors);
  out.reserve(kHeader + places_.size() * (kPoseBytes + cells));
  out.append(kMagic, 4);
  put_u32(out, kFormat);
  put_u32(out, static_cast<std::uint32_t>(cfg_.rings));
  put_u32(out, static_cast<std::uint32_t>(cfg_.sectors));
  put_f64(out, cfg_.max_range_m);
  put_f64(out, cfg_.height_offset_m);
  put_u32(out, static_cast<std::uint32_t>(places_.size()));
  for (const Place& p : places_) {
    put_f64(out, p.position.x());
    put_f64(out, p.position.y());
    put_f64(out, p.position.z());
    put_f64(out, p.yaw);
    for (const float h : p.descriptor.cells) {
      const long q = h > 0 ? std::clamp(std::lround(h / kHeightStep), 1L, 255L) : 0L;
      out.push_back(static_cast<char>(q));
    }
  }
  return out;
}

PlaceIndex PlaceIndex::decode(std::string_view bytes, const std::string& source) {
  if (bytes.size() < 4 || std::memcmp(bytes.data(), kMagic, 4) != 0)
    throw Error(source + ": not a places file (no PLPL header): give the places pl-map build wrote beside its map");
  Reader in(bytes.substr(4), source);
  const std::uint32_t format = in.u32();
  if (format != kFormat)
    throw Error(source + ": places of format " + std::to_string(format) + ", this build reads format " + std::to_string(kFormat) +
                ": rebuild them with this pl-map");
  const std::uint32_t rings = in.u32(), sectors = in.u32();
  if (rings < 1 || sectors < 4 || static_cast<std::uint64_t>(rings) * sectors > kMaxCells)
    in.fail("a grid of " + std::to_string(rings) + " x " + std::to_string(sectors) + " (needs rings >= 1, sectors >= 4, at most " +
            std::to_string(kMaxCells) + " cells)");
  PlaceDescriptorConfig cfg;
  cfg.rings = static_cast<int>(rings);
  cfg.sectors = static_cast<int>(sectors);
  cfg.max_range_m = in.finite("the range");
  if (!(cfg.max_range_m > 0)) in.fail("the range is not positive");
  cfg.height_offset_m = in.finite("the height offset");
  const std::uint32_t count = in.u32();
  const std::size_t cells = static_cast<std::size_t>(rings) * sectors;
  const std::size_t record = kPoseBytes + cells;
  if (in.left() != static_cast<std::size_t>(count) * record)
    in.fail(std::to_string(count) + " places of " + std::to_string(record) + " bytes need " +
            std::to_string(static_cast<std::uint64_t>(count) * record) + " bytes, the file has " + std::to_string(in.left()));
  std::vector<Place> places(count);
  for (Place& p : places) {
    p.position.x() = in.finite("a place's x");
    p.position.y() = in.finite("a place's y");
    p.position.z() = in.finite("a place's z");
    p.yaw = in.finite("a place's heading");
    p.descriptor.rings = cfg.rings;
    p.descriptor.sectors = cfg.sectors;
    p.descriptor.cells.resize(cells);
    for (float& h : p.descriptor.cells) h = static_cast<float>(in.byte() * kHeightStep);
    fill_ring_key(p.descriptor);
  }
  return PlaceIndex(cfg, std::move(places));
}

std::vector<PlaceProposal> PlaceIndex::propose(const PlaceDescriptor& scan, std::size_t count, const Eigen::Vector2d& center,
                                               double radius_m) const {
  if (scan.rings != cfg_.rings || scan.sectors != cfg_.sectors)
    throw Error("place index: the scan's descriptor is not of the index's grid (make it with the index's config())");
  std::vector<std::pair<double, std::size_t>> keyed;
  for (std::size_t i = 0; i < places_.size(); ++i) {
    if (radius_m > 0 && (places_[i].position.head<2>() - center).norm() > radius_m) continue;
    keyed.emplace_back(ring_key_distance(scan, places_[i].descriptor), i);
  }
  const std::size_t full = std::min(keyed.size(), std::max<std::size_t>(50, places_.size() / 10));
  std::partial_sort(keyed.begin(), keyed.begin() + static_cast<std::ptrdiff_t>(full), keyed.end());
  std::vector<PlaceProposal> out;
  for (std::size_t k = 0; k < full; ++k) {
    const Place& p = places_[keyed[k].second];
    const DescriptorMatch m = compare_descriptors(scan, p.descriptor);
    if (m.distance >= 1.0) continue;
    PlaceProposal prop;
    prop.place = keyed[k].second;
    prop.distance = m.distance;
    prop.pose = Eigen::Translation3d(p.position) * Eigen::AngleAxisd(p.yaw + m.yaw_rad, Eigen::Vector3d::UnitZ());
    out.push_back(prop);
  }
  std::sort(out.begin(), out.end(), [](const PlaceProposal& a, const PlaceProposal& b) {
    return a.distance != b.distance ? a.distance < b.distance : a.place < b.place;
  });
  if (out.size() > count) out.resize(count);
  return out;
}

}  // namespace pl::registration
