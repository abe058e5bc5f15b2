// The stream check of decode_tile: see tile_stream.hpp.
#include "tile_stream.hpp"

#include <draco/compression/config/compression_shared.h>
#include <draco/core/draco_types.h>
#include <draco/draco_features.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>

#include "pl/common/error.hpp"

namespace pl::tile_stream {

[[noreturn]] void invalid(const std::string& reason) {
  throw Error("not a valid Draco point cloud: " + reason);
}

namespace {

// Draco allocates for the point and attribute counts a stream declares before it reads the data: a
// few corrupted bytes can ask for gigabytes. So the stream is walked first (the published bitstream:
// header, metadata, point count, attribute descriptors, and the k-d tree coder's own counts) and
// refused before Draco sees it when what Draco would hold to decode it (estimated per point from
// the descriptors, see check_stream) passes min(kDecodeCapBytes, max(kDecodeFloorBytes,
// kDecodeExpansion x the stream's size)). Real tiles need about 19x their size (84 bytes a point
// counted, 4 to 5 bytes a point encoded); only clouds made mostly of duplicates or of exact lattice
// points compress further, and encode_tile refuses to write what this would refuse. What the walk
// cannot see (the entropy-coded payload) is bounded by the point count it checked.
constexpr std::size_t kDecodeFloorBytes = std::size_t{8} << 20;
constexpr std::size_t kDecodeExpansion = 64;
// The hard cap per tile, whatever its size: about 3 million points with normals and intensity, some
// thirty times what a 20 m tile of 0.2 m voxels holds.
constexpr std::size_t kDecodeCapBytes = std::size_t{256} << 20;
constexpr int32_t kMaxPoints = int32_t{1} << 24;
constexpr int kMaxMetadataDepth = 16;
constexpr uint32_t kMaxKdDimensions = 32;

class Reader {
 public:
  explicit Reader(std::string_view bytes) : bytes_(bytes) {}
  std::size_t remaining() const { return bytes_.size() - pos_; }
  bool skip(std::size_t n) {
    if (remaining() < n) return false;
    pos_ += n;
    return true;
  }
  template <typename T>
  bool read(T& value) {  // little-endian, as Draco writes and reads it on the machines we run on
    if (remaining() < sizeof(T)) return false;
    std::memcpy(&value, bytes_.data() + pos_, sizeof(T));
    pos_ += sizeof(T);
    return true;
  }
  // Draco's unsigned varint: 7 bits a byte, low bits first, at most 5 bytes for 32 bits.
  bool varint(uint32_t& value) {
    value = 0;
    for (int i = 0; i < 5; ++i) {
      uint8_t byte = 0;
      if (!read(byte)) return false;
      value |= static_cast<uint32_t>(byte & 0x7f) << (7 * i);
      if (!(byte & 0x80)) return true;
    }
    return false;
  }

 private:
  std::string_view bytes_;
  std::size_t pos_ = 0;
};

bool skip_metadata(Reader& r, int depth) {
  if (depth > kMaxMetadataDepth) return false;
  uint32_t entries = 0;
  if (!r.varint(entries)) return false;
  for (uint32_t i = 0; i < entries; ++i) {
    uint8_t name_length = 0;
    uint32_t size = 0;
    if (!r.read(name_length) || !r.skip(name_length) || !r.varint(size) || size == 0 || !r.skip(size)) return false;
  }
  uint32_t children = 0;
  if (!r.varint(children)) return false;
  for (uint32_t i = 0; i < children; ++i) {
    uint8_t name_length = 0;
    if (!r.read(name_length) || !r.skip(name_length) || !skip_metadata(r, depth + 1)) return false;
  }
  return true;
}

// Walks the stream up to the attribute descriptors and refuses it when it is not a Draco point
// cloud this build reads or when it would decode to more than the budget allows.
}  // namespace

void check_stream(std::string_view bytes) {
  if (bytes.empty()) invalid("no bytes");
  Reader r(bytes);
  char magic[5];
  uint8_t major = 0, minor = 0, geometry = 0, method = 0;
  uint16_t flags = 0;
  if (!r.read(magic) || std::memcmp(magic, "DRACO", 5) != 0) invalid("no DRACO header");
  if (!r.read(major) || !r.read(minor) || !r.read(geometry) || !r.read(method) || !r.read(flags))
    invalid("truncated header");
  if (geometry != draco::POINT_CLOUD) invalid("geometry type " + std::to_string(geometry) + " is not a point cloud");
  if (method != draco::POINT_CLOUD_SEQUENTIAL_ENCODING && method != draco::POINT_CLOUD_KD_TREE_ENCODING)
    invalid("unknown encoding method " + std::to_string(method));
  const auto version = [](int ma, int mi) { return ma * 256 + mi; };
  const int v = version(major, minor);
  const int newest =
      version(draco::kDracoPointCloudBitstreamVersionMajor, draco::kDracoPointCloudBitstreamVersionMinor);
  // Only the bitstreams of current encoders: 2.2 (Draco 1.3 and 1.4) and 2.3 (1.5, what encode_tile
  // writes); the k-d tree coder only at 2.3. Draco's decoder also takes the 1.x and early 2.x
  // layouts, whose k-d tree data declares point counts of its own that Draco sizes buffers by
  // without checking them against the header (a 49-byte stream could ask for 14 GB).
  const std::string version_text = std::to_string(major) + "." + std::to_string(minor);
  if (v < version(2, 2) || v > newest)
    invalid("bitstream version " + version_text + " is not one this build reads (2.2 to " + std::to_string(newest >> 8) + "." +
            std::to_string(newest & 255) + "): re-encode the tile with a current Draco");
  if (method == draco::POINT_CLOUD_KD_TREE_ENCODING && v < version(2, 3))
    invalid("k-d tree stream of bitstream version " + version_text + " (this build reads the k-d tree coder's 2.3): re-encode the tile");
  if (v >= version(1, 3) && (flags & METADATA_FLAG_MASK)) {
    uint32_t attribute_metadata = 0;
    if (!r.varint(attribute_metadata)) invalid("truncated metadata");
    for (uint32_t i = 0; i < attribute_metadata; ++i) {
      uint32_t unique_id = 0;
      if (!r.varint(unique_id) || !skip_metadata(r, 1)) invalid("malformed metadata");
    }
    if (!skip_metadata(r, 1)) invalid("malformed metadata");
  }
  int32_t points = 0;
  if (!r.read(points)) invalid("truncated before the point count");
  if (points < 0 || points > kMaxPoints)
    invalid("point count " + std::to_string(points) + " is out of range (at most " + std::to_string(kMaxPoints) + ")");
  uint8_t decoders = 0;
  if (!r.read(decoders)) invalid("truncated before the attributes");
  const bool kd_tree = method == draco::POINT_CLOUD_KD_TREE_ENCODING;
  // Draco's k-d tree encoder writes one attribute decoder; where a second one's data would start is
  // known only after decoding the first, so its sizes could not be checked here.
  if (kd_tree && decoders != 1) invalid("k-d tree stream with " + std::to_string(decoders) + " attribute decoders (Draco writes one)");
  const std::size_t budget = std::min(kDecodeCapBytes, std::max(kDecodeFloorBytes, kDecodeExpansion * bytes.size()));
  // What Draco holds while decoding, per point: for each attribute and component the attribute
  // itself, the integer values the entropy decoder produces (4 bytes each, whatever the final type)
  // and a portable (quantized) copy, counted as 3 x max(type size, 4); for each sequential decoder
  // its point order (4 bytes).
  std::size_t per_point = 0, fixed = 0;
  uint32_t kd_dimensions = 0;
  for (int d = 0; d < decoders; ++d) {
    uint32_t attributes = 0;
    if (!r.varint(attributes)) invalid("truncated attribute list");
    if (attributes == 0 || attributes > r.remaining() / 5)  // a descriptor takes 5 bytes or more
      invalid("attribute count " + std::to_string(attributes) + " does not fit the stream");
    for (uint32_t a = 0; a < attributes; ++a) {
      uint8_t type = 0, data_type = 0, components = 0, normalized = 0;
      uint32_t unique_id = 0;
      if (!r.read(type) || !r.read(data_type) || !r.read(components) || !r.read(normalized) || !r.varint(unique_id))
        invalid("truncated attribute descriptor");
      if (data_type <= draco::DT_INVALID || data_type >= draco::DT_TYPES_COUNT)
        invalid("attribute data type " + std::to_string(data_type) + " is unknown");
      if (components == 0) invalid("attribute with no components");
      const std::size_t size = static_cast<std::size_t>(draco::DataTypeLength(static_cast<draco::DataType>(data_type)));
      per_point += 3 * static_cast<std::size_t>(components) * std::max<std::size_t>(size, 4);
      kd_dimensions += components;
    }
    if (!kd_tree) {
      per_point += 4;
      if (!r.skip(attributes)) invalid("truncated attribute decoder list");
    }
  }
  if (kd_tree) {
    // The k-d tree decoder's stacks take about 256 D^2 bytes for D components in all, before it
    // reads a byte of its data; encode_tile's tiles have D <= 7.
    if (kd_dimensions > kMaxKdDimensions)
      invalid("k-d tree stream with " + std::to_string(kd_dimensions) + " components (at most " + std::to_string(kMaxKdDimensions) + ")");
    fixed += 256 * static_cast<std::size_t>(kd_dimensions) * kd_dimensions;
    // Then its data: compression level, bit length and the point count again, which Draco 1.5.5
    // loops over before comparing it with the header's.
    uint8_t level = 0;
    uint32_t bit_length = 0, kd_points = 0;
    // (An empty cloud's stream may end before them.)
    if (r.remaining() >= 9 || points > 0) {
      if (!r.read(level) || !r.read(bit_length) || !r.read(kd_points)) invalid("truncated k-d tree data");
      if (level > 6 || bit_length > 32) invalid("k-d tree compression level or bit length out of range");
      if (kd_points != static_cast<uint32_t>(points))
        invalid("the k-d tree data declares " + std::to_string(kd_points) + " points, the header " + std::to_string(points));
    }
  }
  const double decoded = static_cast<double>(points) * static_cast<double>(per_point) + static_cast<double>(fixed);
  if (decoded > static_cast<double>(budget))
    invalid(std::to_string(points) + " points would need about " + std::to_string(static_cast<long long>(decoded)) +
            " bytes to decode from " + std::to_string(bytes.size()) + " (at most " + std::to_string(budget) + " allowed: refused)");
}

}  // namespace pl::tile_stream
