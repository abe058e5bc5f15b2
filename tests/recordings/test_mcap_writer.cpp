// The MCAP writer (pl/recordings/mcap_writer.hpp): what it writes, read back by this project's MCAP reader
// (pl::bag::open_mcap), and its summary, indexes and CRCs walked here by hand from the spec's record
// layouts. tests/client/run_log/check_run_log.mjs reads its files with an independent reader
// (@mcap/core).
#include <gtest/gtest.h>
#include <zlib.h>
#include <zstd.h>

#include <cstdint>
#include <cstring>
#include <map>
#include <string>
#include <vector>

#include "error_of.hpp"
#include "pl/common/error.hpp"
#include "pl/recordings/bag.hpp"
#include "pl/recordings/mcap_writer.hpp"
#include "test_util.hpp"

namespace {

using pl::McapWriter;
using pl::McapWriterOptions;
using pl::test::error_of;

template <typename T>
T le_at(const std::string& b, std::size_t at) {
  T v{};
  if (at + sizeof(T) > b.size()) throw std::runtime_error("read past the end at " + std::to_string(at));
  std::memcpy(&v, b.data() + at, sizeof(T));
  return v;
}

std::uint32_t crc_of(std::string_view s) {
  return static_cast<std::uint32_t>(crc32_z(0L, reinterpret_cast<const Bytef*>(s.data()), s.size()));
}

struct Written {
  std::uint16_t channel;
  std::uint64_t time;
  std::string data;
};

// Three channels on two schemas, `n` messages each round, some of them large enough to fill several
// chunks of `chunk_bytes`.
std::vector<Written> write_file(const std::string& path, McapWriterOptions::Compression compression, std::size_t chunk_bytes,
                                int rounds) {
  McapWriterOptions o;
  o.compression = compression;
  o.chunk_bytes = chunk_bytes;
  McapWriter w(path, o);
  const auto pose = w.add_schema("foxglove.PoseInFrame", "jsonschema", R"({"type":"object"})");
  const auto cloud = w.add_schema("foxglove.PointCloud", "jsonschema", R"({"type":"object","title":"cloud"})");
  const std::uint16_t a = w.add_channel(pose, "/pose", "json");
  const std::uint16_t b = w.add_channel(cloud, "/scan", "json", {{"frame", "map"}, {"note", "thinned"}});
  const std::uint16_t c = w.add_channel(0, "/raw", "json");
  std::vector<Written> out;
  const std::uint64_t t0 = 1'700'000'000'000'000'000ull;
  for (int k = 0; k < rounds; ++k) {
    const std::uint64_t t = t0 + static_cast<std::uint64_t>(k) * 100'000'000ull;
    for (int j = 0; j < 10; ++j) {
      const std::string d = "{\"k\":" + std::to_string(k) + ",\"j\":" + std::to_string(j) + "}";
      out.push_back({a, t + static_cast<std::uint64_t>(j) * 10'000'000ull, d});
    }
    std::string big(3000 + 17 * static_cast<std::size_t>(k), 'x');
    for (std::size_t i = 0; i < big.size(); ++i) big[i] = static_cast<char>('a' + (i * 7 + static_cast<std::size_t>(k)) % 26);
    out.push_back({b, t + 5'000'000ull, big});
    out.push_back({c, t + 1ull, std::string(1, static_cast<char>('0' + k % 10))});
  }
  std::uint32_t seq = 0;
  for (const Written& m : out) w.write(m.channel, seq++, m.time, m.time, m.data);
  w.close();
  EXPECT_EQ(w.messages(), out.size());
  return out;
}

// The file's records walked from the footer: summary CRC, Data End CRC, summary offsets, chunk
// indexes against the chunks and their message indexes. Returns the number of chunks.
std::size_t check_structure(const std::string& b, std::size_t messages, const std::string& compression, bool schemas = true) {
  const std::string magic("\x89MCAP0\r\n", 8);
  EXPECT_EQ(b.substr(0, 8), magic);
  EXPECT_EQ(b.substr(b.size() - 8), magic);
  const std::size_t footer = b.size() - 8 - 29;
  EXPECT_EQ(static_cast<std::uint8_t>(b[footer]), 0x02);
  EXPECT_EQ(le_at<std::uint64_t>(b, footer + 1), 20u);
  const auto summary_start = le_at<std::uint64_t>(b, footer + 9);
  const auto offsets_start = le_at<std::uint64_t>(b, footer + 17);
  const auto summary_crc = le_at<std::uint32_t>(b, footer + 25);
  EXPECT_GT(summary_start, 0u);
  EXPECT_GT(offsets_start, summary_start);
  EXPECT_EQ(summary_crc, crc_of(std::string_view(b).substr(summary_start, footer + 25 - summary_start)));
  // Data End, the last record before the summary, with the CRC of everything before it.
  const std::size_t data_end = summary_start - 13;
  EXPECT_EQ(static_cast<std::uint8_t>(b[data_end]), 0x0f);
  EXPECT_EQ(le_at<std::uint32_t>(b, data_end + 9), crc_of(std::string_view(b).substr(0, data_end)));
  // Summary offsets: every group's records have its opcode and fill the summary exactly.
  std::map<std::uint8_t, std::pair<std::uint64_t, std::uint64_t>> groups;
  std::uint64_t covered = 0;
  for (std::size_t at = offsets_start; at < footer;) {
    EXPECT_EQ(static_cast<std::uint8_t>(b[at]), 0x0e);
    const auto len = le_at<std::uint64_t>(b, at + 1);
    const auto op = static_cast<std::uint8_t>(b[at + 9]);
    groups[op] = {le_at<std::uint64_t>(b, at + 10), le_at<std::uint64_t>(b, at + 18)};
    covered += groups[op].second;
    for (std::uint64_t r = groups[op].first; r < groups[op].first + groups[op].second;
         r += 9 + le_at<std::uint64_t>(b, static_cast<std::size_t>(r) + 1))
      EXPECT_EQ(static_cast<std::uint8_t>(b[r]), op) << "group " << int(op) << " at " << r;
    at += 9 + len;
  }
  EXPECT_EQ(covered, offsets_start - summary_start);
  EXPECT_EQ(groups.count(0x03), schemas ? 1u : 0u);
  EXPECT_TRUE(groups.count(0x04) && groups.count(0x08) && groups.count(0x0b));
  // Statistics: the message count.
  EXPECT_EQ(le_at<std::uint64_t>(b, static_cast<std::size_t>(groups[0x0b].first) + 9), messages);
  // Chunk indexes.
  std::size_t chunks = 0, indexed = 0;
  for (std::uint64_t r = groups[0x08].first; r < groups[0x08].first + groups[0x08].second; ++chunks) {
    std::size_t p = static_cast<std::size_t>(r) + 9;
    const auto start = le_at<std::uint64_t>(b, p), end = le_at<std::uint64_t>(b, p + 8);
    const auto chunk_at = le_at<std::uint64_t>(b, p + 16), chunk_len = le_at<std::uint64_t>(b, p + 24);
    const auto map_len = le_at<std::uint32_t>(b, p + 32);
    std::map<std::uint16_t, std::uint64_t> index_at;
    for (std::size_t q = p + 36; q < p + 36 + map_len; q += 10) index_at[le_at<std::uint16_t>(b, q)] = le_at<std::uint64_t>(b, q + 2);
    p += 36 + map_len;
    const auto index_len = le_at<std::uint64_t>(b, p);
    const auto comp_len = le_at<std::uint32_t>(b, p + 8);
    EXPECT_EQ(b.substr(p + 12, comp_len), compression);
    p += 12 + comp_len;
    const auto compressed = le_at<std::uint64_t>(b, p), uncompressed = le_at<std::uint64_t>(b, p + 8);
    // The chunk it points at: same times and sizes, the CRC of the decompressed records.
    const std::size_t c = static_cast<std::size_t>(chunk_at);
    EXPECT_EQ(static_cast<std::uint8_t>(b[c]), 0x06);
    EXPECT_EQ(9 + le_at<std::uint64_t>(b, c + 1), chunk_len);
    EXPECT_EQ(le_at<std::uint64_t>(b, c + 9), start);
    EXPECT_EQ(le_at<std::uint64_t>(b, c + 17), end);
    EXPECT_LE(start, end);
    EXPECT_EQ(le_at<std::uint64_t>(b, c + 25), uncompressed);
    const auto crc = le_at<std::uint32_t>(b, c + 33);
    const auto name_len = le_at<std::uint32_t>(b, c + 37);
    const std::size_t records_at = c + 41 + name_len + 8;
    EXPECT_EQ(le_at<std::uint64_t>(b, c + 41 + name_len), compressed);
    std::string records = b.substr(records_at, static_cast<std::size_t>(compressed));
    if (compression == "zstd") {
      std::string raw(static_cast<std::size_t>(uncompressed), '\0');
      EXPECT_EQ(ZSTD_decompress(raw.data(), raw.size(), records.data(), records.size()), raw.size());
      records = raw;
    }
    EXPECT_EQ(records.size(), uncompressed);
    EXPECT_EQ(crc, crc_of(records));
    // Message indexes right after the chunk, each entry pointing at a Message record of its channel
    // with its log time.
    EXPECT_EQ(index_at.begin()->second, chunk_at + chunk_len);
    std::uint64_t index_bytes = 0;
    for (const auto& [channel, at] : index_at) {
      const std::size_t m = static_cast<std::size_t>(at);
      EXPECT_EQ(static_cast<std::uint8_t>(b[m]), 0x07);
      EXPECT_EQ(le_at<std::uint16_t>(b, m + 9), channel);
      const auto n = le_at<std::uint32_t>(b, m + 11);
      for (std::size_t e = m + 15; e < m + 15 + n; e += 16, ++indexed) {
        const auto time = le_at<std::uint64_t>(b, e);
        const auto off = static_cast<std::size_t>(le_at<std::uint64_t>(b, e + 8));
        EXPECT_EQ(static_cast<std::uint8_t>(records[off]), 0x05);
        EXPECT_EQ(le_at<std::uint16_t>(records, off + 9), channel);
        EXPECT_EQ(le_at<std::uint64_t>(records, off + 15), time);
        EXPECT_GE(time, start);
        EXPECT_LE(time, end);
      }
      index_bytes += 9 + le_at<std::uint64_t>(b, m + 1);
    }
    EXPECT_EQ(index_bytes, index_len);
    r += 9 + le_at<std::uint64_t>(b, static_cast<std::size_t>(r) + 1);
  }
  EXPECT_EQ(indexed, messages);
  return chunks;
}

class McapWriterRoundTrip : public ::testing::TestWithParam<McapWriterOptions::Compression> {};

TEST_P(McapWriterRoundTrip, OurReaderReadsEveryMessageAndTheIndexesPointAtThem) {
  const pl::test::TempDir dir;
  const std::string path = dir / "log.mcap";
  const auto written = write_file(path, GetParam(), 16 * 1024, 40);
  const bool zstd = GetParam() == McapWriterOptions::Compression::Zstd;
  const std::string bytes = pl::test::read_file(path);
  const std::size_t chunks = check_structure(bytes, written.size(), zstd ? "zstd" : "");
  EXPECT_GE(chunks, 4u);

  auto r = pl::bag::open_mcap(pl::bag::map_file(path));
  ASSERT_EQ(r->topics().size(), 3u);
  std::map<std::string, const pl::bag::Topic*> topics;
  for (const auto& t : r->topics()) topics[t.name] = &t;
  ASSERT_TRUE(topics.count("/pose") && topics.count("/scan") && topics.count("/raw"));
  EXPECT_EQ(topics["/pose"]->type, "json:foxglove.PoseInFrame");
  EXPECT_EQ(topics["/pose"]->definition, R"({"type":"object"})");
  EXPECT_EQ(topics["/scan"]->type, "json:foxglove.PointCloud");
  EXPECT_EQ(topics["/raw"]->type, "json:");
  EXPECT_EQ(topics["/pose"]->count, 400u);
  EXPECT_EQ(topics["/scan"]->count, 40u);
  EXPECT_EQ(topics["/raw"]->count, 40u);
  // The reader gives messages by time (ties in file order); the writer's, sorted the same way.
  std::vector<Written> expected = written;
  std::stable_sort(expected.begin(), expected.end(), [](const Written& a, const Written& b) { return a.time < b.time; });
  ASSERT_EQ(r->messages().size(), expected.size());
  const std::map<std::uint16_t, std::string> names{{1, "/pose"}, {2, "/scan"}, {3, "/raw"}};
  for (std::size_t i = 0; i < expected.size(); ++i) {
    const auto& m = r->messages()[i];
    EXPECT_EQ(static_cast<std::uint64_t>(m.time_ns), expected[i].time) << i;
    EXPECT_EQ(r->topics()[m.topic].name, names.at(expected[i].channel)) << i;
    EXPECT_EQ(r->read(m), expected[i].data) << i;
  }
}

INSTANTIATE_TEST_SUITE_P(Compression, McapWriterRoundTrip,
                         ::testing::Values(McapWriterOptions::Compression::None, McapWriterOptions::Compression::Zstd),
                         [](const auto& info) { return info.param == McapWriterOptions::Compression::Zstd ? "Zstd" : "None"; });

TEST(McapWriter, ChunkTimesAreTheMinimumAndMaximumWhateverTheOrder) {
  const pl::test::TempDir dir;
  const std::string path = dir / "log.mcap";
  {
    McapWriter w(path);
    const auto c = w.add_channel(0, "/a", "json");
    const auto d = w.add_channel(0, "/b", "json");
    w.write(c, 0, 500, 500, "{}");
    w.write(d, 0, 100, 100, "{}");  // another channel, earlier
    w.write(c, 1, 900, 900, "{}");
    w.write(d, 1, 300, 300, "{}");
    w.close();
    w.close();  // a second close does nothing
  }
  const std::string b = pl::test::read_file(path);
  check_structure(b, 4, "zstd", false);
  // The one chunk, right after the two Channel records.
  std::size_t at = 8;
  at += 9 + le_at<std::uint64_t>(b, at + 1);  // Header
  at += 9 + le_at<std::uint64_t>(b, at + 1);  // Channel /a
  at += 9 + le_at<std::uint64_t>(b, at + 1);  // Channel /b
  ASSERT_EQ(static_cast<std::uint8_t>(b[at]), 0x06);
  EXPECT_EQ(le_at<std::uint64_t>(b, at + 9), 100u);
  EXPECT_EQ(le_at<std::uint64_t>(b, at + 17), 900u);
  auto r = pl::bag::open_mcap(pl::bag::hold_bytes(b, "log.mcap"));
  ASSERT_EQ(r->messages().size(), 4u);
  EXPECT_EQ(r->messages().front().time_ns, 100);
  EXPECT_EQ(r->messages().back().time_ns, 900);
}

TEST(McapWriter, AFileWithNoMessagesIsValid) {
  const pl::test::TempDir dir;
  const std::string path = dir / "empty.mcap";
  {
    McapWriter w(path);
    w.add_channel(w.add_schema("s", "jsonschema", "{}"), "/a", "json");
  }  // closed by the destructor
  auto r = pl::bag::open_mcap(pl::bag::map_file(path));
  EXPECT_TRUE(r->messages().empty());
  ASSERT_EQ(r->topics().size(), 1u);
  EXPECT_EQ(r->topics()[0].count, 0u);
}

TEST(McapWriter, ErrorsNameThePathAndTheProblem) {
  const pl::test::TempDir dir;
  const std::string missing = dir / "no-such-folder/log.mcap";
  EXPECT_NE(error_of([&] { McapWriter w(missing); }).find(missing + ": cannot create the MCAP file"), std::string::npos);
  McapWriter w(dir / "log.mcap");
  EXPECT_NE(error_of([&] { w.write(3, 0, 0, 0, "{}"); }).find("channel 3, which was never added"), std::string::npos);
  EXPECT_NE(error_of([&] { w.add_channel(2, "/x", "json"); }).find("schema 2, which was never added"), std::string::npos);
  w.close();
  EXPECT_NE(error_of([&] { w.add_channel(0, "/x", "json"); }).find("after close()"), std::string::npos);
}

TEST(McapWriter, ADiskThatIsFullIsReported) {
  if (!std::filesystem::exists("/dev/full")) GTEST_SKIP() << "no /dev/full here";
  McapWriterOptions o;
  o.compression = McapWriterOptions::Compression::None;
  o.chunk_bytes = 1024;
  McapWriter w("/dev/full", o);
  const auto c = w.add_channel(0, "/a", "json");
  const std::string e = error_of([&] {
    for (std::uint32_t i = 0; i < 10000; ++i) w.write(c, i, i, i, std::string(512, 'x'));
    w.close();
  });
  EXPECT_NE(e.find("/dev/full: cannot write"), std::string::npos) << e;
  EXPECT_NE(e.find("the disk is full"), std::string::npos) << e;
  // Closed after the error: later calls say so.
  EXPECT_NE(error_of([&] { w.write(c, 0, 0, 0, "{}"); }).find("after close() (or after an error"), std::string::npos);
}

}  // namespace
