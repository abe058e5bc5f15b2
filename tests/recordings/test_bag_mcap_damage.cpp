// The MCAP reader (recordings/src/bag_mcap.cpp) on damaged files: cut short at every byte, bad CRCs,
// bad lengths, unknown compressions, channels defined again differently.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <fstream>
#include <string>
#include <utility>
#include <vector>

#include "error_of.hpp"
#include "mcap_test_writer.hpp"
#include "pl/common/error.hpp"
#include "pl/recordings/bag.hpp"
#include "test_util.hpp"

namespace {

using namespace pl::test::mcap;
using pl::bag::Encoding;
using pl::bag::MessageRef;
using pl::test::error_of;

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
