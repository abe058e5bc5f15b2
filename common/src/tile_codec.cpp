// Draco encoding of map tiles. See tile_codec.hpp for the contract; the notes here are about how.
//
// Positions: float32 offsets from a whole-metre tile origin (kept exactly, as doubles, in the geometry
// metadata entry "pl.origin"), quantized explicitly on the cloud's own box with the fewest bits that
// keep the error within cfg.max_error_m (float32 rounding is budgeted for).
// Normals: Draco NORMAL attribute, cfg.normal_bits (octahedral in the sequential coder; the k-d tree
// coder quantizes each component with that many bits instead). Intensity: a GENERIC float attribute
// named "intensity" in its attribute metadata, cfg.intensity_bits on the values' own range.
// Points are sorted (Hilbert order of the quantized positions, then every other field) so that equal
// sets of points give equal bytes. Unless cfg.speed is 10 (Draco's "sequential only"), both of
// Draco's point cloud coders are run and the smaller output is kept: at speeds up to 4 the k-d tree
// coder wins on positions alone and on smooth normals, the sequential one (octahedral normals, delta
// prediction along the Hilbert order) wins once noisy normals and intensity come along.
// Decoding walks the stream's header first and refuses declared sizes Draco would allocate gigabytes
// for (see check_stream), then lets Draco decode, dequantizing positions itself straight to doubles.
#include "pl/common/tile_codec.hpp"

#include <draco/compression/attributes/normal_compression_utils.h>
#include <draco/compression/decode.h>
#include <draco/compression/expert_encode.h>
#include <draco/point_cloud/point_cloud.h>
#include <draco/point_cloud/point_cloud_builder.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <memory>
#include <mutex>
#include <numeric>

#include "pl/common/error.hpp"
#include "tile_stream.hpp"

namespace pl {
namespace {

using tile_stream::check_stream;
using tile_stream::invalid;

constexpr const char* kOriginKey = "pl.origin";
constexpr const char* kNameKey = "name";  // Draco's usual attribute metadata key for a name
constexpr const char* kIntensityName = "intensity";
constexpr int kMaxPositionBits = 30;  // Draco's limit for quantization bits


void check_config(const TileCodecConfig& cfg) {
  if (!(std::isfinite(cfg.max_error_m) && cfg.max_error_m > 0))
    throw Error("tile codec: max_error_m must be a positive number, got " + std::to_string(cfg.max_error_m));
  if (cfg.normal_bits != 0 && (cfg.normal_bits < 2 || cfg.normal_bits > 30))
    throw Error("tile codec: normal_bits must be 0 (none stored) or in [2, 30], got " + std::to_string(cfg.normal_bits));
  if (cfg.intensity_bits < 0 || cfg.intensity_bits > 30)
    throw Error("tile codec: intensity_bits must be 0 (none stored) or in [1, 30], got " + std::to_string(cfg.intensity_bits));
  if (cfg.speed < 0 || cfg.speed > 10)
    throw Error("tile codec: speed must be in [0, 10], got " + std::to_string(cfg.speed));
}

void check_cloud(const TileCloud& cloud) {
  const std::size_t n = cloud.points.size();
  if (n > static_cast<std::size_t>(std::numeric_limits<int32_t>::max()))
    throw Error("tile codec: too many points for Draco (" + std::to_string(n) + ")");
  if (!cloud.normals.empty() && cloud.normals.size() != n)
    throw Error("tile codec: " + std::to_string(cloud.normals.size()) + " normals for " + std::to_string(n) +
                " points (give one per point, or none)");
  if (!cloud.intensity.empty() && cloud.intensity.size() != n)
    throw Error("tile codec: " + std::to_string(cloud.intensity.size()) + " intensity values for " +
                std::to_string(n) + " points (give one per point, or none)");
  for (std::size_t i = 0; i < n; ++i)
    if (!cloud.points[i].allFinite()) throw Error("tile codec: point " + std::to_string(i) + " is not finite");
  for (std::size_t i = 0; i < cloud.normals.size(); ++i) {
    if (!cloud.normals[i].allFinite()) throw Error("tile codec: normal " + std::to_string(i) + " is not finite");
    if (!(cloud.normals[i].cast<double>().norm() > 1e-6))
      throw Error("tile codec: normal " + std::to_string(i) + " has zero length");
  }
  for (std::size_t i = 0; i < cloud.intensity.size(); ++i)
    if (!std::isfinite(cloud.intensity[i]))
      throw Error("tile codec: intensity " + std::to_string(i) + " is not finite");
  if (!cloud.intensity.empty()) {  // Draco quantizes on the float32 range of the values
    const auto [lo, hi] = std::minmax_element(cloud.intensity.begin(), cloud.intensity.end());
    if (!std::isfinite(*hi - *lo))
      throw Error("tile codec: intensity values span more than float32 can hold (" + std::to_string(*lo) + " to " +
                  std::to_string(*hi) + ")");
  }
}

// The explicit quantization of the positions: a whole-metre origin (double), and Draco's
// quantization box in offsets from it (float32, as Draco stores it).
struct PositionQuantization {
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  Eigen::Vector3d min = Eigen::Vector3d::Zero();  // the box's low corner, ENU
  float box_min[3] = {0, 0, 0};                   // low corner as offsets from origin
  float range = 1;                                // one range for all three axes
  int bits = 1;
  double step = 1;  // range / (2^bits - 1)
};

PositionQuantization quantize_positions(const std::vector<Eigen::Vector3d>& points, double max_error) {
  PositionQuantization q;
  if (points.empty()) {
    q.step = q.range;
    return q;
  }
  Eigen::Vector3d lo = points.front(), hi = points.front();
  for (const auto& p : points) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  q.origin = lo.array().floor() + 0.0;  // (+ 0.0: no -0 in the bytes, equal tiles give equal bytes)
  q.min = lo;
  const double extent = (hi - lo).maxCoeff();
  // Float32 rounding: the offset, Draco's subtraction, scaling and rounding on encode, scaling and
  // addition on decode each err by about half an ulp of numbers up to extent + 1 m. Budget 16 ulps.
  const double slack = 16.0 * std::ldexp(1.0, -24) * (extent + 1.0);
  const double budget = max_error - slack;
  if (budget <= 0)
    throw Error("tile codec: max_error_m " + std::to_string(max_error) + " cannot be met with float32 offsets in a " +
                std::to_string(extent) + " m box (use at least " + std::to_string(2 * slack) + " m)");
  // Draco divides by the range: keep it positive (and no smaller than the extent after rounding).
  float range = static_cast<float>(std::max(extent, budget));
  if (static_cast<double>(range) < extent) range = std::nextafter(range, std::numeric_limits<float>::infinity());
  int bits = 1;
  while (static_cast<double>(range) / (std::ldexp(1.0, bits) - 1.0) / 2.0 > budget) {
    if (++bits > kMaxPositionBits)
      throw Error("tile codec: max_error_m " + std::to_string(max_error) + " needs more than " +
                  std::to_string(kMaxPositionBits) + " bits in a " + std::to_string(extent) + " m box");
  }
  for (int c = 0; c < 3; ++c) q.box_min[c] = static_cast<float>(lo[c] - q.origin[c]) + 0.0f;
  q.range = range;
  q.bits = bits;
  q.step = static_cast<double>(range) / (std::ldexp(1.0, bits) - 1.0);
  return q;
}

// Position of an integer point along the 3-D Hilbert curve of 2^bits cells a side (Skilling's
// transposition: undo the excess work, Gray-encode, then read the bits out axis by axis). Bits up to
// 30 a component make a 90-bit index, kept in two words.
struct HilbertKey {
  uint64_t hi = 0, lo = 0;
  bool operator<(const HilbertKey& o) const { return hi != o.hi ? hi < o.hi : lo < o.lo; }
  bool operator!=(const HilbertKey& o) const { return hi != o.hi || lo != o.lo; }
};

HilbertKey hilbert_key(uint32_t x, uint32_t y, uint32_t z, int bits) {
  uint32_t v[3] = {x, y, z};
  const uint32_t top = uint32_t{1} << (bits - 1);
  for (uint32_t q = top; q > 1; q >>= 1) {
    const uint32_t low_mask = q - 1;
    for (int i = 0; i < 3; ++i) {
      if (v[i] & q) {
        v[0] ^= low_mask;
      } else {
        const uint32_t t = (v[0] ^ v[i]) & low_mask;
        v[0] ^= t;
        v[i] ^= t;
      }
    }
  }
  for (int i = 1; i < 3; ++i) v[i] ^= v[i - 1];
  uint32_t flip = 0;
  for (uint32_t q = top; q > 1; q >>= 1)
    if (v[2] & q) flip ^= q - 1;
  for (int i = 0; i < 3; ++i) v[i] ^= flip;
  HilbertKey key;
  for (int b = bits - 1; b >= 0; --b)
    for (int i = 0; i < 3; ++i) {
      key.hi = (key.hi << 1) | (key.lo >> 63);
      key.lo = (key.lo << 1) | ((v[i] >> b) & 1u);
    }
  return key;
}

// The order in which points are handed to Draco: along the Hilbert curve through the quantized
// positions (neighbours in space stay neighbours in the stream, which is what the sequential coder's
// delta prediction wants: about 2% smaller than Morton order), ties broken by every field, so the
// order depends on the set of points only.
std::vector<uint32_t> canonical_order(const TileCloud& cloud, const std::vector<Eigen::Vector3f>& normals,
                                      const std::vector<float>& intensity, const PositionQuantization& q) {
  const std::size_t n = cloud.size();
  std::vector<HilbertKey> keys(n);
  const double max_q = std::ldexp(1.0, q.bits) - 1.0;
  for (std::size_t i = 0; i < n; ++i) {
    uint32_t cell[3];
    for (int c = 0; c < 3; ++c)
      cell[c] = static_cast<uint32_t>(std::clamp(std::round((cloud.points[i][c] - q.min[c]) / q.step), 0.0, max_q));
    keys[i] = hilbert_key(cell[0], cell[1], cell[2], q.bits);
  }
  std::vector<uint32_t> order(n);
  std::iota(order.begin(), order.end(), 0u);
  auto less = [&](uint32_t a, uint32_t b) {
    if (keys[a] != keys[b]) return keys[a] < keys[b];
    if (!normals.empty()) {
      for (int c = 0; c < 3; ++c)
        if (normals[a][c] != normals[b][c]) return normals[a][c] < normals[b][c];
    }
    if (!intensity.empty() && intensity[a] != intensity[b]) return intensity[a] < intensity[b];
    for (int c = 0; c < 3; ++c)
      if (cloud.points[a][c] != cloud.points[b][c]) return cloud.points[a][c] < cloud.points[b][c];
    return false;
  };
  std::sort(order.begin(), order.end(), less);
  return order;
}

struct Attributes {
  int position = -1, normal = -1, intensity = -1;
};

// The point cloud as Draco will encode it; `atts` receives the attribute ids.
std::unique_ptr<draco::PointCloud> build_point_cloud(const TileCloud& cloud,
                                                     const std::vector<Eigen::Vector3f>& normals,
                                                     const std::vector<float>& intensity,
                                                     const PositionQuantization& q,
                                                     const std::vector<uint32_t>& order, Attributes& atts) {
  const auto n = static_cast<draco::PointIndex::ValueType>(cloud.size());
  draco::PointCloudBuilder builder;
  builder.Start(n);
  atts.position = builder.AddAttribute(draco::GeometryAttribute::POSITION, 3, draco::DT_FLOAT32);
  if (!normals.empty()) atts.normal = builder.AddAttribute(draco::GeometryAttribute::NORMAL, 3, draco::DT_FLOAT32);
  if (!intensity.empty())
    atts.intensity = builder.AddAttribute(draco::GeometryAttribute::GENERIC, 1, draco::DT_FLOAT32);

  std::vector<float> xyz(3 * cloud.size());
  for (std::size_t k = 0; k < order.size(); ++k)
    for (int c = 0; c < 3; ++c)
      xyz[3 * k + c] = static_cast<float>(cloud.points[order[k]][c] - q.origin[c]);
  // (Draco's builder crashes when handed the values of no points.)
  if (!order.empty()) builder.SetAttributeValuesForAllPoints(atts.position, xyz.data(), 0);
  if (atts.normal >= 0) {
    for (std::size_t k = 0; k < order.size(); ++k)
      for (int c = 0; c < 3; ++c) xyz[3 * k + c] = normals[order[k]][c];
    builder.SetAttributeValuesForAllPoints(atts.normal, xyz.data(), 0);
  }
  if (atts.intensity >= 0) {
    std::vector<float> values(order.size());
    for (std::size_t k = 0; k < order.size(); ++k) values[k] = intensity[order[k]] + 0.0f;  // no -0
    builder.SetAttributeValuesForAllPoints(atts.intensity, values.data(), 0);
  }
  std::unique_ptr<draco::PointCloud> pc = builder.Finalize(false);
  if (!pc) throw Error("tile codec: Draco could not build the point cloud");

  auto metadata = std::make_unique<draco::GeometryMetadata>();
  metadata->AddEntryDoubleArray(kOriginKey, {q.origin.x(), q.origin.y(), q.origin.z()});
  pc->AddMetadata(std::move(metadata));
  if (atts.intensity >= 0) {
    auto att_metadata = std::make_unique<draco::AttributeMetadata>();
    att_metadata->AddEntryString(kNameKey, kIntensityName);
    pc->AddAttributeMetadata(atts.intensity, std::move(att_metadata));
  }
  return pc;
}

// --- decoding ---------------------------------------------------------------------------------------

std::unique_ptr<draco::PointCloud> draco_decode(std::string_view bytes);

std::unique_ptr<draco::PointCloud> decode_point_cloud(std::string_view bytes) {
  check_stream(bytes);
  // What check_stream cannot bound (Draco's working memory beyond its estimate) fails as an error,
  // not an exception that escapes the caller.
  try {
    return draco_decode(bytes);
  } catch (const std::bad_alloc&) {
    invalid("the decoder ran out of memory (" + std::to_string(bytes.size()) + " bytes)");
  }
}

std::unique_ptr<draco::PointCloud> draco_decode(std::string_view bytes) {
  draco::DecoderBuffer buffer;
  buffer.Init(bytes.data(), bytes.size());
  draco::Decoder decoder;
  decoder.SetSkipAttributeTransform(draco::GeometryAttribute::POSITION);  // see read_positions
  decoder.SetSkipAttributeTransform(draco::GeometryAttribute::NORMAL);    // see read_normals
  auto result = decoder.DecodePointCloudFromBuffer(&buffer);
  if (!result.ok()) invalid(result.status().error_msg_string());
  std::unique_ptr<draco::PointCloud> pc = std::move(result).value();
  if (!pc) invalid("the decoder returned nothing");
  return pc;
}

// The attribute of that type with 3 components (positions and normals; octahedral normals are left
// as 2-component codes by the decoder), or nullptr.
const draco::PointAttribute* vector_attribute(const draco::PointCloud& pc, draco::GeometryAttribute::Type type) {
  for (int i = 0; i < pc.NumNamedAttributes(type); ++i) {
    const draco::PointAttribute* att = pc.GetNamedAttribute(type, i);
    if (!att) continue;
    const draco::AttributeTransformData* transform = att->GetAttributeTransformData();
    const bool octahedral = transform && transform->transform_type() == draco::ATTRIBUTE_OCTAHEDRON_TRANSFORM;
    if (att->num_components() == (octahedral ? 2 : 3)) return att;
  }
  return nullptr;
}

// The GENERIC 1-component attribute named "intensity" in its metadata, or nullptr.
const draco::PointAttribute* intensity_attribute(const draco::PointCloud& pc) {
  for (int i = 0; i < pc.NumNamedAttributes(draco::GeometryAttribute::GENERIC); ++i) {
    const int id = pc.GetNamedAttributeId(draco::GeometryAttribute::GENERIC, i);
    const draco::PointAttribute* att = pc.attribute(id);
    if (!att || att->num_components() != 1) continue;
    const draco::AttributeMetadata* md = pc.GetAttributeMetadataByAttributeId(id);
    std::string name;
    if (md && md->GetEntryString(kNameKey, &name) && name == kIntensityName) return att;
  }
  return nullptr;
}

// Checks that the attribute's values can be read as numbers of the output type and that every
// point maps to a stored value. Draco reads bool values by loading bytes as bool (undefined for
// anything but 0 and 1), and float64 values cannot all be narrowed to the float32 of normals and
// intensities: both are refused where they cannot be read safely.
void check_mapping(const draco::PointAttribute& att, std::size_t n, const char* what, bool float_output) {
  if (att.data_type() == draco::DT_BOOL || att.data_type() == draco::DT_INVALID || att.data_type() >= draco::DT_TYPES_COUNT)
    invalid(std::string(what) + " attribute has data type " + std::to_string(att.data_type()) + ", not a number type");
  if (float_output && att.data_type() == draco::DT_FLOAT64)
    invalid(std::string(what) + " attribute is float64 (this reader takes float32 or integer values)");
  const std::size_t stored = att.size();
  const int64_t stride = att.byte_stride();
  const std::size_t value_bytes =
      static_cast<std::size_t>(att.num_components()) * draco::DataTypeLength(att.data_type());
  if (!att.buffer() || stride <= 0 ||
      (stored > 0 && static_cast<std::size_t>(att.byte_offset() + stride * static_cast<int64_t>(stored - 1)) +
                             value_bytes > att.buffer()->data_size()))
    invalid(std::string(what) + " attribute has no data");
  if (att.is_mapping_identity()) {
    if (stored < n) invalid(std::string(what) + " attribute has fewer values than points");
    return;
  }
  if (att.indices_map_size() < n) invalid(std::string(what) + " attribute maps fewer points than the cloud has");
  for (std::size_t i = 0; i < n; ++i)
    if (att.mapped_index(draco::PointIndex(static_cast<uint32_t>(i))).value() >= stored)
      invalid(std::string(what) + " attribute maps a point to a missing value");
}

// Copies the C components of every point's value to out[C * i + c] when they are stored as
// identity-mapped, tightly packed Stored values (what Draco's decoder makes of encode_tile's output).
template <typename Stored, int C, typename Out>
bool read_packed(const draco::PointAttribute& att, draco::DataType type, std::size_t n, Out* out) {
  if (att.data_type() != type || att.num_components() != C || !att.is_mapping_identity() ||
      att.byte_stride() != static_cast<int64_t>(C * sizeof(Stored)))
    return false;
  const uint8_t* src = att.GetAddress(draco::AttributeValueIndex(0));
  for (std::size_t i = 0; i < n; ++i) {
    Stored v[C];
    std::memcpy(v, src + i * sizeof(v), sizeof(v));
    for (int c = 0; c < C; ++c) out[C * i + c] = static_cast<Out>(v[c]);
  }
  return true;
}

// Copies the C components of every point's value to out[C * i + c], any type and mapping.
template <int C, typename Out>
void read_values(const draco::PointAttribute& att, std::size_t n, Out* out, const char* what) {
  if (n == 0 || read_packed<float, C>(att, draco::DT_FLOAT32, n, out) ||
      read_packed<int32_t, C>(att, draco::DT_INT32, n, out) || read_packed<uint32_t, C>(att, draco::DT_UINT32, n, out))
    return;
  for (std::size_t i = 0; i < n; ++i)
    if (!att.ConvertValue<Out>(att.mapped_index(draco::PointIndex(static_cast<uint32_t>(i))), C, out + C * i))
      invalid(std::string(what) + " value " + std::to_string(i) + " cannot be read");
}

// Throws naming the first non-finite value when there is one (one sum catches NaN and infinity).
template <typename T>
void check_finite(const T* values, std::size_t count, int per_point, const char* what) {
  double sum = 0;
  for (std::size_t k = 0; k < count; ++k) sum += static_cast<double>(values[k]);
  if (std::isfinite(sum)) return;
  for (std::size_t k = 0; k < count; ++k)
    if (!std::isfinite(static_cast<double>(values[k])))
      invalid(std::string(what) + " " + std::to_string(k / per_point) + " is not finite");
}

// Positions in ENU. The decoder is asked to leave quantized positions as integers (Draco would
// dequantize them to float32 offsets in a pass of its own): they are dequantized here with Draco's
// parameters (bits, low corner, range), in double, and moved to the tile origin in the same pass.
// Dequantized values are finite by construction; other streams are checked.
void read_positions(const draco::PointAttribute& att, std::size_t n, const Eigen::Vector3d& origin, double* xyz) {
  const draco::AttributeTransformData* transform = att.GetAttributeTransformData();
  if (!transform || att.data_type() == draco::DT_FLOAT32 || att.data_type() == draco::DT_FLOAT64) {
    read_values<3>(att, n, xyz, "POSITION");
    for (std::size_t i = 0; i < n; ++i)
      for (int c = 0; c < 3; ++c) xyz[3 * i + c] += origin[c];
    check_finite(xyz, 3 * n, 3, "position");
    return;
  }
  // Draco's layout of the quantization data: int32 bits, float32 low corner per component, float32 range.
  if (transform->transform_type() != draco::ATTRIBUTE_QUANTIZATION_TRANSFORM)
    invalid("POSITION has an unknown transform " + std::to_string(transform->transform_type()));
  const int32_t bits = transform->GetParameterValue<int32_t>(0);
  double low[3];
  for (int c = 0; c < 3; ++c) low[c] = origin[c] + transform->GetParameterValue<float>(4 + 4 * c);
  const double range = transform->GetParameterValue<float>(16);
  if (bits < 1 || bits > 30 || !std::isfinite(range) || !std::isfinite(low[0] + low[1] + low[2]))
    invalid("POSITION quantization parameters are malformed");
  const double step = range / (std::ldexp(1.0, bits) - 1.0);
  if (att.data_type() == draco::DT_INT32 && att.is_mapping_identity() && att.byte_stride() == 12) {
    const uint8_t* src = att.GetAddress(draco::AttributeValueIndex(0));
    for (std::size_t i = 0; i < n; ++i) {
      int32_t v[3];
      std::memcpy(v, src + 12 * i, sizeof(v));
      xyz[3 * i + 0] = low[0] + v[0] * step;
      xyz[3 * i + 1] = low[1] + v[1] * step;
      xyz[3 * i + 2] = low[2] + v[2] * step;
    }
    return;
  }
  read_values<3>(att, n, xyz, "POSITION");
  for (std::size_t i = 0; i < n; ++i)
    for (int c = 0; c < 3; ++c) xyz[3 * i + c] = low[c] + xyz[3 * i + c] * step;
  check_finite(xyz, 3 * n, 3, "position");
}

// Unit vectors of every octahedral code (s, t) at `bits` bits, as Draco's own tool box computes them,
// so decode_tile returns exactly Draco's normals. Built once per bit count; 8 bits (tiles written
// before 2026-12-07) take 768 KiB, 6 bits (the default) 48 KiB: both stay in the L2 cache.
constexpr int kMaxTableBits = 8;

const std::vector<Eigen::Vector3f>& octahedral_table(int bits) {
  static std::once_flag once[kMaxTableBits + 1];
  static std::vector<Eigen::Vector3f> tables[kMaxTableBits + 1];
  std::call_once(once[bits], [bits] {
    draco::OctahedronToolBox box;
    box.SetQuantizationBits(bits);
    const int side = 1 << bits;
    std::vector<Eigen::Vector3f>& table = tables[bits];
    table.resize(static_cast<std::size_t>(side) * side);
    for (int s = 0; s < side; ++s)
      for (int t = 0; t < side; ++t) box.QuantizedOctahedralCoordsToUnitVector(s, t, table[s * side + t].data());
  });
  return tables[bits];
}

// Unit normals. The decoder is asked to leave octahedral normals as their integer codes (Draco
// would turn them into floats in a pass of its own, then we would copy them): they are looked up
// here. Other streams (float or component-quantized normals of the k-d tree coder, which are off unit
// length) are copied, checked and brought back to unit length in one pass.
void read_normals(const draco::PointAttribute& att, std::size_t n, Eigen::Vector3f* out) {
  const draco::AttributeTransformData* transform = att.GetAttributeTransformData();
  if (transform && transform->transform_type() == draco::ATTRIBUTE_OCTAHEDRON_TRANSFORM) {
    const int32_t bits = transform->GetParameterValue<int32_t>(0);
    if (bits < 2 || bits > 30 || att.num_components() != 2)
      invalid("NORMAL octahedral parameters are malformed");
    std::vector<int32_t> codes(2 * n);
    read_values<2>(att, n, codes.data(), "NORMAL");
    const uint32_t side = uint32_t{1} << bits;
    for (std::size_t i = 0; i < 2 * n; ++i)
      if (static_cast<uint32_t>(codes[i]) >= side) invalid("NORMAL code " + std::to_string(i / 2) + " is out of range");
    if (bits <= kMaxTableBits) {
      const Eigen::Vector3f* table = octahedral_table(bits).data();
      for (std::size_t i = 0; i < n; ++i) out[i] = table[codes[2 * i] * side + codes[2 * i + 1]];
    } else {
      draco::OctahedronToolBox box;
      box.SetQuantizationBits(bits);
      for (std::size_t i = 0; i < n; ++i) box.QuantizedOctahedralCoordsToUnitVector(codes[2 * i], codes[2 * i + 1], out[i].data());
    }
    return;
  }
  if (transform && transform->transform_type() == draco::ATTRIBUTE_QUANTIZATION_TRANSFORM) {
    // Draco's layout of the quantization data: int32 bits, float32 low corner per component, float32 range.
    const int32_t bits = transform->GetParameterValue<int32_t>(0);
    if (bits < 1 || bits > 30 || att.num_components() != 3) invalid("NORMAL quantization parameters are malformed");
    float low[3];
    for (int c = 0; c < 3; ++c) low[c] = transform->GetParameterValue<float>(4 + 4 * c);
    const float step = transform->GetParameterValue<float>(16) / static_cast<float>(std::ldexp(1.0, bits) - 1.0);
    read_values<3>(att, n, out ? out->data() : nullptr, "NORMAL");
    for (std::size_t i = 0; i < n; ++i)
      for (int c = 0; c < 3; ++c) out[i][c] = low[c] + out[i][c] * step;
  } else {
    read_values<3>(att, n, out ? out->data() : nullptr, "NORMAL");
  }
  // Back to unit length, in double (float squares of tiny or huge components underflow or
  // overflow). A zero-length normal has no direction: refused, as encode_tile refuses to write one.
  for (std::size_t i = 0; i < n; ++i) {
    Eigen::Vector3f& u = out[i];
    const double norm = u.cast<double>().norm();
    if (!std::isfinite(norm)) invalid("normal " + std::to_string(i) + " is not finite");
    if (!(norm > 1e-6)) invalid("normal " + std::to_string(i) + " has zero length");
    if (std::abs(norm - 1.0) > 1e-6) u = (u.cast<double>() / norm).cast<float>();
  }
}

Eigen::Vector3d tile_origin(const draco::PointCloud& pc) {
  const draco::GeometryMetadata* md = pc.GetMetadata();
  std::vector<double> origin;
  if (!md || !md->GetEntryDoubleArray(kOriginKey, &origin)) return Eigen::Vector3d::Zero();
  if (origin.size() != 3 || !std::isfinite(origin[0]) || !std::isfinite(origin[1]) || !std::isfinite(origin[2]))
    invalid(std::string(kOriginKey) + " metadata is not 3 finite numbers");
  return {origin[0], origin[1], origin[2]};
}

}  // namespace

std::string encode_tile(const TileCloud& cloud, const TileCodecConfig& cfg) {
  check_config(cfg);
  check_cloud(cloud);

  // An attribute given 0 bits is not stored.
  std::vector<Eigen::Vector3f> normals(cfg.normal_bits > 0 ? cloud.normals.size() : 0);
  const std::vector<float> none;
  const std::vector<float>& intensity = cfg.intensity_bits > 0 ? cloud.intensity : none;
  for (std::size_t i = 0; i < normals.size(); ++i) {
    const Eigen::Vector3d u = cloud.normals[i].cast<double>().normalized();
    for (int c = 0; c < 3; ++c) normals[i][c] = static_cast<float>(u[c]) + 0.0f;  // no -0
  }
  const PositionQuantization q = quantize_positions(cloud.points, cfg.max_error_m);
  const std::vector<uint32_t> order = canonical_order(cloud, normals, intensity, q);
  Attributes atts;
  const std::unique_ptr<draco::PointCloud> pc = build_point_cloud(cloud, normals, intensity, q, order, atts);

  // Both coders unless speed 10 asks for the fast one; an empty cloud only decodes from the k-d tree
  // coder (Draco's sequential decoder refuses zero quantized points).
  std::vector<int> methods;
  if (!cloud.points.empty()) methods.push_back(draco::POINT_CLOUD_SEQUENTIAL_ENCODING);
  if (cloud.points.empty() || cfg.speed < 10) methods.push_back(draco::POINT_CLOUD_KD_TREE_ENCODING);
  std::string best, errors;
  for (int method : methods) {
    draco::ExpertEncoder encoder(*pc);
    encoder.SetSpeedOptions(cfg.speed, cfg.speed);
    encoder.SetEncodingMethod(method);
    encoder.SetAttributeExplicitQuantization(atts.position, q.bits, 3, q.box_min, q.range);
    if (atts.normal >= 0) encoder.SetAttributeQuantization(atts.normal, cfg.normal_bits);
    if (atts.intensity >= 0) encoder.SetAttributeQuantization(atts.intensity, cfg.intensity_bits);
    draco::EncoderBuffer buffer;
    const draco::Status status = encoder.EncodeToBuffer(&buffer);
    if (!status.ok()) {
      errors += (errors.empty() ? "" : "; ") + status.error_msg_string();
      continue;
    }
    if (best.empty() || buffer.size() < best.size()) best.assign(buffer.data(), buffer.size());
  }
  if (best.empty()) throw Error("tile codec: Draco could not encode the tile: " + errors);
  try {
    check_stream(best);
  } catch (const Error& e) {
    throw Error(std::string("tile codec: decode_tile would refuse the encoded tile (") + e.what() +
                "): too many points, or mostly duplicates?");
  }
  return best;
}

TileCloud decode_tile(std::string_view bytes) {
  const std::unique_ptr<draco::PointCloud> pc = decode_point_cloud(bytes);
  const draco::PointAttribute* pos = vector_attribute(*pc, draco::GeometryAttribute::POSITION);
  if (!pos) invalid("no 3-component POSITION attribute");
  const draco::PointAttribute* nrm = vector_attribute(*pc, draco::GeometryAttribute::NORMAL);
  const draco::PointAttribute* inten = intensity_attribute(*pc);
  const std::size_t n = pc->num_points();
  check_mapping(*pos, n, "POSITION", false);
  if (nrm) check_mapping(*nrm, n, "NORMAL", true);
  if (inten) check_mapping(*inten, n, "intensity", true);
  const Eigen::Vector3d origin = tile_origin(*pc);

  TileCloud cloud;
  cloud.points.resize(n);
  static_assert(sizeof(Eigen::Vector3d) == 3 * sizeof(double) && sizeof(Eigen::Vector3f) == 3 * sizeof(float));
  double* xyz = cloud.points.empty() ? nullptr : cloud.points.front().data();
  read_positions(*pos, n, origin, xyz);
  if (nrm) {
    cloud.normals.resize(n);
    read_normals(*nrm, n, cloud.normals.empty() ? nullptr : cloud.normals.data());
  }
  if (inten) {
    cloud.intensity.resize(n);
    read_values<1>(*inten, n, cloud.intensity.data(), "intensity");
    check_finite(cloud.intensity.data(), n, 1, "intensity");
  }
  return cloud;
}

TileSummary inspect_tile(std::string_view bytes) {
  // Draco has no cheaper way to check the payload than decoding it, and an upload check must accept
  // exactly what decode_tile accepts: decode, then summarise.
  const TileCloud cloud = decode_tile(bytes);
  TileSummary s;
  s.points = cloud.size();
  s.has_normals = !cloud.normals.empty();
  s.has_intensity = !cloud.intensity.empty();
  return s;
}

}  // namespace pl
