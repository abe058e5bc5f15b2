// A small MCAP writer (https://mcap.dev/spec), for logs that other tools open: Foxglove, the `mcap`
// command, the readers in other languages. pl::bag::open_mcap reads what it writes.
//
//   McapWriter w("run.mcap");
//   const auto s = w.add_schema("foxglove.PoseInFrame", "jsonschema", schema_text);
//   const auto c = w.add_channel(s, "/pose", "json");
//   w.write(c, seq, log_time_ns, log_time_ns, json_text);
//   w.close();  // the summary and the footer: a file without them is unfinished
//
// The file it makes (what the spec calls an indexed, chunked file):
//   magic, Header (profile "", library "PointLocalization X.Y.Z"),
//   the data section: each Schema and Channel record when it is added (outside chunks, so that every
//     chunk can be read on its own with the summary's copies), Message records grouped in Chunk
//     records of about `chunk_bytes` (zstd or uncompressed; uncompressed size and CRC-32 set), each
//     chunk followed by its Message Index records (one per channel in it, sorted by channel id),
//     Data End (with the CRC-32 of every byte before it),
//   the summary section: copies of the Schema and Channel records, a Chunk Index per chunk and one
//     Statistics record, grouped by opcode, then a Summary Offset record per group,
//   Footer (summary_start, summary_offset_start, the CRC-32 of the summary up to the footer's CRC),
//   magic.
//
// Decisions:
// - Messages may come in any log-time order (a chunk's message_start/end_time are its min and max,
//   the statistics' the file's); readers that stream the file see them in the order written.
// - Writing goes through a buffered stdio file. An error (disk full, a closed pipe) is a pl::Error
//   naming the path and the problem when it shows: at a write, at close(). After an error the writer
//   is closed: later calls throw too.
// - The destructor closes the file when close() was not called, but cannot report an error then;
//   call close() to know that the file is complete.
// - One thread at a time (the caller serializes).
#pragma once

#include <cstdint>
#include <cstdio>
#include <map>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

namespace pl {

struct McapWriterOptions {
  enum class Compression { None, Zstd };
  Compression compression = Compression::Zstd;
  int zstd_level = 3;                       // zstd's default: fast, and JSON shrinks 5-10 times
  std::size_t chunk_bytes = 1024 * 1024;    // a chunk is closed once its records reach this (1 MiB)
  bool message_indexes = true;              // Message Index records after each chunk
  std::string library;                      // the Header's library (default "PointLocalization X.Y.Z")
};

class McapWriter {
 public:
  // Creates (or truncates) the file and writes the magic and the Header. Throws pl::Error naming the
  // path when it cannot be created.
  explicit McapWriter(const std::string& path, const McapWriterOptions& options = {});
  ~McapWriter();  // closes the file if close() was not called (errors then go unreported)
  McapWriter(const McapWriter&) = delete;
  McapWriter& operator=(const McapWriter&) = delete;

  // A schema: its name ("foxglove.PoseInFrame"), encoding ("jsonschema", "ros2msg", ...) and text.
  // Returns its id (1, 2, ...).
  std::uint16_t add_schema(const std::string& name, const std::string& encoding, std::string_view data);
  // A channel of messages on `topic` (schema_id 0: no schema). Returns its id (1, 2, ...).
  std::uint16_t add_channel(std::uint16_t schema_id, const std::string& topic, const std::string& message_encoding,
                            const std::map<std::string, std::string>& metadata = {});
  // One message; times in nanoseconds (the same epoch for the whole file). Throws pl::Error for a
  // channel never added, and for a write that fails.
  void write(std::uint16_t channel_id, std::uint32_t sequence, std::uint64_t log_time_ns, std::uint64_t publish_time_ns,
             std::string_view data);
  // Ends the last chunk, writes the summary and the footer, closes the file. Throws pl::Error naming
  // the path when anything could not be written (disk full: the file is incomplete). A second call
  // does nothing.
  void close();

  const std::string& path() const { return path_; }
  std::uint64_t messages() const { return message_count_; }
  std::uint64_t bytes_written() const { return offset_; }  // so far (the file's size after close())

 private:
  struct ChunkIndex {
    std::uint64_t start_time = 0, end_time = 0, offset = 0, length = 0;
    std::map<std::uint16_t, std::uint64_t> index_offsets;  // channel -> Message Index record offset
    std::uint64_t index_length = 0, compressed_size = 0, uncompressed_size = 0;
  };

  std::string path_;
  McapWriterOptions options_;
  std::unique_ptr<std::FILE, int (*)(std::FILE*)> file_;
  bool closed_ = false;
  std::uint64_t offset_ = 0;   // bytes written to the file so far
  std::uint32_t data_crc_ = 0; // CRC-32 of those bytes (for the Data End record)
  // Records kept for the summary.
  std::vector<std::string> schema_records_, channel_records_;
  std::vector<ChunkIndex> chunk_indexes_;
  // The open chunk: its records, their times, and per channel (log time, offset in the records).
  std::string chunk_;
  std::uint64_t chunk_start_ = 0, chunk_end_ = 0;
  std::map<std::uint16_t, std::vector<std::pair<std::uint64_t, std::uint64_t>>> chunk_index_;
  // Statistics.
  std::uint64_t message_count_ = 0, start_time_ = 0, end_time_ = 0;
  std::map<std::uint16_t, std::uint64_t> channel_counts_;
  std::vector<char> channel_known_;  // by channel id
  std::string compressed_;           // reused between chunks

  void put(std::string_view bytes);  // to the file, counted and CRC'd
  void flush_chunk();
  [[noreturn]] void fail(const std::string& problem);
};

}  // namespace pl
