// The MCAP reader (recordings/src/bag_mcap.cpp) on files written by a small MCAP writer of this test's own
// (chunks uncompressed, zstd or lz4, with CRCs, message indexes and a summary section, or messages
// straight in the data section), and on those files damaged: cut short, bad CRCs, bad lengths.
#include <gtest/gtest.h>
#include <lz4frame.h>
#include <zlib.h>
#include <zstd.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <map>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "error_of.hpp"
#include "pl/common/error.hpp"
#include "pl/recordings/bag.hpp"
#include "test_util.hpp"

namespace {

using pl::bag::Encoding;
using pl::bag::MessageRef;
using pl::test::error_of;

// --- A small MCAP writer, for these tests only ------------------------------------------------------

template <typename T>
std::string le(T v) {
  std::string s(sizeof(T), '\0');
  std::memcpy(s.data(), &v, sizeof(T));  // the host is little-endian
  return s;
}
std::string u16(std::uint16_t v) { return le(v); }
std::string u32(std::uint32_t v) { return le(v); }
std::string u64(std::uint64_t v) { return le(v); }
std::string str(const std::string& s) { return u32(static_cast<std::uint32_t>(s.size())) + s; }
std::string record(std::uint8_t op, const std::string& body) { return std::string(1, static_cast<char>(op)) + u64(body.size()) + body; }

const std::string kMagic("\x89MCAP0\r\n", 8);

enum class Comp { None, Zstd, Lz4 };

std::string compress(Comp c, const std::string& raw) {
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

std::uint32_t crc_of(const std::string& s) {
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

std::unique_ptr<pl::bag::Reader> open_bytes(std::string bytes, const std::string& name = "test.mcap") {
  return pl::bag::open_mcap(pl::bag::hold_bytes(std::move(bytes), name));
}

std::string random_bytes(std::size_t n, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::string s(n, '\0');
  for (auto& c : s) c = static_cast<char>(rng());
  return s;
}

// A point cloud's bytes: floats of a smooth scene (compressible, as real clouds are).
std::string cloud_bytes(std::size_t points, std::uint32_t seed) {
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

const std::string kRos1Def = "Header header\nuint32 height\nuint32 width\n";
const std::string kRos2Def = "std_msgs/Header header\nuint32 height\nuint32 width\n";

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

Sample sample(Comp comp) {
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

const pl::bag::Topic& topic_named(const pl::bag::Reader& r, const std::string& name) {
  for (const auto& t : r.topics())
    if (t.name == name) return t;
  throw std::runtime_error("no topic " + name);
}

// --- Reading ---------------------------------------------------------------------------------------

TEST(BagMcap, TopicsTypesEncodingsDefinitionsCounts) {
  const auto r = open_bytes(sample(Comp::None).bytes);
  EXPECT_STREQ(r->format(), "MCAP");
  EXPECT_EQ(r->path(), "test.mcap");
  ASSERT_EQ(r->topics().size(), 3u);
  const auto& velodyne = topic_named(*r, "/velodyne_points");
  EXPECT_EQ(velodyne.type, "sensor_msgs/PointCloud2");
  EXPECT_EQ(velodyne.encoding, Encoding::Ros1);
  EXPECT_EQ(velodyne.definition, kRos1Def);
  EXPECT_EQ(velodyne.count, 3u);
  const auto& points = topic_named(*r, "/points");
  EXPECT_EQ(points.type, "sensor_msgs/PointCloud2");  // "sensor_msgs/msg/PointCloud2" in the file
  EXPECT_EQ(points.encoding, Encoding::Cdr);
  EXPECT_EQ(points.definition, kRos2Def);
  EXPECT_EQ(points.count, 4u);
  const auto& status = topic_named(*r, "/status");
  EXPECT_EQ(status.type, "json:pl.Status");  // no ROS decoder takes it
  EXPECT_EQ(status.definition, "{\"type\": \"object\"}");
  EXPECT_EQ(status.count, 1u);
  EXPECT_EQ(r->messages().size(), 8u);
}

TEST(BagMcap, MessagesComeBackExactlyInTimeOrderAcrossOverlappingChunks) {
  for (Comp comp : {Comp::None, Comp::Zstd, Comp::Lz4}) {
    SCOPED_TRACE(static_cast<int>(comp));
    const Sample s = sample(comp);
    const auto r = open_bytes(s.bytes);
    // The expected order: by time, ties in file order.
    std::vector<Sample::Msg> expected = s.written;
    std::stable_sort(expected.begin(), expected.end(), [](const auto& a, const auto& b) { return a.time < b.time; });
    ASSERT_EQ(r->messages().size(), expected.size());
    for (std::size_t i = 0; i < expected.size(); ++i) {
      const MessageRef& m = r->messages()[i];
      EXPECT_EQ(r->topics()[m.topic].name, expected[i].topic) << i;
      EXPECT_EQ(m.time_ns, static_cast<std::int64_t>(expected[i].time)) << i;
      EXPECT_EQ(m.size, expected[i].data.size()) << i;
      EXPECT_EQ(std::string(r->read(m)), expected[i].data) << i;
    }
    // The tie at 3000: the first chunk's message first.
    EXPECT_EQ(std::string(r->read(r->messages()[2])).substr(4), cloud_bytes(200, 2));
    // Backwards too (each read may need another chunk than the one kept).
    for (std::size_t i = expected.size(); i-- > 0;) EXPECT_EQ(std::string(r->read(r->messages()[i])), expected[i].data) << i;
  }
}

TEST(BagMcap, EachCompressionReadsLargeChunks) {
  for (Comp comp : {Comp::None, Comp::Zstd, Comp::Lz4}) {
    SCOPED_TRACE(static_cast<int>(comp));
    Writer w;
    w.schema(1, "sensor_msgs/msg/PointCloud2", "ros2msg", kRos2Def);
    w.channel(1, 1, "/points", "cdr");
    std::vector<std::string> data;
    for (int c = 0; c < 3; ++c) {
      w.begin_chunk();
      for (int i = 0; i < 4; ++i) {
        // A cloud of 500 KB, and random bytes (that do not compress) between them.
        data.push_back(cloud_bytes(32000, static_cast<std::uint32_t>(10 * c + i)));
        w.message(1, static_cast<std::uint64_t>(100 * c + 2 * i), data.back());
        data.push_back(random_bytes(70000 + i, static_cast<std::uint32_t>(c * 10 + i)));
        w.message(1, static_cast<std::uint64_t>(100 * c + 2 * i + 1), data.back());
      }
      w.end_chunk({comp});
    }
    const auto r = open_bytes(w.finish());
    ASSERT_EQ(r->messages().size(), data.size());
    EXPECT_EQ(r->topics()[0].count, data.size());
    for (std::size_t i = 0; i < data.size(); ++i) {
      const std::string_view got = r->read(r->messages()[i]);
      ASSERT_EQ(got.size(), data[i].size()) << i;
      EXPECT_TRUE(got == data[i]) << i;
    }
  }
}

TEST(BagMcap, UncompressedMessagesAreViewsIntoTheSource) {
  const Sample s = sample(Comp::None);
  const auto src = pl::bag::hold_bytes(s.bytes, "views.mcap");
  const auto r = pl::bag::open_mcap(src);
  const std::string_view file = src->bytes();
  for (const auto& m : r->messages()) {
    const std::string_view v = r->read(m);
    EXPECT_GE(v.data(), file.data());
    EXPECT_LE(v.data() + v.size(), file.data() + file.size());
  }
}

TEST(BagMcap, MessagesOutsideChunksWithoutSummaryOrDataEnd) {
  Writer w;
  w.schema(1, "std_msgs/String", "ros1msg", "string data\n");
  w.channel(7, 1, "/chatter", "ros1");
  w.channel(8, 0, "/raw", "cdr");  // no schema
  w.message(7, 20, "bb");
  w.message(8, 5, "raw");
  w.message(7, 10, "a");
  w.raw(0xff, "");  // unknown opcodes are skipped
  w.raw(0x42, "future record");
  const auto r = open_bytes(w.finish(false, false));
  ASSERT_EQ(r->topics().size(), 2u);
  EXPECT_EQ(topic_named(*r, "/raw").type, "");
  EXPECT_EQ(topic_named(*r, "/raw").encoding, Encoding::Cdr);
  ASSERT_EQ(r->messages().size(), 3u);
  EXPECT_EQ(r->read(r->messages()[0]), "raw");
  EXPECT_EQ(r->read(r->messages()[1]), "a");
  EXPECT_EQ(r->read(r->messages()[2]), "bb");
  EXPECT_EQ(r->messages()[1].time_ns, 10);
}

TEST(BagMcap, EmptyFile) {
  Writer w;
  const auto r = open_bytes(w.finish());
  EXPECT_TRUE(r->topics().empty());
  EXPECT_TRUE(r->messages().empty());
}

TEST(BagMcap, ChannelsOfOneTopicAreOneTopic) {
  Writer w;
  w.schema(1, "sensor_msgs/msg/Imu", "ros2msg", "x");
  w.schema(2, "std_msgs/msg/String", "ros2msg", "string data");
  w.channel(1, 1, "/imu", "cdr", {{"publisher", "a"}});
  w.channel(2, 1, "/imu", "cdr", {{"publisher", "b"}});
  w.channel(3, 2, "/imu", "cdr");  // the same name, another type: another topic
  w.message(1, 1, "one");
  w.message(2, 2, "two");
  w.message(3, 3, "three");
  const auto r = open_bytes(w.finish());
  ASSERT_EQ(r->topics().size(), 2u);
  EXPECT_EQ(r->topics()[0].type, "sensor_msgs/Imu");
  EXPECT_EQ(r->topics()[0].count, 2u);
  EXPECT_EQ(r->topics()[1].type, "std_msgs/String");
  EXPECT_EQ(r->topics()[1].count, 1u);
}

TEST(BagMcap, TypeNames) {
  Writer w;
  w.schema(1, "a/msg/B", "ros2msg", "");
  w.schema(2, "pkg/Type", "ros1msg", "");
  w.schema(3, "a/srv/B", "ros2msg", "");
  w.schema(4, "a/msg/b/c", "ros2msg", "");
  w.channel(1, 1, "/1", "cdr");
  w.channel(2, 2, "/2", "ros1");
  w.channel(3, 3, "/3", "cdr");
  w.channel(4, 4, "/4", "cdr");
  w.channel(5, 1, "/5", "protobuf");
  const auto r = open_bytes(w.finish());
  ASSERT_EQ(r->topics().size(), 5u);
  EXPECT_EQ(topic_named(*r, "/1").type, "a/B");
  EXPECT_EQ(topic_named(*r, "/2").type, "pkg/Type");
  EXPECT_EQ(topic_named(*r, "/3").type, "a/srv/B");
  EXPECT_EQ(topic_named(*r, "/4").type, "a/msg/b/c");
  EXPECT_EQ(topic_named(*r, "/5").type, "protobuf:a/msg/B");
  EXPECT_EQ(topic_named(*r, "/1").count, 0u);
}

TEST(BagMcap, OpensAFileThroughOpen) {
  pl::test::TempDir dir;
  const std::string path = dir / "drive.mcap";
  const Sample s = sample(Comp::Zstd);
  {
    std::ofstream(path, std::ios::binary) << s.bytes;
  }
  EXPECT_TRUE(pl::bag::is_recording(path));
  const auto r = pl::bag::open(path);
  EXPECT_STREQ(r->format(), "MCAP");
  EXPECT_EQ(r->path(), path);
  EXPECT_EQ(r->messages().size(), s.written.size());
  for (const auto& m : r->messages()) EXPECT_EQ(r->read(m).size(), m.size);
}

// --- Damage ----------------------------------------------------------------------------------------

// A file with a chunk of each compression and a message outside chunks, to cut and damage.
std::string small_file() {
  Writer w;
  w.schema(1, "sensor_msgs/PointCloud2", "ros1msg", kRos1Def);
  w.channel(1, 1, "/velodyne_points", "ros1");
  w.message(1, 1, "outside");
  for (Comp comp : {Comp::None, Comp::Zstd, Comp::Lz4}) {
    w.begin_chunk();
    w.message(1, 10, "first message");
    w.message(1, 20, std::string(40, 'x'));
    w.end_chunk({comp});
  }
  return w.finish();
}

TEST(BagMcap, TruncatedAtEveryByteIsRefusedNamingTheOffset) {
  const std::string full = small_file();
  ASSERT_EQ(open_bytes(full)->messages().size(), 7u);
  for (std::size_t cut = 0; cut < full.size(); ++cut) {
    const std::string e = error_of([&] { open_bytes(full.substr(0, cut), "cut.mcap"); });
    ASSERT_EQ(e.rfind("cut.mcap: offset ", 0), 0u) << "cut at " << cut << ": " << e;
    EXPECT_NE(e.find("cut short"), std::string::npos) << e;
    EXPECT_NE(e.find("mcap recover"), std::string::npos) << e;
  }
  EXPECT_EQ(error_of([&] { open_bytes(full.substr(0, full.size() - 8), "cut.mcap"); }),
            "cut.mcap: offset " + std::to_string(full.size() - 8) +
                ": the file ends inside the closing magic: the file was cut short (a recording that did not end cleanly?) or a "
                "record's length is damaged; `mcap recover cut.mcap -o FIXED.mcap` rewrites what it holds");
}

TEST(BagMcap, EveryDamagedByteIsRefusedOrReadConsistently) {
  // Whatever one damaged byte does, the reader refuses with pl::Error or gives messages that read.
  const std::string full = small_file();
  for (std::size_t i = 0; i < full.size(); ++i) {
    for (unsigned char x : {0x01, 0x80, 0xff}) {
      std::string bad = full;
      bad[i] = static_cast<char>(bad[i] ^ x);
      try {
        const auto r = open_bytes(bad);
        for (const auto& m : r->messages()) ASSERT_EQ(r->read(m).size(), m.size) << i;
      } catch (const pl::Error& e) {
        EXPECT_EQ(std::string(e.what()).rfind("test.mcap: offset ", 0), 0u) << e.what();
      }
    }
  }
}

TEST(BagMcap, BadCrc) {
  for (Comp comp : {Comp::None, Comp::Zstd, Comp::Lz4}) {
    Writer w;
    w.channel(1, 0, "/a", "cdr");
    w.begin_chunk();
    w.message(1, 1, "payload");
    ChunkOptions o;
    o.comp = comp;
    o.crc_xor = 0x10;
    const std::uint64_t at = w.end_chunk(o);
    const std::string e = error_of([&] { open_bytes(w.finish()); });
    EXPECT_NE(e.find("test.mcap: offset " + std::to_string(at) + ": the chunk's CRC does not match"), std::string::npos) << e;
  }
  // A damaged byte in an uncompressed chunk's message.
  Writer w;
  w.channel(1, 0, "/a", "cdr");
  w.begin_chunk();
  w.message(1, 1, "payload");
  w.end_chunk();
  std::string bytes = w.finish();
  bytes[bytes.find("payload")] = 'P';
  EXPECT_NE(error_of([&] { open_bytes(bytes); }).find("CRC does not match"), std::string::npos);
  // Without a CRC (0), nothing is checked.
  Writer w2;
  w2.channel(1, 0, "/a", "cdr");
  w2.begin_chunk();
  w2.message(1, 1, "payload");
  ChunkOptions no_crc;
  no_crc.crc = false;
  no_crc.comp = Comp::Zstd;
  w2.end_chunk(no_crc);
  EXPECT_EQ(open_bytes(w2.finish())->messages().size(), 1u);
}

TEST(BagMcap, DamagedRecordLength) {
  // A message's length beyond the file.
  {
    Writer w;
    w.channel(1, 0, "/a", "cdr");
    const std::uint64_t at = w.message(1, 1, "payload");
    std::string bytes = w.finish();
    const std::string huge = u64(1ull << 40);
    bytes.replace(at + 1, 8, huge);
    const std::string e = error_of([&] { open_bytes(bytes); });
    EXPECT_EQ(e.rfind("test.mcap: offset " + std::to_string(at) + ": the record there (opcode 0x05) claims 1099511627776 bytes", 0), 0u)
        << e;
  }
  // A message's length one short: the record after it begins inside it, with opcode 0.
  {
    Writer w;
    w.channel(1, 0, "/a", "cdr");
    const std::uint64_t at = w.message(1, 1, std::string("data\0", 5));
    std::string bytes = w.finish();
    const std::uint64_t len = 22 + 5 - 1;
    bytes.replace(at + 1, 8, u64(len));
    const std::string e = error_of([&] { open_bytes(bytes); });
    EXPECT_EQ(e, "test.mcap: offset " + std::to_string(at + 9 + len) + ": opcode 0 is no record (the length of the record before it is damaged?)");
  }
  // A record inside an uncompressed chunk (no CRC to catch it first).
  {
    Writer w;
    w.channel(1, 0, "/a", "cdr");
    w.begin_chunk();
    w.message(1, 1, "first");
    const std::uint64_t in_chunk = w.message(1, 2, "second");
    ChunkOptions o;
    o.crc = false;
    const std::uint64_t chunk_at = w.end_chunk(o);
    std::string bytes = w.finish();
    const std::size_t record = bytes.find("second") - 9 - 22;
    bytes.replace(record + 1, 8, u64(1000));
    const std::string e = error_of([&] { open_bytes(bytes); });
    EXPECT_EQ(e.rfind("test.mcap: offset " + std::to_string(in_chunk) + " in chunk at offset " + std::to_string(chunk_at) +
                          ": the record there (opcode 0x05) claims 1000 bytes",
                      0),
              0u)
        << e;
  }
  // A Message shorter than its fixed fields.
  {
    Writer w;
    w.channel(1, 0, "/a", "cdr");
    const std::uint64_t at = w.size();
    w.raw(0x05, u16(1) + u32(0) + u64(5));
    EXPECT_EQ(error_of([&] { open_bytes(w.finish()); }),
              "test.mcap: offset " + std::to_string(at) + ": a Message record of 14 bytes, shorter than its fixed fields (22 bytes)");
  }
  // A Schema whose string runs past its record.
  {
    Writer w;
    w.raw(0x03, u16(1) + u32(100) + "short");
    EXPECT_NE(error_of([&] { open_bytes(w.finish()); }).find("the Schema's name needs 100 bytes"), std::string::npos);
  }
}

TEST(BagMcap, UnknownCompressionIsNamed) {
  Writer w;
  w.channel(1, 0, "/a", "cdr");
  w.begin_chunk();
  w.message(1, 1, "payload");
  ChunkOptions o;
  o.compression_name = "brotli";
  w.end_chunk(o);
  const std::string e = error_of([&] { open_bytes(w.finish()); });
  EXPECT_NE(e.find("test.mcap: offset "), std::string::npos) << e;
  EXPECT_NE(e.find("a chunk compressed with \"brotli\", which this reader does not know"), std::string::npos) << e;
}

TEST(BagMcap, WrongUncompressedSizes) {
  for (Comp comp : {Comp::None, Comp::Zstd, Comp::Lz4}) {
    for (std::int64_t delta : {-1, 1}) {
      Writer w;
      w.channel(1, 0, "/a", "cdr");
      w.begin_chunk();
      w.message(1, 1, std::string(1000, 'a') + "payload");
      ChunkOptions o;
      o.comp = comp;
      o.size_delta = delta;
      o.crc = false;
      const std::uint64_t at = w.end_chunk(o);
      const std::string e = error_of([&] { open_bytes(w.finish()); });
      EXPECT_EQ(e.rfind("test.mcap: offset " + std::to_string(at) + ": ", 0), 0u) << static_cast<int>(comp) << " " << delta << ": " << e;
    }
  }
  // A size no compression reaches is refused before anything is allocated.
  for (Comp comp : {Comp::Zstd, Comp::Lz4}) {
    Writer w;
    w.channel(1, 0, "/a", "cdr");
    w.begin_chunk();
    w.message(1, 1, "payload");
    ChunkOptions o;
    o.comp = comp;
    o.size_override = 1ull << 50;
    w.end_chunk(o);
    const std::string e = error_of([&] { open_bytes(w.finish()); });
    EXPECT_NE(e.find("can compress to that (a damaged size)"), std::string::npos) << e;
  }
  // Not zstd at all.
  Writer w;
  w.channel(1, 0, "/a", "cdr");
  w.begin_chunk();
  w.message(1, 1, "payload");
  ChunkOptions o;
  o.compression_name = "zstd";
  w.end_chunk(o);
  EXPECT_NE(error_of([&] { open_bytes(w.finish()); }).find("does not begin with a zstd frame"), std::string::npos);
}

TEST(BagMcap, HighlyCompressedChunksAreRead) {
  // 8 MB of zeros: zstd makes some 300 bytes of them, lz4 some 32 KB.
  for (Comp comp : {Comp::Zstd, Comp::Lz4}) {
    Writer w;
    w.channel(1, 0, "/camera", "cdr");
    w.begin_chunk();
    w.message(1, 1, std::string(8u << 20, '\0'));
    w.end_chunk({comp});
    const auto r = open_bytes(w.finish());
    ASSERT_EQ(r->messages().size(), 1u);
    EXPECT_EQ(r->read(r->messages()[0]), std::string(8u << 20, '\0'));
  }
}

TEST(BagMcap, MissingMagic) {
  const std::string full = small_file();
  std::string bad = full;
  bad[1] = 'm';
  EXPECT_EQ(error_of([&] { open_bytes(bad); }),
            "test.mcap: offset 0: not an MCAP file: it does not begin with the MCAP magic \\x89MCAP0\\r\\n");
  bad = full;
  bad[bad.size() - 2] = '\n';
  EXPECT_EQ(error_of([&] { open_bytes(bad); }),
            "test.mcap: offset " + std::to_string(full.size() - 8) + ": expected the closing MCAP magic after the Footer record");
  EXPECT_NE(error_of([&] { open_bytes(full + "x"); }).find("1 bytes follow the closing magic"), std::string::npos);
  // The magic and then no Header.
  EXPECT_NE(error_of([&] { open_bytes(kMagic + record(0x03, u16(1) + str("a") + str("b") + str(""))); })
                .find("offset 8: expected the Header record (opcode 0x01) after the magic, found opcode 0x03"),
            std::string::npos);
}

TEST(BagMcap, MessageOnAnUnknownChannel) {
  {
    Writer w;
    w.channel(1, 0, "/a", "cdr");
    const std::uint64_t at = w.message(9, 1, "payload");
    EXPECT_EQ(error_of([&] { open_bytes(w.finish()); }),
              "test.mcap: offset " + std::to_string(at) + ": a message on channel 9, which no Channel record before it defines");
  }
  {
    Writer w;
    w.begin_chunk();
    const std::uint64_t at = w.message(3, 1, "payload");
    w.channel(3, 0, "/late", "cdr");  // after the message: too late
    const std::uint64_t chunk_at = w.end_chunk({Comp::Lz4});
    EXPECT_EQ(error_of([&] { open_bytes(w.finish()); }),
              "test.mcap: offset " + std::to_string(at) + " in chunk at offset " + std::to_string(chunk_at) +
                  ": a message on channel 3, which no Channel record before it defines");
  }
}

TEST(BagMcap, ChannelsAndSchemasDefinedAgainDifferently) {
  {
    Writer w;
    w.channel(1, 0, "/a", "cdr");
    const std::uint64_t at = w.size();
    w.channel(1, 0, "/b", "cdr");
    EXPECT_EQ(error_of([&] { open_bytes(w.finish()); }),
              "test.mcap: offset " + std::to_string(at) +
                  ": channel 1 defined again differently (topic \"/b\", encoding \"cdr\", schema 0; before: topic \"/a\", "
                  "encoding \"cdr\", schema 0)");
  }
  {
    Writer w;
    w.channel(1, 0, "/a", "cdr", {{"k", "1"}});
    w.channel(1, 0, "/a", "cdr", {{"k", "2"}});
    EXPECT_NE(error_of([&] { open_bytes(w.finish()); }).find("channel 1 defined again differently"), std::string::npos);
  }
  {
    Writer w;
    w.schema(4, "a/B", "ros1msg", "int32 x");
    const std::uint64_t at = w.size();
    w.schema(4, "a/B", "ros1msg", "int64 x");
    EXPECT_EQ(error_of([&] { open_bytes(w.finish()); }),
              "test.mcap: offset " + std::to_string(at) + ": schema 4 defined again differently (\"a/B\", before \"a/B\")");
  }
  {
    Writer w;
    const std::uint64_t at = w.size();
    w.channel(2, 5, "/a", "ros1");
    EXPECT_EQ(error_of([&] { open_bytes(w.finish()); }),
              "test.mcap: offset " + std::to_string(at) +
                  ": channel 2 (\"/a\") refers to schema 5, which no Schema record before it defines");
  }
  {
    // Schema 0 is invalid and ignored: a channel naming it has no schema.
    Writer w;
    w.schema(0, "ignored", "ros1msg", "x");
    w.channel(2, 0, "/a", "ros1");
    const auto r = open_bytes(w.finish());
    EXPECT_EQ(r->topics().at(0).type, "");
  }
}

TEST(BagMcap, OtherDamage) {
  {
    Writer w;
    w.channel(1, 0, "/a", "cdr");
    const std::uint64_t at = w.message(1, 1ull << 63, "x");
    EXPECT_NE(error_of([&] { open_bytes(w.finish()); }).find("offset " + std::to_string(at) + ": a message's log_time"), std::string::npos);
  }
  {
    Writer w;
    w.channel(1, 0, "/a", "cdr");
    w.begin_chunk();
    w.raw_bytes(record(0x06, ""));
    const std::uint64_t chunk_at = w.end_chunk();
    EXPECT_EQ(error_of([&] { open_bytes(w.finish()); }),
              "test.mcap: offset 0 in chunk at offset " + std::to_string(chunk_at) + ": a chunk inside a chunk");
  }
  {
    Writer w;
    w.raw(0x01, str("ros1") + str("again"));
    EXPECT_NE(error_of([&] { open_bytes(w.finish()); }).find("a second Header record"), std::string::npos);
  }
  {
    // An uncompressed chunk whose stated size is not its records'.
    Writer w;
    w.begin_chunk();
    ChunkOptions o;
    o.size_delta = 3;
    const std::uint64_t at = w.end_chunk(o);
    EXPECT_EQ(error_of([&] { open_bytes(w.finish()); }),
              "test.mcap: offset " + std::to_string(at) + ": an uncompressed chunk of 0 bytes says it holds 3");
  }
}

TEST(BagMcap, ReadRefusesRefsOfAnotherFile) {
  const auto r = open_bytes(sample(Comp::Zstd).bytes);
  MessageRef m = r->messages().at(0);
  m.where = 99;
  EXPECT_NE(error_of([&] { r->read(m); }).find("chunk 99 asked for"), std::string::npos);
  m = r->messages().at(0);
  m.size = 1u << 30;
  EXPECT_NE(error_of([&] { r->read(m); }).find("runs past the chunk's end"), std::string::npos);
  m.where = UINT64_MAX;
  EXPECT_NE(error_of([&] { r->read(m); }).find("runs past the end of the file"), std::string::npos);
}

}  // namespace
