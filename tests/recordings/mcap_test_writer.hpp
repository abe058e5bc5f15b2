// A small MCAP writer of the tests' own (chunks uncompressed, zstd or lz4, with CRCs, message
// indexes and a summary section, or messages straight in the data section), and the sample files
// the MCAP reader's tests read and damage.
#pragma once

#include <lz4frame.h>
#include <zlib.h>
#include <zstd.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <map>
#include <memory>
#include <random>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "pl/recordings/bag.hpp"

namespace pl::test::mcap {

template <typename T>
inline std::string le(T v) {
  std::string s(sizeof(T), '\0');
  std::memcpy(s.data(), &v, sizeof(T));  // the host is little-endian
  return s;
}
inline std::string u16(std::uint16_t v) { return le(v); }
inline std::string u32(std::uint32_t v) { return le(v); }
inline std::string u64(std::uint64_t v) { return le(v); }
inline std::string str(const std::string& s) { return u32(static_cast<std::uint32_t>(s.size())) + s; }
inline std::string record(std::uint8_t op, const std::string& body) { return std::string(1, static_cast<char>(op)) + u64(body.size()) + body; }

inline const std::string kMagic("\x89MCAP0\r\n", 8);

enum class Comp { None, Zstd, Lz4 };

inline std::string compress(Comp c, const std::string& raw) {
  if (c == Comp::None) return raw;
  std::string out;
  if (c == Comp::Zstd) {
    out.resize(ZSTD_compressBound(raw.size()));
    const std::size_t n = ZSTD_compress(out.data(), out.size(), raw.data(), raw.size(), 3);
    if (ZSTD_isError(n)) throw std::runtime_error("ZSTD_compress failed");
    out.resize(n);
  } else {
    LZ4F_preferences_t prefs{};
    prefs.frameInfo.contentChecksumFlag = LZ4F_contentChecksumEnabled;
    out.resize(LZ4F_compressFrameBound(raw.size(), &prefs));
    const std::size_t n = LZ4F_compressFrame(out.data(), out.size(), raw.data(), raw.size(), &prefs);
    if (LZ4F_isError(n)) throw std::runtime_error("LZ4F_compressFrame failed");
    out.resize(n);
  }
  return out;
}

inline std::uint32_t crc_of(const std::string& s) {
  return static_cast<std::uint32_t>(crc32_z(0L, reinterpret_cast<const Bytef*>(s.data()), s.size()));
}

// How end_chunk writes a chunk (the defaults make a valid one).
struct ChunkOptions {
  Comp comp = Comp::None;
  bool crc = true;
  const char* compression_name = nullptr;  // instead of comp's
  std::uint32_t crc_xor = 0;               // damages the CRC
  std::int64_t size_delta = 0;             // damages uncompressed_size
  std::uint64_t size_override = 0;         // damages uncompressed_size (when non-zero)
};

class Writer {
 public:
  Writer() { out_ = kMagic + record(0x01, str("ros2") + str("pl test writer")); }

  void schema(std::uint16_t id, const std::string& name, const std::string& encoding, const std::string& data) {
    const std::string body = u16(id) + str(name) + str(encoding) + str(data);
    put(0x03, body);
    schemas_[id] = record(0x03, body);
  }
  void channel(std::uint16_t id, std::uint16_t schema_id, const std::string& topic, const std::string& encoding,
               const std::map<std::string, std::string>& metadata = {}) {
    std::string map;
    for (const auto& [k, v] : metadata) map += str(k) + str(v);
    const std::string body = u16(id) + u16(schema_id) + str(topic) + str(encoding) + str(map);
    put(0x04, body);
    channels_[id] = record(0x04, body);
  }
  // Returns the record's offset (in the file, or in the open chunk's records).
  std::uint64_t message(std::uint16_t channel, std::uint64_t log_time, const std::string& data, std::uint32_t sequence = 0) {
    const std::uint64_t at = in_chunk_ ? chunk_.size() : out_.size();
    if (in_chunk_) {
      index_[channel].push_back({log_time, at});
      start_ = std::min(start_, log_time);
      end_ = std::max(end_, log_time);
    }
    put(0x05, u16(channel) + u32(sequence) + u64(log_time) + u64(log_time + 1) + data);
    ++message_count_;
    ++channel_counts_[channel];
    return at;
  }
  void raw(std::uint8_t op, const std::string& body) { put(op, body); }
  void raw_bytes(const std::string& bytes) { (in_chunk_ ? chunk_ : out_) += bytes; }
  void attachment(const std::string& name, const std::string& data) {
    std::string body = u64(5) + u64(6) + str(name) + str("application/octet-stream") + u64(data.size()) + data;
    body += u32(crc_of(body));
    attachment_indexes_ += record(0x0a, u64(out_.size()) + u64(9 + body.size()) + u64(5) + u64(6) + u64(data.size()) + str(name) +
                                            str("application/octet-stream"));
    put(0x09, body);
  }
  void metadata(const std::string& name, const std::string& key, const std::string& value) {
    put(0x0c, str(name) + str(str(key) + str(value)));
  }

  void begin_chunk() {
    in_chunk_ = true;
    chunk_.clear();
    index_.clear();
    start_ = UINT64_MAX;
    end_ = 0;
  }
  // Returns the chunk record's offset in the file.
  std::uint64_t end_chunk(const ChunkOptions& o = {}) {
    in_chunk_ = false;
    const std::string stored = compress(o.comp, chunk_);
    const char* name = o.compression_name ? o.compression_name : o.comp == Comp::Zstd ? "zstd" : o.comp == Comp::Lz4 ? "lz4" : "";
    std::uint64_t size = chunk_.size() + static_cast<std::uint64_t>(o.size_delta);
    if (o.size_override) size = o.size_override;
    const std::uint64_t at = out_.size();
    if (start_ == UINT64_MAX) start_ = 0;
    const std::string body = u64(start_) + u64(end_) + u64(size) + u32((o.crc ? crc_of(chunk_) : 0) ^ o.crc_xor) + str(name) +
                             u64(stored.size()) + stored;
    out_ += record(0x06, body);
    const std::uint64_t chunk_length = out_.size() - at;
    std::string offsets;
    const std::uint64_t index_start = out_.size();
    for (const auto& [channel, entries] : index_) {
      offsets += u16(channel) + u64(out_.size());
      std::string array;
      for (const auto& [t, off] : entries) array += u64(t) + u64(off);
      out_ += record(0x07, u16(channel) + str(array));
    }
    chunk_indexes_ += record(0x08, u64(start_) + u64(end_) + u64(at) + u64(chunk_length) + str(offsets) +
                                       u64(out_.size() - index_start) + str(name) + u64(stored.size()) + u64(size));
    ++chunk_count_;
    return at;
  }

  std::uint64_t size() const { return out_.size(); }

  // The file: Data End, a summary section (copies of the schemas and channels, the chunk and
  // attachment indexes, statistics, summary offsets), the Footer and the magic.
  std::string finish(bool summary = true, bool data_end = true) {
    if (data_end) out_ += record(0x0f, u32(0));
    std::uint64_t summary_start = 0, offsets_start = 0;
    if (summary) {
      summary_start = out_.size();
      std::string offsets;
      const auto group = [&](std::uint8_t op, const std::string& records) {
        if (records.empty()) return;
        offsets += record(0x0e, std::string(1, static_cast<char>(op)) + u64(out_.size()) + u64(records.size()));
        out_ += records;
      };
      std::string s, c, counts;
      for (const auto& [id, r] : schemas_) s += r;
      for (const auto& [id, r] : channels_) c += r;
      for (const auto& [id, n] : channel_counts_) counts += u16(id) + u64(n);
      group(0x03, s);
      group(0x04, c);
      group(0x08, chunk_indexes_);
      group(0x0a, attachment_indexes_);
      group(0x0b, record(0x0b, u64(message_count_) + u16(static_cast<std::uint16_t>(schemas_.size())) +
                                   u32(static_cast<std::uint32_t>(channels_.size())) + u32(0) + u32(0) + u32(chunk_count_) +
                                   u64(0) + u64(0) + str(counts)));
      offsets_start = out_.size();
      out_ += offsets;
    }
    out_ += record(0x02, u64(summary_start) + u64(offsets_start) + u32(0));
    out_ += kMagic;
    return out_;
  }

 private:
  void put(std::uint8_t op, const std::string& body) { (in_chunk_ ? chunk_ : out_) += record(op, body); }

  std::string out_, chunk_;
  bool in_chunk_ = false;
  std::map<std::uint16_t, std::vector<std::pair<std::uint64_t, std::uint64_t>>> index_;
  std::uint64_t start_ = 0, end_ = 0;
  std::map<std::uint16_t, std::string> schemas_, channels_;
  std::map<std::uint16_t, std::uint64_t> channel_counts_;
  std::string chunk_indexes_, attachment_indexes_;
  std::uint64_t message_count_ = 0;
  std::uint32_t chunk_count_ = 0;
};

inline std::unique_ptr<pl::bag::Reader> open_bytes(std::string bytes, const std::string& name = "test.mcap") {
  return pl::bag::open_mcap(pl::bag::hold_bytes(std::move(bytes), name));
}

inline std::string random_bytes(std::size_t n, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::string s(n, '\0');
  for (auto& c : s) c = static_cast<char>(rng());
  return s;
}

// A point cloud's bytes: floats of a smooth scene (compressible, as real clouds are).
inline std::string cloud_bytes(std::size_t points, std::uint32_t seed) {
  std::string s;
  s.reserve(points * 16);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> noise(-0.01f, 0.01f);
  for (std::size_t i = 0; i < points; ++i) {
    const float a = static_cast<float>(i) * 0.001f;
    const float v[4] = {10.0f * std::cos(a) + noise(rng), 10.0f * std::sin(a) + noise(rng), 0.5f, static_cast<float>(i % 97)};
    s.append(reinterpret_cast<const char*>(v), sizeof v);
  }
  return s;
}

inline const std::string kRos1Def = "Header header\nuint32 height\nuint32 width\n";
inline const std::string kRos2Def = "std_msgs/Header header\nuint32 height\nuint32 width\n";

// Three topics (ROS 1, CDR, JSON) in two chunks that overlap in time, and one message outside chunks.
struct Sample {
  std::string bytes;
  // Every message, as written: topic name, time, data.
  struct Msg {
    std::string topic;
    std::uint64_t time;
    std::string data;
  };
  std::vector<Msg> written;
};

inline Sample sample(Comp comp) {
  Sample s;
  Writer w;
  const auto msg = [&](std::uint16_t ch, const std::string& topic, std::uint64_t t, const std::string& data) {
    w.message(ch, t, data);
    s.written.push_back({topic, t, data});
  };
  w.begin_chunk();
  w.schema(1, "sensor_msgs/PointCloud2", "ros1msg", kRos1Def);
  w.schema(2, "sensor_msgs/msg/PointCloud2", "ros2msg", kRos2Def);
  w.channel(1, 1, "/velodyne_points", "ros1", {{"callerid", "/velodyne"}});
  w.channel(2, 2, "/points", "cdr", {{"offered_qos_profiles", "- history: 3"}});
  msg(1, "/velodyne_points", 1000, cloud_bytes(300, 1));
  msg(2, "/points", 3000, std::string("\x00\x01\x00\x00", 4) + cloud_bytes(200, 2));
  msg(1, "/velodyne_points", 5000, cloud_bytes(250, 3));
  w.end_chunk({comp});
  w.attachment("calibration.yaml", "lidar: {x: 1}\n");
  w.schema(3, "pl.Status", "jsonschema", "{\"type\": \"object\"}");
  w.channel(3, 3, "/status", "json");
  msg(3, "/status", 3500, "{\"ok\": true}");  // outside chunks
  w.metadata("robot", "serial", "42");
  w.begin_chunk();
  // Writers may repeat a schema and a channel in later chunks.
  w.schema(2, "sensor_msgs/msg/PointCloud2", "ros2msg", kRos2Def);
  w.channel(2, 2, "/points", "cdr", {{"offered_qos_profiles", "- history: 3"}});
  msg(2, "/points", 2000, std::string("\x00\x01\x00\x00", 4) + cloud_bytes(100, 4));
  msg(1, "/velodyne_points", 4000, cloud_bytes(10, 5));
  msg(2, "/points", 3000, std::string("\x00\x01\x00\x00", 4) + "tie: after the first chunk's message at 3000");
  w.raw(0x80, "a private record, skipped");
  msg(2, "/points", 6000, "");  // empty message
  w.end_chunk({comp});
  s.bytes = w.finish();
  return s;
}

inline const pl::bag::Topic& topic_named(const pl::bag::Reader& r, const std::string& name) {
  for (const auto& t : r.topics())
    if (t.name == name) return t;
  throw std::runtime_error("no topic " + name);
}

}  // namespace pl::test::mcap
