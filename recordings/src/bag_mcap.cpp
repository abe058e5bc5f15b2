// MCAP files (https://mcap.dev/spec): the reader behind pl::bag::open_mcap.
//
// The data section is read from the start, record by record (opcode u8, length u64, body), without
// the summary section: the messages come from the Message records themselves, in the data section or
// inside Chunk records (compression "", "zstd" or "lz4", the LZ4 frame format). Every chunk is
// decompressed once while the file is opened, to list its messages and check its CRC; read() then
// decompresses the chunk again when a message in it is asked for, and keeps it for the following
// reads. Messages in uncompressed chunks and outside chunks are never copied: read() returns a view
// into the source (the mapped file).
//
// What this reader decides:
// - A file must begin with the magic and a Header record and end with a Footer record and the magic.
//   A file that ends earlier (a recorder that crashed) is refused, naming the offset where it stops
//   and the fix (`mcap recover`), rather than read in part without a word.
// - After the Data End record only the Footer is looked for: the summary section (copies of Schema
//   and Channel records, indexes, statistics) adds nothing a sequential read does not know.
// - Schema, Channel and Message records are read (in the data section and in chunks); Chunk records in
//   the data section; every other record (indexes, attachments, metadata, statistics, private and
//   unknown opcodes) is skipped by its length. Opcode 0 and a chunk inside a chunk are refused.
// - A channel's message_encoding "ros1" is Encoding::Ros1, "cdr" is Encoding::Cdr. Channels of any
//   other encoding (json, protobuf, ...) are listed with their messages, their type being
//   "ENCODING:SCHEMA_NAME" so that no ROS decoder takes them; read() hands out their bytes.
// - A topic's type is its schema's name, "pkg/msg/Type" given as "pkg/Type"; the definition is the
//   schema's data (ros1msg, ros2msg or ros2idl text). Channels with the same topic, type and
//   encoding are one Topic; the same topic with another type or encoding is another Topic.
// - Refused, naming the offset: a Schema or Channel id defined again differently, a channel whose
//   schema no Schema record before it defines, a message on a channel no Channel record before it
//   defines, a log time beyond int64 nanoseconds, a chunk CRC that does not match, a chunk that does
//   not decompress to its stated size, a compression this reader does not know.
//
// MessageRef: `where` is the chunk's number in the file (0, 1, ...) or kOutsideChunks for a message
// in the data section itself; `offset` is the offset of the message's data in the chunk's
// decompressed records, or in the file.
#include <lz4.h>
#include <lz4frame.h>
#include <zlib.h>
#include <zstd.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <limits>
#include <map>
#include <memory>
#include <new>
#include <string>
#include <string_view>
#include <tuple>
#include <unordered_map>
#include <vector>

#include "byte_reader.hpp"
#include "mcap_format.hpp"
#include "pl/common/error.hpp"
#include "pl/recordings/bag.hpp"

namespace pl::bag {
namespace {

using namespace mcap_format;  // the magic and the opcodes
constexpr std::uint64_t kOutsideChunks = std::numeric_limits<std::uint64_t>::max();
constexpr std::size_t kRecordPrefix = 9;  // opcode u8 + length u64

// The most a compressed chunk can expand, per byte of its compressed records: zstd's RLE blocks make
// 128 KiB of 4 bytes (100 MB of zeros compress to some 3,100 bytes, 32,000:1), LZ4's matches at most
// 255 bytes of one length byte. A stated uncompressed size beyond these is damage, refused before
// anything is allocated.
constexpr std::uint64_t kZstdMaxRatio = 32768;
constexpr std::uint64_t kLz4MaxRatio = 256;
constexpr std::uint64_t kRatioSlack = 64 * 1024;  // frame headers of tiny chunks

enum class Compression { None, Zstd, Lz4 };

struct Chunk {
  std::uint64_t offset = 0;  // of the Chunk record in the file
  std::string_view records;  // its records field, as stored (a view into the source)
  std::uint64_t uncompressed_size = 0;
  std::uint32_t crc = 0;
  Compression compression = Compression::None;
  std::string where;  // "chunk at offset N", for messages
};

struct Schema {
  std::string name, encoding, data;
  bool operator==(const Schema& o) const { return name == o.name && encoding == o.encoding && data == o.data; }
};

struct Channel {
  std::uint16_t schema_id = 0;
  std::string topic, encoding, metadata;
  std::uint32_t topic_index = 0;
  bool same(const Channel& o) const {
    return schema_id == o.schema_id && topic == o.topic && encoding == o.encoding && metadata == o.metadata;
  }
};

std::string quoted(std::string_view s) { return "\"" + std::string(s) + "\""; }

std::string hex_op(std::uint8_t op) {
  static const char* digits = "0123456789abcdef";
  return std::string("0x") + digits[op >> 4] + digits[op & 15];
}

// "sensor_msgs/msg/PointCloud2" -> "sensor_msgs/PointCloud2"; other names as they are.
std::string ros_type(std::string_view name) {
  const std::size_t a = name.find('/');
  if (a == std::string_view::npos) return std::string(name);
  const std::size_t b = name.find('/', a + 1);
  if (b == std::string_view::npos || name.find('/', b + 1) != std::string_view::npos) return std::string(name);
  if (name.substr(a + 1, b - a - 1) != "msg") return std::string(name);
  return std::string(name.substr(0, a + 1)) + std::string(name.substr(b + 1));
}

std::string_view string_field(ByteReader& r, const char* what) {
  const std::uint32_t n = r.u32(what);
  return r.bytes(n, what);
}

// Decompressed bytes, uninitialised (a chunk is written over whole), kept between chunks.
class Buffer {
 public:
  char* resize(std::size_t n) {
    if (n > capacity_) {
      data_.reset();
      capacity_ = 0;
      data_.reset(new char[n]);
      capacity_ = n;
    }
    size_ = n;
    return data_.get();
  }
  std::string_view view() const { return {data_.get(), size_}; }

 private:
  std::unique_ptr<char[]> data_;
  std::size_t capacity_ = 0;
  std::size_t size_ = 0;
};

class McapReader : public Reader {
 public:
  explicit McapReader(std::shared_ptr<const Source> src) : src_(std::move(src)) {
    path_ = src_->name();
    scan();
    // By time, ties in file order. A file written in time order is sorted already.
    const auto by_time = [](const MessageRef& a, const MessageRef& b) { return a.time_ns < b.time_ns; };
    if (!std::is_sorted(messages_.begin(), messages_.end(), by_time))
      std::stable_sort(messages_.begin(), messages_.end(), by_time);
  }

  const char* format() const override { return "MCAP"; }

  std::string_view read(const MessageRef& m) override {
    if (m.where == kOutsideChunks) {
      const std::string_view b = src_->bytes();
      if (m.offset > b.size() || m.size > b.size() - m.offset)
        throw Error(path_ + ": offset " + std::to_string(m.offset) + ": a message of " + std::to_string(m.size) +
                    " bytes there runs past the end of the file (" + std::to_string(b.size()) + " bytes)");
      return b.substr(static_cast<std::size_t>(m.offset), static_cast<std::size_t>(m.size));
    }
    if (m.where >= chunks_.size())
      throw Error(path_ + ": chunk " + std::to_string(m.where) + " asked for: the file has " +
                  std::to_string(chunks_.size()) + " chunks (a message of another file?)");
    const std::string_view records = chunk_records(static_cast<std::size_t>(m.where), false);
    if (m.offset > records.size() || m.size > records.size() - m.offset)
      throw Error(path_ + ": offset " + std::to_string(m.offset) + " in " + chunks_[m.where].where + ": a message of " +
                  std::to_string(m.size) + " bytes there runs past the chunk's end (" + std::to_string(records.size()) +
                  " bytes)");
    return records.substr(static_cast<std::size_t>(m.offset), static_cast<std::size_t>(m.size));
  }

 private:
  [[noreturn]] void fail(std::uint64_t offset, const std::string& problem) const {
    throw Error(path_ + ": offset " + std::to_string(offset) + ": " + problem);
  }

  [[noreturn]] void cut_short(std::uint64_t offset, const std::string& what) const {
    fail(offset, what + ": the file was cut short (a recording that did not end cleanly?) or a record's length is damaged; " +
                     "`mcap recover " + path_ + " -o FIXED.mcap` rewrites what it holds");
  }

  void scan() {
    const std::string_view b = src_->bytes();
    if (b.size() < kMagic.size() || b.substr(0, kMagic.size()) != kMagic) {
      if (b.size() < kMagic.size() && kMagic.substr(0, b.size()) == b) cut_short(b.size(), "the file ends inside the MCAP magic");
      fail(0, "not an MCAP file: it does not begin with the MCAP magic \\x89MCAP0\\r\\n");
    }
    std::size_t pos = kMagic.size();
    bool data_end = false;
    for (bool first = true;; first = false) {
      if (b.size() - pos < kRecordPrefix) {
        if (b.size() == pos) cut_short(pos, "the file ends without its Footer record and closing magic");
        cut_short(pos, "the file ends inside a record's opcode and length (" + std::to_string(b.size() - pos) + " bytes left)");
      }
      const auto op = static_cast<std::uint8_t>(b[pos]);
      std::uint64_t len = 0;
      std::memcpy(&len, b.data() + pos + 1, sizeof len);  // little-endian host (x86-64, arm64)
      const std::size_t body_at = pos + kRecordPrefix;
      if (first && op != kHeader) fail(pos, "expected the Header record (opcode 0x01) after the magic, found opcode " + hex_op(op));
      if (op == 0) fail(pos, "opcode 0 is no record (the length of the record before it is damaged?)");
      if (len > b.size() - body_at)
        cut_short(pos, "the record there (opcode " + hex_op(op) + ") claims " + std::to_string(len) + " bytes, " +
                           std::to_string(b.size() - body_at) + " are left");
      const std::string_view body = b.substr(body_at, static_cast<std::size_t>(len));
      const std::size_t end = body_at + static_cast<std::size_t>(len);
      if (op == kFooter) {
        ByteReader r(body, path_, body_at);
        r.u64("the Footer's summary_start");
        r.u64("the Footer's summary_offset_start");
        r.u32("the Footer's summary_crc");
        if (b.size() - end < kMagic.size()) cut_short(end, "the file ends inside the closing magic");
        if (b.substr(end, kMagic.size()) != kMagic) fail(end, "expected the closing MCAP magic after the Footer record");
        if (b.size() - end > kMagic.size())
          fail(end + kMagic.size(), std::to_string(b.size() - end - kMagic.size()) + " bytes follow the closing magic");
        return;
      }
      if (op == kHeader && !first) fail(pos, "a second Header record");
      if (op == kDataEnd) data_end = true;
      if (!data_end) {
        if (op == kChunk) {
          chunk(b.substr(pos, end - pos), pos);
        } else if (op != kHeader) {
          record(op, b.substr(pos, end - pos), pos, kOutsideChunks, no_where_);
        }
      }
      pos = end;
    }
  }

  // "FILE: offset N[ in WHERE]: PROBLEM", as ByteReader says it.
  [[noreturn]] void fail_in(std::uint64_t offset, const std::string& where, const std::string& problem) const {
    throw Error(path_ + ": offset " + std::to_string(offset) + (where.empty() ? "" : " in " + where) + ": " + problem);
  }

  // A Schema, Channel or Message record (others are skipped) of the data section or of chunk `where`
  // (named `where_name` in messages): `rec`, from its opcode, at offset `at` in the file or in the
  // chunk's records.
  void record(std::uint8_t op, std::string_view rec, std::uint64_t at, std::uint64_t where, const std::string& where_name) {
    if (op == kMessage) {
      // The hot path (every message of the file): the fixed fields read directly.
      constexpr std::size_t kFixed = kRecordPrefix + 2 + 4 + 8 + 8;  // channel_id, sequence, log_time, publish_time
      if (rec.size() < kFixed)
        fail_in(at, where_name, "a Message record of " + std::to_string(rec.size() - kRecordPrefix) +
                                    " bytes, shorter than its fixed fields (22 bytes)");
      std::uint16_t channel_id = 0;
      std::uint64_t log_time = 0;
      std::memcpy(&channel_id, rec.data() + kRecordPrefix, sizeof channel_id);
      std::memcpy(&log_time, rec.data() + kRecordPrefix + 6, sizeof log_time);
      if (channel_id != last_channel_id_ || !last_channel_) {
        const auto c = channels_.find(channel_id);
        if (c == channels_.end())
          fail_in(at, where_name, "a message on channel " + std::to_string(channel_id) + ", which no Channel record before it defines");
        last_channel_id_ = channel_id;
        last_channel_ = &c->second;
      }
      if (log_time > static_cast<std::uint64_t>(std::numeric_limits<std::int64_t>::max()))
        fail_in(at, where_name, "a message's log_time " + std::to_string(log_time) + " lies beyond the year 2262 (damaged?)");
      MessageRef m;
      m.topic = last_channel_->topic_index;
      m.time_ns = static_cast<std::int64_t>(log_time);
      m.where = where;
      m.offset = at + kFixed;
      m.size = rec.size() - kFixed;
      messages_.push_back(m);
      ++topics_[m.topic].count;
      return;
    }
    if (op != kSchema && op != kChannel) return;
    ByteReader r(rec, path_, at, where_name);
    r.seek(kRecordPrefix);
    if (op == kSchema) {
      const std::uint16_t id = r.u16("the Schema's id");
      Schema s;
      s.name = std::string(string_field(r, "the Schema's name"));
      s.encoding = std::string(string_field(r, "the Schema's encoding"));
      s.data = std::string(string_field(r, "the Schema's data"));
      if (id == 0) return;  // invalid; the spec says to ignore it
      const auto [it, added] = schemas_.emplace(id, s);
      if (!added && !(it->second == s))
        r.fail_at_offset(0, "schema " + std::to_string(id) + " defined again differently (" + quoted(s.name) + ", before " +
                                quoted(it->second.name) + ")");
    } else if (op == kChannel) {
      const std::uint16_t id = r.u16("the Channel's id");
      Channel c;
      c.schema_id = r.u16("the Channel's schema_id");
      c.topic = std::string(string_field(r, "the Channel's topic"));
      c.encoding = std::string(string_field(r, "the Channel's message_encoding"));
      c.metadata = std::string(string_field(r, "the Channel's metadata"));
      const auto known = channels_.find(id);
      if (known != channels_.end()) {
        if (!known->second.same(c))
          r.fail_at_offset(0, "channel " + std::to_string(id) + " defined again differently (topic " + quoted(c.topic) +
                                  ", encoding " + quoted(c.encoding) + ", schema " + std::to_string(c.schema_id) +
                                  "; before: topic " + quoted(known->second.topic) + ", encoding " +
                                  quoted(known->second.encoding) + ", schema " + std::to_string(known->second.schema_id) + ")");
        return;
      }
      const Schema* schema = nullptr;
      if (c.schema_id != 0) {
        const auto s = schemas_.find(c.schema_id);
        if (s == schemas_.end())
          r.fail_at_offset(0, "channel " + std::to_string(id) + " (" + quoted(c.topic) + ") refers to schema " +
                                  std::to_string(c.schema_id) + ", which no Schema record before it defines");
        schema = &s->second;
      }
      c.topic_index = topic_of(c, schema);
      channels_.emplace(id, c);
    }
  }

  std::uint32_t topic_of(const Channel& c, const Schema* schema) {
    Topic t;
    t.name = std::string(c.topic);
    if (c.encoding == "ros1" || c.encoding == "cdr") {
      t.encoding = c.encoding == "ros1" ? Encoding::Ros1 : Encoding::Cdr;
      if (schema) t.type = ros_type(schema->name);
    } else {
      // No decoder of pl::bag's encodings reads these: the type says what they are.
      t.type = std::string(c.encoding) + ":" + (schema ? std::string(schema->name) : std::string());
    }
    if (schema) t.definition = std::string(schema->data);
    auto key = std::make_tuple(t.name, t.type, t.encoding);
    const auto [it, added] = topic_index_.emplace(std::move(key), static_cast<std::uint32_t>(topics_.size()));
    if (added) topics_.push_back(std::move(t));
    return it->second;
  }

  // The Chunk record `rec` (from its opcode) at `record_at` in the file: checked, decompressed, and
  // its records read.
  void chunk(std::string_view rec, std::size_t record_at) {
    ByteReader r(rec, path_, record_at);
    r.seek(kRecordPrefix);
    Chunk c;
    c.offset = record_at;
    c.where = "chunk at offset " + std::to_string(record_at);
    r.u64("the Chunk's message_start_time");
    r.u64("the Chunk's message_end_time");
    c.uncompressed_size = r.u64("the Chunk's uncompressed_size");
    c.crc = r.u32("the Chunk's uncompressed_crc");
    const std::size_t compression_at = r.pos();
    const std::string_view compression = string_field(r, "the Chunk's compression");
    const std::uint64_t records_size = r.u64("the Chunk's records length");
    c.records = r.bytes(records_size, "the Chunk's records");
    const std::uint64_t stored = c.records.size();
    if (compression.empty()) {
      c.compression = Compression::None;
      if (c.uncompressed_size != stored)
        fail(record_at, "an uncompressed chunk of " + std::to_string(stored) + " bytes says it holds " +
                            std::to_string(c.uncompressed_size));
    } else if (compression == "zstd" || compression == "lz4") {
      c.compression = compression == "zstd" ? Compression::Zstd : Compression::Lz4;
      const std::uint64_t ratio = c.compression == Compression::Zstd ? kZstdMaxRatio : kLz4MaxRatio;
      if (c.uncompressed_size > stored * ratio + kRatioSlack)
        fail(record_at, "a " + std::string(compression) + " chunk of " + std::to_string(stored) + " bytes says it holds " +
                            std::to_string(c.uncompressed_size) + ", more than " + std::string(compression) +
                            " can compress to that (a damaged size)");
      if (c.uncompressed_size > std::numeric_limits<std::size_t>::max() / 2)
        fail(record_at, "a chunk of " + std::to_string(c.uncompressed_size) + " bytes is more than this reader takes");
    } else {
      fail(record_at + compression_at, "a chunk compressed with " + quoted(compression) +
                                         ", which this reader does not know (it reads \"\", \"zstd\" and \"lz4\")");
    }
    chunks_.push_back(std::move(c));
    const std::size_t index = chunks_.size() - 1;
    const std::string_view records = chunk_records(index, true);
    // The chunk's records: offsets in messages are those in the decompressed records.
    ByteReader rr(records, path_, 0, chunks_[index].where);
    while (!rr.done()) {
      const std::size_t at = rr.pos();
      const std::uint8_t op = rr.u8("a record's opcode");
      const std::uint64_t len = rr.u64("a record's length");
      if (op == 0) rr.fail_at_offset(at, "opcode 0 is no record (the length of the record before it is damaged?)");
      if (len > rr.left())
        rr.fail_at_offset(at, "the record there (opcode " + hex_op(op) + ") claims " + std::to_string(len) + " bytes, " +
                                  std::to_string(rr.left()) + " are left in the chunk (a damaged length)");
      rr.bytes(len, "a record");
      if (op == kChunk) rr.fail_at_offset(at, "a chunk inside a chunk");
      record(op, records.substr(at, kRecordPrefix + static_cast<std::size_t>(len)), at, index, chunks_[index].where);
    }
  }

  // Chunk i's records, decompressed (and kept until another chunk is asked for); `check_crc`: verify
  // its CRC when it has one (done once, when the file is opened).
  std::string_view chunk_records(std::size_t i, bool check_crc) {
    const Chunk& c = chunks_[i];
    std::string_view out;
    if (c.compression == Compression::None) {
      out = c.records;
    } else if (cached_ == i) {
      out = buffer_.view();
    } else {
      cached_ = kOutsideChunks;
      char* dst = nullptr;
      try {
        dst = buffer_.resize(static_cast<std::size_t>(c.uncompressed_size));
      } catch (const std::bad_alloc&) {
        fail(c.offset, "cannot allocate " + std::to_string(c.uncompressed_size) + " bytes to decompress the chunk");
      }
      if (c.compression == Compression::Zstd)
        unzstd(c, dst);
      else
        unlz4(c, dst, !check_crc || c.crc != 0);
      cached_ = i;
      out = buffer_.view();
    }
    if (check_crc && c.crc != 0) {
      const std::uint32_t crc = static_cast<std::uint32_t>(
          crc32_z(0L, reinterpret_cast<const Bytef*>(out.data()), out.size()));
      if (crc != c.crc) {
        cached_ = kOutsideChunks;
        fail(c.offset, "the chunk's CRC does not match (" + std::to_string(crc) + ", the chunk says " + std::to_string(c.crc) +
                           "): its bytes are damaged");
      }
    }
    return out;
  }

  void unzstd(const Chunk& c, char* dst) {
    const std::size_t n = static_cast<std::size_t>(c.uncompressed_size);
    if (c.records.empty() && n == 0) return;
    // The first frame's header, checked before anything is decompressed: it must be zstd, and the
    // size it states (when it states one) must fit the chunk's, exactly when it is the only frame.
    const unsigned long long first = ZSTD_getFrameContentSize(c.records.data(), c.records.size());
    if (first == ZSTD_CONTENTSIZE_ERROR) fail(c.offset, "the zstd chunk does not begin with a zstd frame (damaged)");
    if (first != ZSTD_CONTENTSIZE_UNKNOWN) {
      const bool only = ZSTD_findFrameCompressedSize(c.records.data(), c.records.size()) == c.records.size();
      if (first > c.uncompressed_size || (only && first != c.uncompressed_size))
        fail(c.offset, "the zstd chunk's frame holds " + std::to_string(first) + " bytes, the chunk says " +
                           std::to_string(c.uncompressed_size));
    }
    if (!zstd_) {
      zstd_.reset(ZSTD_createDCtx());
      if (!zstd_) throw std::bad_alloc();
    }
    const std::size_t got = ZSTD_decompressDCtx(zstd_.get(), dst, n, c.records.data(), c.records.size());
    if (ZSTD_isError(got))
      fail(c.offset, std::string("the zstd chunk does not decompress (") + ZSTD_getErrorName(got) + "; or it holds more than the " +
                         std::to_string(n) + " bytes it says)");
    if (got != n)
      fail(c.offset, "the zstd chunk decompresses to " + std::to_string(got) + " bytes, it says " + std::to_string(n));
  }

  // `skip_checksums`: leave LZ4's own checksums (xxHash, a third of the time) unchecked, when the
  // chunk's CRC is checked or was checked when the file was opened.
  void unlz4(const Chunk& c, char* dst, bool skip_checksums) {
    const std::size_t n = static_cast<std::size_t>(c.uncompressed_size);
    if (c.records.empty() && n == 0) return;
    if (!lz4_) {
      LZ4F_dctx* ctx = nullptr;
      if (LZ4F_isError(LZ4F_createDecompressionContext(&ctx, LZ4F_VERSION))) throw std::bad_alloc();
      lz4_.reset(ctx);
    } else {
      LZ4F_resetDecompressionContext(lz4_.get());
    }
    LZ4F_decompressOptions_t options{};
    options.stableDst = 1;  // dst is one buffer, left alone between calls
#if LZ4_VERSION_NUMBER >= 10904
    options.skipChecksums = skip_checksums ? 1 : 0;
#else
    (void)skip_checksums;
#endif
    std::size_t in = 0, out = 0, hint = 1;
    // Frame after frame (a chunk may hold several) until the input is used up.
    while (in < c.records.size()) {
      std::size_t dst_n = n - out, src_n = c.records.size() - in;
      hint = LZ4F_decompress(lz4_.get(), dst + out, &dst_n, c.records.data() + in, &src_n, &options);
      if (LZ4F_isError(hint)) {
        LZ4F_resetDecompressionContext(lz4_.get());
        fail(c.offset, std::string("the lz4 chunk does not decompress (") + LZ4F_getErrorName(hint) + ")");
      }
      in += src_n;
      out += dst_n;
      if (src_n == 0 && dst_n == 0) {
        LZ4F_resetDecompressionContext(lz4_.get());
        fail(c.offset, "the lz4 chunk decompresses to more than the " + std::to_string(n) + " bytes it says");
      }
    }
    if (hint != 0) {
      LZ4F_resetDecompressionContext(lz4_.get());
      fail(c.offset, "the lz4 chunk's frame is cut short");
    }
    if (out != n) fail(c.offset, "the lz4 chunk decompresses to " + std::to_string(out) + " bytes, it says " + std::to_string(n));
  }

  std::shared_ptr<const Source> src_;
  std::vector<Chunk> chunks_;
  std::unordered_map<std::uint16_t, Schema> schemas_;
  std::unordered_map<std::uint16_t, Channel> channels_;  // (nodes: last_channel_ stays valid)
  std::map<std::tuple<std::string, std::string, Encoding>, std::uint32_t> topic_index_;
  const std::string no_where_;  // a record outside chunks
  std::uint16_t last_channel_id_ = 0;
  const Channel* last_channel_ = nullptr;
  Buffer buffer_;
  std::size_t cached_ = kOutsideChunks;  // the chunk in buffer_
  struct FreeZstd {
    void operator()(ZSTD_DCtx* c) const { ZSTD_freeDCtx(c); }
  };
  struct FreeLz4 {
    void operator()(LZ4F_dctx* c) const { LZ4F_freeDecompressionContext(c); }
  };
  // Made on the first chunk that needs one, kept for the next.
  std::unique_ptr<ZSTD_DCtx, FreeZstd> zstd_;
  std::unique_ptr<LZ4F_dctx, FreeLz4> lz4_;
};

}  // namespace

std::unique_ptr<Reader> open_mcap(std::shared_ptr<const Source> src) { return std::make_unique<McapReader>(std::move(src)); }

}  // namespace pl::bag
