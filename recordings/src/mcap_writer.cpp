#include "pl/recordings/mcap_writer.hpp"

#include <zlib.h>
#include <zstd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <limits>

#include "mcap_format.hpp"
#include "pl/common/error.hpp"

#ifndef PL_VERSION
#error "PL_VERSION (the CMake project version) must be defined"
#endif

namespace pl {
namespace {

using namespace mcap_format;  // the magic and the opcodes

// Little-endian fields (the host is little-endian: x86-64, arm64; the reader assumes it too).
template <typename T>
void put_le(std::string& out, T v) {
  char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  out.append(b, sizeof(T));
}
void put_string(std::string& out, std::string_view s) {
  put_le(out, static_cast<std::uint32_t>(s.size()));
  out.append(s.data(), s.size());
}
// <opcode><u64 length><body>
void put_record(std::string& out, std::uint8_t op, std::string_view body) {
  out.push_back(static_cast<char>(op));
  put_le(out, static_cast<std::uint64_t>(body.size()));
  out.append(body.data(), body.size());
}
std::string record(std::uint8_t op, std::string_view body) {
  std::string out;
  put_record(out, op, body);
  return out;
}

std::uint32_t crc32_of(std::uint32_t crc, std::string_view bytes) {
  return static_cast<std::uint32_t>(crc32_z(crc, reinterpret_cast<const Bytef*>(bytes.data()), bytes.size()));
}

std::string write_problem(int err) {
  if (err == ENOSPC) return "the disk is full (free some space, or write the log elsewhere)";
  if (err == EDQUOT) return "the disk quota is used up (free some space, or write the log elsewhere)";
  return std::string(std::strerror(err)) + " (check the disk and the path)";
}

}  // namespace

McapWriter::McapWriter(const std::string& path, const McapWriterOptions& options)
    : path_(path), options_(options), file_(std::fopen(path.c_str(), "wb"), &std::fclose) {
  if (!file_) throw Error(path_ + ": cannot create the MCAP file: " + std::strerror(errno) + " (is the folder there and writable?)");
  if (options_.chunk_bytes == 0) options_.chunk_bytes = 1;
  put(kMagic);
  std::string header;
  put_string(header, "");  // profile: none of the well-known ones (JSON messages with JSON Schemas)
  put_string(header, options_.library.empty() ? std::string("PointLocalization " PL_VERSION) : options_.library);
  put(record(kHeader, header));
}

McapWriter::~McapWriter() {
  try {
    close();
  } catch (...) {  // a destructor cannot report it: close() does
  }
}

void McapWriter::fail(const std::string& problem) {
  closed_ = true;
  file_.reset();
  throw Error(path_ + ": " + problem);
}

void McapWriter::put(std::string_view bytes) {
  if (bytes.empty()) return;
  errno = 0;
  if (std::fwrite(bytes.data(), 1, bytes.size(), file_.get()) != bytes.size())
    fail("cannot write the MCAP file after " + std::to_string(offset_) + " bytes: " + write_problem(errno ? errno : EIO));
  data_crc_ = crc32_of(data_crc_, bytes);
  offset_ += bytes.size();
}

std::uint16_t McapWriter::add_schema(const std::string& name, const std::string& encoding, std::string_view data) {
  if (closed_) throw Error(path_ + ": add_schema after close()");
  if (schema_records_.size() >= std::numeric_limits<std::uint16_t>::max())
    throw Error(path_ + ": more than 65,535 schemas (MCAP's ids are 16-bit)");
  if (data.size() > std::numeric_limits<std::uint32_t>::max()) throw Error(path_ + ": schema " + name + " is over 4 GiB");
  const auto id = static_cast<std::uint16_t>(schema_records_.size() + 1);
  std::string body;
  put_le(body, id);
  put_string(body, name);
  put_string(body, encoding);
  put_string(body, data);
  schema_records_.push_back(record(kSchema, body));
  put(schema_records_.back());
  return id;
}

std::uint16_t McapWriter::add_channel(std::uint16_t schema_id, const std::string& topic, const std::string& message_encoding,
                                      const std::map<std::string, std::string>& metadata) {
  if (closed_) throw Error(path_ + ": add_channel after close()");
  if (schema_id > schema_records_.size())
    throw Error(path_ + ": channel " + topic + " names schema " + std::to_string(schema_id) + ", which was never added (add_schema)");
  if (channel_records_.size() >= std::numeric_limits<std::uint16_t>::max())
    throw Error(path_ + ": more than 65,535 channels (MCAP's ids are 16-bit)");
  const auto id = static_cast<std::uint16_t>(channel_records_.size() + 1);
  std::string map;
  for (const auto& [k, v] : metadata) {
    put_string(map, k);
    put_string(map, v);
  }
  std::string body;
  put_le(body, id);
  put_le(body, schema_id);
  put_string(body, topic);
  put_string(body, message_encoding);
  put_string(body, map);
  channel_records_.push_back(record(kChannel, body));
  put(channel_records_.back());
  if (channel_known_.size() <= id) channel_known_.resize(id + 1u, 0);
  channel_known_[id] = 1;
  return id;
}

void McapWriter::write(std::uint16_t channel_id, std::uint32_t sequence, std::uint64_t log_time_ns, std::uint64_t publish_time_ns,
                       std::string_view data) {
  if (closed_) throw Error(path_ + ": write after close() (or after an error writing the file)");
  if (channel_id >= channel_known_.size() || !channel_known_[channel_id])
    throw Error(path_ + ": a message on channel " + std::to_string(channel_id) + ", which was never added (add_channel)");
  if (chunk_.empty()) {
    chunk_start_ = chunk_end_ = log_time_ns;
  } else {
    chunk_start_ = std::min(chunk_start_, log_time_ns);
    chunk_end_ = std::max(chunk_end_, log_time_ns);
  }
  chunk_index_[channel_id].emplace_back(log_time_ns, chunk_.size());
  chunk_.push_back(static_cast<char>(kMessage));
  put_le(chunk_, static_cast<std::uint64_t>(2 + 4 + 8 + 8 + data.size()));
  put_le(chunk_, channel_id);
  put_le(chunk_, sequence);
  put_le(chunk_, log_time_ns);
  put_le(chunk_, publish_time_ns);
  chunk_.append(data.data(), data.size());
  start_time_ = message_count_ == 0 ? log_time_ns : std::min(start_time_, log_time_ns);
  end_time_ = message_count_ == 0 ? log_time_ns : std::max(end_time_, log_time_ns);
  ++message_count_;
  ++channel_counts_[channel_id];
  if (chunk_.size() >= options_.chunk_bytes) flush_chunk();
}

void McapWriter::flush_chunk() {
  if (chunk_.empty()) return;
  const bool zstd = options_.compression == McapWriterOptions::Compression::Zstd;
  std::string_view records = chunk_;
  if (zstd) {
    compressed_.resize(ZSTD_compressBound(chunk_.size()));
    const std::size_t n = ZSTD_compress(compressed_.data(), compressed_.size(), chunk_.data(), chunk_.size(), options_.zstd_level);
    if (ZSTD_isError(n)) fail(std::string("zstd could not compress a chunk: ") + ZSTD_getErrorName(n));
    compressed_.resize(n);
    records = compressed_;
  }
  ChunkIndex ci;
  ci.start_time = chunk_start_;
  ci.end_time = chunk_end_;
  ci.offset = offset_;
  ci.compressed_size = records.size();
  ci.uncompressed_size = chunk_.size();
  std::string head;  // the Chunk record up to its records' bytes (they are written without a copy)
  put_le(head, ci.start_time);
  put_le(head, ci.end_time);
  put_le(head, ci.uncompressed_size);
  put_le(head, crc32_of(0, chunk_));
  put_string(head, zstd ? "zstd" : "");
  put_le(head, static_cast<std::uint64_t>(records.size()));
  const std::uint64_t body = head.size() + records.size();
  std::string prefix(1, static_cast<char>(kChunk));
  put_le(prefix, body);
  put(prefix);
  put(head);
  put(records);
  ci.length = prefix.size() + body;
  if (options_.message_indexes) {
    const std::uint64_t start = offset_;
    for (const auto& [channel, entries] : chunk_index_) {
      std::string b;
      put_le(b, channel);
      put_le(b, static_cast<std::uint32_t>(entries.size() * 16));
      for (const auto& [time, at] : entries) {
        put_le(b, time);
        put_le(b, at);
      }
      ci.index_offsets[channel] = offset_;
      put(record(kMessageIndex, b));
    }
    ci.index_length = offset_ - start;
  }
  chunk_indexes_.push_back(std::move(ci));
  chunk_.clear();
  chunk_index_.clear();
}

void McapWriter::close() {
  if (closed_) return;
  flush_chunk();
  std::string data_end;
  put_le(data_end, data_crc_);  // every byte from the magic up to here
  put(record(kDataEnd, data_end));

  // The summary: records grouped by opcode, each group then named by a Summary Offset record.
  const std::uint64_t summary_start = offset_;
  std::string summary, offsets;
  const auto group = [&](std::uint8_t op, const std::vector<std::string>& records) {
    if (records.empty()) return;
    const std::uint64_t start = summary_start + summary.size();
    for (const std::string& r : records) summary += r;
    std::string b;
    b.push_back(static_cast<char>(op));
    put_le(b, start);
    put_le(b, static_cast<std::uint64_t>(summary_start + summary.size() - start));
    put_record(offsets, kSummaryOffset, b);
  };
  group(kSchema, schema_records_);
  group(kChannel, channel_records_);
  std::vector<std::string> indexes;
  for (const ChunkIndex& ci : chunk_indexes_) {
    std::string b;
    put_le(b, ci.start_time);
    put_le(b, ci.end_time);
    put_le(b, ci.offset);
    put_le(b, ci.length);
    put_le(b, static_cast<std::uint32_t>(ci.index_offsets.size() * 10));
    for (const auto& [channel, at] : ci.index_offsets) {
      put_le(b, channel);
      put_le(b, at);
    }
    put_le(b, ci.index_length);
    put_string(b, options_.compression == McapWriterOptions::Compression::Zstd ? "zstd" : "");
    put_le(b, ci.compressed_size);
    put_le(b, ci.uncompressed_size);
    indexes.push_back(record(kChunkIndex, b));
  }
  group(kChunkIndex, indexes);
  std::string stats;
  put_le(stats, message_count_);
  put_le(stats, static_cast<std::uint16_t>(schema_records_.size()));
  put_le(stats, static_cast<std::uint32_t>(channel_records_.size()));
  put_le(stats, std::uint32_t{0});  // attachments
  put_le(stats, std::uint32_t{0});  // metadata
  put_le(stats, static_cast<std::uint32_t>(chunk_indexes_.size()));
  put_le(stats, start_time_);
  put_le(stats, end_time_);
  put_le(stats, static_cast<std::uint32_t>(channel_counts_.size() * 10));
  for (const auto& [channel, n] : channel_counts_) {
    put_le(stats, channel);
    put_le(stats, n);
  }
  group(kStatistics, {record(kStatistics, stats)});

  const std::uint64_t offsets_start = summary_start + summary.size();
  std::string footer(1, static_cast<char>(kFooter));
  put_le(footer, std::uint64_t{8 + 8 + 4});
  put_le(footer, summary_start);
  put_le(footer, offsets_start);
  // The CRC of the summary, the summary offsets and the footer up to the CRC itself.
  const std::uint32_t crc = crc32_of(crc32_of(crc32_of(0, summary), offsets), footer);
  put_le(footer, crc);
  put(summary);
  put(offsets);
  put(footer);
  put(kMagic);

  errno = 0;
  if (std::fflush(file_.get()) != 0) fail("cannot write the end of the MCAP file: " + write_problem(errno ? errno : EIO));
  std::FILE* f = file_.release();
  closed_ = true;
  if (std::fclose(f) != 0) throw Error(path_ + ": cannot close the MCAP file: " + write_problem(errno ? errno : EIO));
}

}  // namespace pl
