// ROS 1 bags (format 2.0, "#ROSBAG V2.0"): the records are read in file order, chunk by chunk, so
// that a recording stopped before rosbag wrote its index still gives every message it holds. The
// index section at the end is not needed and not trusted; plain chunks are handed out as views of
// the mapped file, bz2 and lz4 chunks are decompressed on demand (the last one is kept).
#include <bzlib.h>
#include <lz4frame.h>

#include <algorithm>
#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <string_view>
#include <unordered_map>
#include <utility>
#include <vector>

#include "byte_reader.hpp"
#include "pl/common/error.hpp"
#include "pl/common/text.hpp"
#include "pl/recordings/bag.hpp"

namespace pl::bag {
namespace {

constexpr std::string_view kMagic = "#ROSBAG V2.0\n";

// Record kinds (the "op" field of a record header).
constexpr std::uint8_t kOpMessage = 0x02;
constexpr std::uint8_t kOpBagHeader = 0x03;
constexpr std::uint8_t kOpIndex = 0x04;
constexpr std::uint8_t kOpChunk = 0x05;
constexpr std::uint8_t kOpChunkInfo = 0x06;
constexpr std::uint8_t kOpConnection = 0x07;

// MessageRef::where of a message record that lies outside any chunk (its offset is then one in the
// file). rosbag always writes messages into chunks, but a chunk whose length was never written (a
// recorder killed mid-chunk) leaves its records to be read as if they stood on their own.
constexpr std::uint64_t kOutsideChunk = ~std::uint64_t{0};

// How far a chunk's declared uncompressed size may exceed its stored size. LZ4 spends at least one
// byte per 255 bytes of a match, so it cannot do better than about 255:1 (plus its frame header).
// bzip2 turns a run of up to 255 bytes into 5 before sorting, and a block of such runs can end up
// in about 25 bytes: some 45.9 MB from 25 bytes, a bound of 2,000,000:1.
constexpr std::uint64_t kLz4MaxRatio = 255;
constexpr std::uint64_t kLz4Slack = 64 * 1024;
constexpr std::uint64_t kBz2MaxRatio = 2000000;

std::string num(std::uint64_t v) { return std::to_string(v); }

// One "name=value" field of a record header (or of a connection record's data).
struct Field {
  std::string_view name;
  std::string_view value;
  std::size_t at = 0;  // where its length starts, in the reader's offsets
};

struct Record {
  std::size_t at = 0;  // where its header length starts
  std::uint8_t op = 0;
  std::vector<Field> fields;
  std::string_view data;
  std::size_t data_at = 0;
};

const char* op_name(std::uint8_t op) {
  switch (op) {
    case kOpMessage:
      return "message data";
    case kOpBagHeader:
      return "bag header";
    case kOpIndex:
      return "index data";
    case kOpChunk:
      return "chunk";
    case kOpChunkInfo:
      return "chunk info";
    case kOpConnection:
      return "connection";
    default:
      return "unknown";
  }
}

// The fields from r.pos() up to `end`; leaves r at `end`. Each field takes at least 5 bytes (its
// length and the '='), so the count is bounded by the bytes.
void parse_fields(ByteReader& r, std::size_t end, std::vector<Field>& out, const std::string& hint) {
  out.clear();
  while (r.pos() < end) {
    const std::size_t at = r.pos();
    if (end - at < 4) r.fail("a header field needs a 4-byte length, " + num(end - at) + " bytes of the header are left" + hint);
    const std::uint32_t n = r.u32("a header field's length");
    if (n > end - r.pos())
      r.fail_at_offset(at, "a header field's length (" + num(n) + " bytes) runs past the end of its header (" +
                               num(end - r.pos()) + " bytes left)" + hint);
    const std::string_view text = r.bytes(n, "a header field");
    const std::size_t eq = text.find('=');
    if (eq == std::string_view::npos) r.fail_at_offset(at, "a header field without '=' (\"" + printable(text, 40) + "\")" + hint);
    out.push_back({text.substr(0, eq), text.substr(eq + 1), at});
  }
}

// The record at r.pos(); leaves r after it. `hint` ends the message of a length that runs past the
// end (what the reader can do about it).
void read_record(ByteReader& r, Record& rec, const std::string& hint) {
  rec.at = r.pos();
  if (r.left() < 4) r.fail("a record needs a 4-byte header length, " + num(r.left()) + " bytes are left" + hint);
  const std::uint32_t header_len = r.u32("a record's header length");
  if (header_len > r.left())
    r.fail_at_offset(rec.at, "the record's header length (" + num(header_len) + " bytes) runs past the end (" + num(r.left()) +
                                 " bytes left)" + hint);
  parse_fields(r, r.pos() + header_len, rec.fields, hint);
  const std::size_t data_len_at = r.pos();
  if (r.left() < 4) r.fail("the record's data length needs 4 bytes, " + num(r.left()) + " are left" + hint);
  const std::uint32_t data_len = r.u32("a record's data length");
  if (data_len > r.left())
    r.fail_at_offset(data_len_at, "the record's data length (" + num(data_len) + " bytes) runs past the end (" + num(r.left()) +
                                      " bytes left)" + hint);
  rec.data_at = r.pos();
  rec.data = r.bytes(data_len, "a record's data");

  const Field* op = nullptr;
  for (const Field& f : rec.fields)
    if (f.name == "op") {
      op = &f;
      break;
    }
  if (!op) r.fail_at_offset(rec.at, "a record without an \"op\" field" + hint);
  if (op->value.size() != 1)
    r.fail_at_offset(op->at, "the \"op\" field has " + num(op->value.size()) + " bytes, expected 1" + hint);
  rec.op = static_cast<std::uint8_t>(op->value[0]);
}

const Field* find(const std::vector<Field>& fields, std::string_view name) {
  for (const Field& f : fields)
    if (f.name == name) return &f;
  return nullptr;
}

// A field that must be there, of exactly `width` bytes when width > 0.
std::string_view need(const ByteReader& r, const Record& rec, const std::vector<Field>& fields, std::string_view name,
                      std::size_t width) {
  const Field* f = find(fields, name);
  if (!f) r.fail_at_offset(rec.at, std::string("the ") + op_name(rec.op) + " record has no \"" + std::string(name) + "\" field");
  if (width && f->value.size() != width)
    r.fail_at_offset(f->at, "the \"" + std::string(name) + "\" field of the " + op_name(rec.op) + " record has " +
                                num(f->value.size()) + " bytes, expected " + num(width));
  return f->value;
}

template <typename T>
T as(std::string_view v) {
  T out;
  std::memcpy(&out, v.data(), sizeof(T));  // the width was checked by need()
  return out;
}

enum class Codec { None, Bz2, Lz4 };

const char* codec_name(Codec c) { return c == Codec::Bz2 ? "bz2" : c == Codec::Lz4 ? "lz4" : "none"; }

struct Chunk {
  std::uint64_t at = 0;       // the chunk record, in the file
  std::uint64_t data_at = 0;  // its data, in the file
  std::uint32_t stored = 0;   // bytes of data in the file
  std::uint32_t size = 0;     // bytes once decompressed
  Codec codec = Codec::None;
};

struct Connection {
  std::string topic;
  std::string type;
  std::uint32_t topic_index = 0;
};

class Ros1Bag final : public Reader {
 public:
  explicit Ros1Bag(std::shared_ptr<const Source> src) : src_(std::move(src)) {
    path_ = src_->name();
    scan();
  }

  const char* format() const override { return "ROS 1 bag"; }

  std::string_view read(const MessageRef& m) override {
    std::string_view area;
    if (m.where == kOutsideChunk) {
      area = src_->bytes();
    } else {
      if (m.where >= chunks_.size())
        throw Error(path_ + ": no chunk " + num(m.where) + " (the bag has " + num(chunks_.size()) +
                    "): the message reference does not come from this reader");
      area = chunk_bytes(m.where);
    }
    if (m.offset > area.size() || m.size > area.size() - m.offset)
      throw Error(path_ + ": " + place(m) + ": a message of " + num(m.size) + " bytes does not fit its " +
                  (m.where == kOutsideChunk ? "file" : "chunk") + " (" + num(area.size()) +
                  " bytes): the message reference does not come from this reader");
    return area.substr(static_cast<std::size_t>(m.offset), static_cast<std::size_t>(m.size));
  }

 private:
  void scan();
  void scan_chunk(const Chunk& c, std::size_t index);
  void add_connection(ByteReader& r, const Record& rec);
  void add_message(const ByteReader& r, const Record& rec, std::uint64_t where, std::uint64_t offset);
  std::string_view chunk_bytes(std::size_t index);
  void inflate_bz2(const Chunk& c, std::string_view in);
  void inflate_lz4(const Chunk& c, std::string_view in);
  [[noreturn]] void fail_chunk(const Chunk& c, const std::string& problem) const {
    throw Error(path_ + ": offset " + num(c.at) + ": the " + codec_name(c.codec) + " chunk " + problem + "; `rosbag reindex " +
                path_ + "` keeps the chunks before it");
  }
  std::string chunk_where(const Chunk& c) const {
    return c.codec == Codec::None ? "the chunk at offset " + num(c.at)
                                  : std::string("the decompressed ") + codec_name(c.codec) + " chunk at offset " + num(c.at);
  }
  // "offset N[ in WHERE]" of a message's data, for messages.
  std::string place(const MessageRef& m) const {
    if (m.where >= chunks_.size()) return "offset " + num(m.offset);
    const Chunk& c = chunks_[m.where];
    if (c.codec == Codec::None) return "offset " + num(c.data_at + m.offset) + " in " + chunk_where(c);
    return "offset " + num(m.offset) + " in " + chunk_where(c);
  }

  std::shared_ptr<const Source> src_;
  std::vector<Chunk> chunks_;
  std::unordered_map<std::uint32_t, Connection> connections_;
  std::map<std::pair<std::string, std::string>, std::uint32_t> topic_of_;  // (name, type) -> index
  std::vector<std::size_t> unresolved_;                                    // messages whose connection was not yet described
  Record rec_;                                                             // scratch, to keep the field lists' memory
  std::vector<Field> conn_fields_;
  std::string cache_;                                  // the decompressed chunk...
  std::size_t cached_ = static_cast<std::size_t>(-1);  // ...and its index
};

void Ros1Bag::scan() {
  const std::string_view file = src_->bytes();
  ByteReader r(file, path_);
  if (file.substr(0, kMagic.size()) != kMagic) {
    const std::string_view head = file.substr(0, std::min<std::size_t>(file.find('\n'), 16));
    if (head.substr(0, 4) == "#ROS")
      r.fail_at_offset(0, "a ROS bag of another format version (\"" + printable(head) +
                              "\"): this reader reads format 2.0; convert it with `rosbag fix " + path_ + " new.bag`");
    r.fail_at_offset(0, "not a ROS 1 bag: expected \"#ROSBAG V2.0\", found \"" + printable(head) + "\"");
  }
  r.seek(kMagic.size());
  const std::string hint =
      "; the bag is cut short or damaged here: `rosbag reindex " + path_ + "` rebuilds it from the chunks before this offset";

  Record& rec = rec_;
  read_record(r, rec, hint);
  if (rec.op != kOpBagHeader)
    r.fail_at_offset(rec.at, std::string("expected the bag header record (op 3), found a ") + op_name(rec.op) + " record (op " +
                                 num(rec.op) + ")");
  if (const Field* enc = find(rec.fields, "encryptor"); enc && !enc->value.empty())
    r.fail_at_offset(
        enc->at, "an encrypted bag (\"" + printable(enc->value) + "\"): decrypt it with `rosbag decrypt " + path_ + "` first");

  while (!r.done()) {
    read_record(r, rec, hint);
    switch (rec.op) {
      case kOpChunk: {
        Chunk c;
        c.at = rec.at;
        c.data_at = rec.data_at;
        c.stored = static_cast<std::uint32_t>(rec.data.size());
        const Field* comp = find(rec.fields, "compression");
        const std::string_view name = comp ? comp->value : std::string_view("none");
        if (name == "none") {
          c.codec = Codec::None;
        } else if (name == "bz2") {
          c.codec = Codec::Bz2;
        } else if (name == "lz4") {
          c.codec = Codec::Lz4;
        } else {
          r.fail_at_offset(comp->at, "chunk compression \"" + printable(name, 40) +
                                         "\" is not one ROS 1 bags use (none, bz2 or lz4): the bag is damaged or "
                                         "was written by another tool");
        }
        if (c.codec == Codec::None) {
          c.size = c.stored;
          if (const Field* size = find(rec.fields, "size")) {
            const std::uint32_t declared = as<std::uint32_t>(need(r, rec, rec.fields, "size", 4));
            if (declared != c.stored)
              r.fail_at_offset(size->at,
                               "the uncompressed chunk declares " + num(declared) + " bytes but holds " + num(c.stored) + hint);
          }
        } else {
          c.size = as<std::uint32_t>(need(r, rec, rec.fields, "size", 4));
          if (c.stored == 0)
            r.fail_at_offset(rec.at, std::string("the ") + codec_name(c.codec) +
                                         " chunk has no data (the recording stopped before its length was written)" + hint);
          const std::uint64_t bound = c.codec == Codec::Lz4 ? c.stored * kLz4MaxRatio + kLz4Slack : c.stored * kBz2MaxRatio;
          if (c.size > bound)
            r.fail_at_offset(find(rec.fields, "size")->at, "the chunk declares " + num(c.size) +
                                                               " bytes uncompressed, more than " + num(c.stored) + " bytes of " +
                                                               codec_name(c.codec) + " can hold" + hint);
        }
        chunks_.push_back(c);
        scan_chunk(chunks_.back(), chunks_.size() - 1);
        break;
      }
      case kOpConnection:
        add_connection(r, rec);
        break;
      case kOpMessage:
        add_message(r, rec, kOutsideChunk, rec.data_at);
        break;
      case kOpBagHeader:
        r.fail_at_offset(rec.at, "a second bag header record" + hint);
      default:
        // Index data, chunk info and records this reader does not know: the messages are all
        // found in the chunks, so these are skipped whole.
        break;
    }
  }

  // Connection records normally precede their messages inside the chunks; bags written by old
  // recorders have some only after the chunks, so a message is matched once all are known.
  for (const std::size_t i : unresolved_) {
    MessageRef& m = messages_[i];
    const auto it = connections_.find(m.topic);
    if (it == connections_.end())
      throw Error(path_ + ": " + place(m) + ": a message on connection " + num(m.topic) +
                  ", which no connection record in the bag describes (the bag is damaged)");
    m.topic = it->second.topic_index;
    ++topics_[m.topic].count;
  }
  unresolved_.clear();

  const auto by_time = [](const MessageRef& a, const MessageRef& b) { return a.time_ns < b.time_ns; };
  if (!std::is_sorted(messages_.begin(), messages_.end(), by_time)) std::stable_sort(messages_.begin(), messages_.end(), by_time);
}

void Ros1Bag::scan_chunk(const Chunk& c, std::size_t index) {
  const std::string_view bytes = chunk_bytes(index);
  // Positions count from the chunk's start (what a MessageRef holds); the messages of a plain chunk
  // name file offsets, those of a decompressed one offsets in it.
  ByteReader r(bytes, path_, c.codec == Codec::None ? c.data_at : 0, chunk_where(c));
  const std::string hint = "; the chunk is damaged: `rosbag reindex " + path_ + "` keeps the chunks before it";
  Record& rec = rec_;
  while (!r.done()) {
    read_record(r, rec, hint);
    switch (rec.op) {
      case kOpConnection:
        add_connection(r, rec);
        break;
      case kOpMessage:
        add_message(r, rec, index, rec.data_at);
        break;
      case kOpChunk:
      case kOpBagHeader:
        r.fail_at_offset(rec.at, std::string("a ") + op_name(rec.op) + " record inside a chunk" + hint);
      default:
        break;  // nothing else belongs in a chunk; rosbag skips such records too
    }
  }
}

void Ros1Bag::add_connection(ByteReader& r, const Record& rec) {
  const std::uint32_t id = as<std::uint32_t>(need(r, rec, rec.fields, "conn", 4));
  const std::string_view topic = need(r, rec, rec.fields, "topic", 0);
  // The data is the publisher's connection header, in the same field format as a record header.
  const std::size_t end = r.pos();
  r.seek(rec.data_at);
  parse_fields(r, end, conn_fields_, "");
  const std::string_view type = need(r, rec, conn_fields_, "type", 0);
  const Field* def = find(conn_fields_, "message_definition");

  const auto known = connections_.find(id);
  if (known != connections_.end()) {
    if (known->second.topic != topic || known->second.type != type)
      r.fail_at_offset(rec.at, "connection " + num(id) + " is described again as \"" + printable(topic, 80) + "\" (" +
                                   printable(type, 80) + "), but was \"" + printable(known->second.topic, 80) + "\" (" +
                                   printable(known->second.type, 80) + ") before: the bag is damaged");
    return;
  }
  Connection conn{std::string(topic), std::string(type), 0};
  const auto key = std::make_pair(conn.topic, conn.type);
  const auto it = topic_of_.find(key);
  if (it != topic_of_.end()) {
    conn.topic_index = it->second;  // another publisher of a topic already listed
  } else {
    conn.topic_index = static_cast<std::uint32_t>(topics_.size());
    Topic t;
    t.name = conn.topic;
    t.type = conn.type;
    t.encoding = Encoding::Ros1;
    if (def) t.definition = std::string(def->value);
    topics_.push_back(std::move(t));
    topic_of_.emplace(key, conn.topic_index);
  }
  connections_.emplace(id, std::move(conn));
}

void Ros1Bag::add_message(const ByteReader& r, const Record& rec, std::uint64_t where, std::uint64_t offset) {
  MessageRef m;
  const std::uint32_t conn = as<std::uint32_t>(need(r, rec, rec.fields, "conn", 4));
  const std::string_view time = need(r, rec, rec.fields, "time", 8);
  const std::uint32_t sec = as<std::uint32_t>(time.substr(0, 4));
  const std::uint32_t nsec = as<std::uint32_t>(time.substr(4, 4));
  m.time_ns = static_cast<std::int64_t>(sec) * 1000000000 + nsec;  // at most 4.3e18: no overflow
  m.where = where;
  m.offset = offset;
  m.size = rec.data.size();
  const auto it = connections_.find(conn);
  if (it != connections_.end()) {
    m.topic = it->second.topic_index;
    ++topics_[m.topic].count;
  } else {
    m.topic = conn;  // resolved at the end of scan()
    unresolved_.push_back(messages_.size());
  }
  messages_.push_back(m);
}

std::string_view Ros1Bag::chunk_bytes(std::size_t index) {
  const Chunk& c = chunks_[index];
  const std::string_view stored = src_->bytes().substr(static_cast<std::size_t>(c.data_at), c.stored);
  if (c.codec == Codec::None) return stored;
  if (cached_ == index) return cache_;
  cached_ = static_cast<std::size_t>(-1);  // the cache is overwritten below, and may be left half-done
  if (c.codec == Codec::Bz2)
    inflate_bz2(c, stored);
  else
    inflate_lz4(c, stored);
  cached_ = index;
  return cache_;
}

// bzip2 can shrink data a millionfold, so the declared size alone does not justify allocating it:
// the buffer grows as the stream actually produces bytes, one byte past the declared size at most
// (so that "more than declared" shows without a second call).
void Ros1Bag::inflate_bz2(const Chunk& c, std::string_view in) {
  const std::size_t limit = static_cast<std::size_t>(c.size) + 1;
  cache_.resize(std::min<std::size_t>(limit, std::max<std::size_t>(std::size_t{4} * in.size(), 1 << 20)));
  bz_stream s{};
  if (BZ2_bzDecompressInit(&s, 0, 0) != BZ_OK) fail_chunk(c, "could not be decompressed (out of memory)");
  struct End {
    bz_stream* s;
    ~End() { BZ2_bzDecompressEnd(s); }
  } end{&s};
  s.next_in = const_cast<char*>(in.data());
  s.avail_in = static_cast<unsigned>(in.size());
  std::size_t produced = 0;
  for (;;) {
    s.next_out = cache_.data() + produced;
    s.avail_out = static_cast<unsigned>(cache_.size() - produced);
    const int rc = BZ2_bzDecompress(&s);
    produced = cache_.size() - s.avail_out;
    if (rc == BZ_STREAM_END) {
      if (s.avail_in == 0) break;
      // bzip2 allows streams one after another; the next one starts afresh.
      char* next = s.next_in;
      const unsigned left = s.avail_in;
      BZ2_bzDecompressEnd(&s);
      s = bz_stream{};
      if (BZ2_bzDecompressInit(&s, 0, 0) != BZ_OK) fail_chunk(c, "could not be decompressed (out of memory)");
      s.next_in = next;
      s.avail_in = left;
      continue;
    }
    if (rc == BZ_DATA_ERROR_MAGIC) fail_chunk(c, "does not hold bz2 data (no \"BZh\" signature)");
    if (rc == BZ_DATA_ERROR) fail_chunk(c, "has damaged bz2 data (a checksum or code does not match)");
    if (rc != BZ_OK) fail_chunk(c, "could not be decompressed (bzip2 error " + std::to_string(rc) + ")");
    // BZ_OK: bzip2 stopped because the input or the output ran out.
    if (s.avail_out > 0) fail_chunk(c, "ends before its bz2 stream does (cut short)");
    if (cache_.size() == limit) fail_chunk(c, "decompresses to more than the " + num(c.size) + " bytes its header declares");
    cache_.resize(std::min(limit, 2 * cache_.size()));
  }
  if (produced != c.size) fail_chunk(c, "decompresses to " + num(produced) + " bytes, its header declares " + num(c.size));
  cache_.resize(produced);
}

// LZ4 cannot shrink data more than about 255:1 (checked when the chunk was listed), so the declared
// size is allocated at once; the output must not move while a frame is decoded (linked blocks refer
// back into it).
void Ros1Bag::inflate_lz4(const Chunk& c, std::string_view in) {
  cache_.resize(c.size);
  LZ4F_dctx* raw = nullptr;
  if (LZ4F_isError(LZ4F_createDecompressionContext(&raw, LZ4F_VERSION)))
    fail_chunk(c, "could not be decompressed (out of memory)");
  const std::unique_ptr<LZ4F_dctx, LZ4F_errorCode_t (*)(LZ4F_dctx*)> ctx(raw, &LZ4F_freeDecompressionContext);
  std::size_t produced = 0, consumed = 0;
  bool frame_done = false;
  // roslz4 writes one frame a chunk; frames one after another are read in turn, as lz4 does.
  while (consumed < in.size()) {
    std::size_t out_n = cache_.size() - produced, in_n = in.size() - consumed;
    const std::size_t hint = LZ4F_decompress(ctx.get(), cache_.data() + produced, &out_n, in.data() + consumed, &in_n, nullptr);
    if (LZ4F_isError(hint)) fail_chunk(c, std::string("has damaged lz4 data (") + LZ4F_getErrorName(hint) + ")");
    produced += out_n;
    consumed += in_n;
    frame_done = hint == 0;
    if (!frame_done && out_n == 0 && in_n == 0)
      fail_chunk(c, "decompresses to more than the " + num(c.size) + " bytes its header declares");
  }
  if (!frame_done) fail_chunk(c, "ends before its lz4 frame does (cut short)");
  if (produced != c.size) fail_chunk(c, "decompresses to " + num(produced) + " bytes, its header declares " + num(c.size));
}

}  // namespace

std::unique_ptr<Reader> open_ros1(std::shared_ptr<const Source> src) { return std::make_unique<Ros1Bag>(std::move(src)); }

}  // namespace pl::bag
