// Tests of the ROS 1 bag reader (recordings/src/bag_ros1.cpp): bags written by Debian's python3-rosbag
// (tests/recordings/make_ros1_bag.py, uncompressed, bz2 and lz4, many small chunks) must come back
// topic for topic and byte for byte; a recording cut before its index still reads; damaged and
// truncated bags are refused with a pl::Error naming the file, the offset and the problem.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <regex>
#include <set>
#include <string>
#include <vector>

#include "error_of.hpp"
#include "pl/common/error.hpp"
#include "pl/recordings/bag.hpp"
#include "test_util.hpp"

#ifndef PL_TEST_SCRIPTS_DIR
#define PL_TEST_SCRIPTS_DIR "tests/recordings"
#endif

using pl::test::error_of;
using pl::test::TempDir;

namespace {

// Whether an error message says what it should; on failure the test shows both.
testing::AssertionResult contains(const std::string& message, const std::string& part) {
  if (message.find(part) != std::string::npos) return testing::AssertionSuccess();
  return testing::AssertionFailure() << "the message \"" << message << "\"\ndoes not contain \"" << part << "\"";
}

using pl::test::from_hex;

std::string read_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

std::uint32_t u32_at(const std::string& b, std::size_t at) {
  std::uint32_t v;
  std::memcpy(&v, b.data() + at, 4);
  return v;
}

void put_u32(std::string& b, std::size_t at, std::uint32_t v) { std::memcpy(b.data() + at, &v, 4); }

std::string u32le(std::uint32_t v) { return std::string(reinterpret_cast<const char*>(&v), 4); }
std::string u64le(std::uint64_t v) { return std::string(reinterpret_cast<const char*>(&v), 8); }

// --- A minimal record walker of the test's own, to find what to damage in python's bags. ---

struct Rec {
  std::size_t at = 0, header_at = 0, header_len = 0, data_at = 0, data_len = 0;
  int op = -1;
};

// The offset of field `name`'s value in the header of `r`, or npos.
std::size_t value_at(const std::string& b, const Rec& r, const std::string& name) {
  for (std::size_t p = r.header_at; p + 4 <= r.header_at + r.header_len;) {
    const std::uint32_t n = u32_at(b, p);
    if (b.compare(p + 4, name.size() + 1, name + "=") == 0) return p + 4 + name.size() + 1;
    p += 4 + n;
  }
  return std::string::npos;
}

std::vector<Rec> walk(const std::string& b, std::size_t begin, std::size_t end) {
  std::vector<Rec> out;
  for (std::size_t p = begin; p + 8 <= end;) {
    Rec r;
    r.at = p;
    r.header_len = u32_at(b, p);
    r.header_at = p + 4;
    r.data_len = u32_at(b, r.header_at + r.header_len);
    r.data_at = r.header_at + r.header_len + 4;
    const std::size_t op = value_at(b, r, "op");
    if (op != std::string::npos) r.op = static_cast<unsigned char>(b[op]);
    out.push_back(r);
    p = r.data_at + r.data_len;
  }
  return out;
}

std::vector<Rec> top_level(const std::string& b) { return walk(b, 13, b.size()); }

std::vector<Rec> of_op(const std::vector<Rec>& recs, int op) {
  std::vector<Rec> out;
  for (const Rec& r : recs)
    if (r.op == op) out.push_back(r);
  return out;
}

// --- Hand-made bags, for what python's writer never writes. ---

std::string field(const std::string& name, const std::string& value) {
  return u32le(static_cast<std::uint32_t>(name.size() + 1 + value.size())) + name + "=" + value;
}
std::string op_field(int op) { return field("op", std::string(1, static_cast<char>(op))); }
std::string record(const std::string& header, const std::string& data) {
  return u32le(static_cast<std::uint32_t>(header.size())) + header + u32le(static_cast<std::uint32_t>(data.size())) + data;
}
std::string bag_start() {
  return "#ROSBAG V2.0\n" +
         record(op_field(3) + field("index_pos", u64le(0)) + field("conn_count", u32le(0)) + field("chunk_count", u32le(0)),
                std::string(64, ' '));
}
std::string connection(std::uint32_t id, const std::string& topic, const std::string& type) {
  return record(op_field(7) + field("conn", u32le(id)) + field("topic", topic),
                field("topic", topic) + field("type", type) + field("md5sum", "0123456789abcdef0123456789abcdef") +
                    field("message_definition", "string data\n"));
}
std::string message(std::uint32_t conn, std::uint32_t sec, std::uint32_t nsec, const std::string& data) {
  return record(op_field(2) + field("conn", u32le(conn)) + field("time", u32le(sec) + u32le(nsec)), data);
}
std::string chunk(const std::string& content, const std::string& compression = "none") {
  return record(
      op_field(5) + field("compression", compression) + field("size", u32le(static_cast<std::uint32_t>(content.size()))),
      content);
}

std::unique_ptr<pl::bag::Reader> open_bytes(const std::string& bytes, const std::string& name = "hand.bag") {
  return pl::bag::open_ros1(pl::bag::hold_bytes(bytes, name));
}

std::unique_ptr<pl::bag::Reader> open_file(const std::string& path) { return pl::bag::open_ros1(pl::bag::map_file(path)); }

// The message of opening these bytes and reading every message, or "" when nothing is refused.
std::string read_all_error(const std::string& bytes, const std::string& name) {
  return error_of([&] {
    auto r = open_bytes(bytes, name);
    for (const auto& m : r->messages()) r->read(m);
  });
}

// --- python3-rosbag's bags, written once for the whole suite. ---

class BagRos1 : public testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new TempDir;
    for (const char* c : {"none", "bz2", "lz4"}) make(c, std::string("--compression ") + c);
    make("cut_none", "--unindexed");
    make("cut_lz4", "--unindexed --compression lz4");
  }
  static void TearDownTestSuite() {
    delete dir_;
    dir_ = nullptr;
  }

  static void make(const std::string& name, const std::string& args) {
    const std::string bag = bag_path(name);
    const auto res = pl::test::run("/usr/bin/python3 " PL_TEST_SCRIPTS_DIR "/make_ros1_bag.py " + bag + " " + (*dir_ / name) +
                                   ".json " + args);
    ASSERT_EQ(res.exit_code, 0) << res.output;
    manifests_[name] = nlohmann::json::parse(pl::test::read_file(*dir_ / name + ".json"));
  }
  static std::string bag_path(const std::string& name) { return *dir_ / name + ".bag"; }
  static const nlohmann::json& manifest(const std::string& name) { return manifests_.at(name); }

  // Every topic and message of the reader against python's manifest: topics by name and type,
  // messages in time order (ties in the order written), each one's bytes exactly.
  static void expect_same(pl::bag::Reader& r, const nlohmann::json& want) {
    ASSERT_EQ(r.topics().size(), want["topics"].size());
    for (const auto& t : want["topics"]) {
      const auto it = std::find_if(r.topics().begin(), r.topics().end(), [&](const pl::bag::Topic& got) {
        return got.name == t["name"].get<std::string>() && got.type == t["type"].get<std::string>();
      });
      ASSERT_NE(it, r.topics().end()) << t["name"] << " " << t["type"];
      EXPECT_EQ(it->count, t["count"].get<std::size_t>()) << it->name;
      EXPECT_EQ(it->definition, t["definition"].get<std::string>()) << it->name;
      EXPECT_EQ(it->encoding, pl::bag::Encoding::Ros1);
    }
    std::vector<nlohmann::json> expected(want["messages"].begin(), want["messages"].end());
    std::stable_sort(expected.begin(), expected.end(), [](const nlohmann::json& a, const nlohmann::json& b) {
      return a["time_ns"].get<std::int64_t>() < b["time_ns"].get<std::int64_t>();
    });
    ASSERT_EQ(r.messages().size(), expected.size());
    for (std::size_t i = 0; i < expected.size(); ++i) {
      const pl::bag::MessageRef& m = r.messages()[i];
      ASSERT_LT(m.topic, r.topics().size());
      EXPECT_EQ(r.topics()[m.topic].name, expected[i]["topic"].get<std::string>()) << "message " << i;
      EXPECT_EQ(r.topics()[m.topic].type, expected[i]["type"].get<std::string>()) << "message " << i;
      EXPECT_EQ(m.time_ns, expected[i]["time_ns"].get<std::int64_t>()) << "message " << i;
      EXPECT_EQ(m.size, expected[i]["size"].get<std::uint64_t>()) << "message " << i;
      EXPECT_EQ(r.read(m), from_hex(expected[i]["hex"].get<std::string>())) << "message " << i;
    }
  }

  static TempDir* dir_;
  static std::map<std::string, nlohmann::json> manifests_;
};

TempDir* BagRos1::dir_ = nullptr;
std::map<std::string, nlohmann::json> BagRos1::manifests_;

}  // namespace

TEST_F(BagRos1, ReadsAnUncompressedBagByteForByte) {
  auto r = open_file(bag_path("none"));
  EXPECT_STREQ(r->format(), "ROS 1 bag");
  EXPECT_EQ(r->path(), bag_path("none"));
  expect_same(*r, manifest("none"));
}

TEST_F(BagRos1, ReadsABz2BagByteForByte) {
  auto r = open_file(bag_path("bz2"));
  expect_same(*r, manifest("bz2"));
}

TEST_F(BagRos1, ReadsAnLz4BagByteForByte) {
  auto r = open_file(bag_path("lz4"));
  expect_same(*r, manifest("lz4"));
}

TEST_F(BagRos1, OpenDispatchesABagFileToThisReader) {
  auto r = pl::bag::open(bag_path("lz4"));
  EXPECT_STREQ(r->format(), "ROS 1 bag");
  EXPECT_EQ(r->messages().size(), manifest("lz4")["messages"].size());
}

TEST_F(BagRos1, MessagesOfUncompressedChunksAreViewsIntoTheMappedFile) {
  const auto src = pl::bag::map_file(bag_path("none"));
  auto r = pl::bag::open_ros1(src);
  const std::string_view file = src->bytes();
  std::set<std::uint64_t> chunks;
  for (const auto& m : r->messages()) {
    const std::string_view v = r->read(m);
    EXPECT_GE(v.data(), file.data());
    EXPECT_LE(v.data() + v.size(), file.data() + file.size());
    chunks.insert(m.where);
  }
  EXPECT_GT(chunks.size(), 10u);  // python's small chunk threshold: many chunks
}

TEST_F(BagRos1, SeveralConnectionsOfOneTopicAreOneTopicAndTwoTypesAreTwo) {
  auto r = open_file(bag_path("bz2"));
  EXPECT_EQ(manifest("bz2")["connections"].get<std::size_t>(), 8u);  // what python's rosbag reads back
  std::map<std::string, std::vector<std::string>> types;
  for (const auto& t : r->topics()) types[t.name].push_back(t.type);
  ASSERT_EQ(types["/gps/fix"], std::vector<std::string>{"sensor_msgs/NavSatFix"});  // two publishers
  ASSERT_EQ(types["/pose"].size(), 2u);
  EXPECT_EQ(r->topics().size(), 6u);
  for (const auto& t : r->topics()) {
    if (t.name == "/gps/fix") {
      EXPECT_EQ(t.count, 19u);
    }
    if (t.name == "/tf_static") {
      EXPECT_NE(t.definition.find("geometry_msgs/TransformStamped[] transforms"), std::string::npos);
    }
  }
}

TEST_F(BagRos1, SortsByTimeWithTiesInFileOrder) {
  // The bag has messages written late (recorded as earlier) and pairs written at the same time.
  const auto& written = manifest("none")["messages"];
  bool out_of_order = false;
  for (std::size_t i = 1; i < written.size(); ++i)
    out_of_order |= written[i]["time_ns"].get<std::int64_t>() < written[i - 1]["time_ns"].get<std::int64_t>();
  ASSERT_TRUE(out_of_order);
  auto r = open_file(bag_path("none"));
  const auto& ms = r->messages();
  EXPECT_TRUE(std::is_sorted(ms.begin(), ms.end(), [](const auto& a, const auto& b) { return a.time_ns < b.time_ns; }));
  // The first /odom and the first /gps/fix share a time; /odom was written first.
  const std::int64_t t = 1700000000LL * 1000000000 + 1234;
  std::vector<std::string> at_t;
  for (const auto& m : ms)
    if (m.time_ns == t) at_t.push_back(r->topics()[m.topic].name);
  EXPECT_EQ(at_t, (std::vector<std::string>{"/odom", "/velodyne_points", "/gps/fix"}));
}

TEST_F(BagRos1, ReadingOutOfOrderDecompressesTheRightChunk) {
  for (const char* name : {"bz2", "lz4"}) {
    auto r = open_file(bag_path(name));
    std::vector<std::string> forward;
    for (const auto& m : r->messages()) forward.emplace_back(r->read(m));
    for (std::size_t i = r->messages().size(); i-- > 0;) EXPECT_EQ(r->read(r->messages()[i]), forward[i]) << name << " " << i;
    for (std::size_t i = 0; i < r->messages().size(); i += 7)
      EXPECT_EQ(r->read(r->messages()[i]), forward[i]) << name << " " << i;
  }
}

TEST_F(BagRos1, ReadsARecordingCutBeforeItsIndexWasWritten) {
  for (const char* name : {"cut_none", "cut_lz4"}) {
    const std::string bytes = read_bytes(bag_path(name));
    std::uint64_t index_pos = 1;
    std::memcpy(&index_pos, bytes.data() + value_at(bytes, top_level(bytes)[0], "index_pos"), 8);
    ASSERT_EQ(index_pos, 0u) << name;
    EXPECT_LT(bytes.size(), read_bytes(bag_path(name == std::string("cut_none") ? "none" : "lz4")).size());
    auto r = open_file(bag_path(name));
    expect_same(*r, manifest(name));
  }
}

TEST_F(BagRos1, ATruncatedBagIsRefusedAtTheCutOrReadUpToIt) {
  for (const char* name : {"none", "bz2"}) {
    const std::string bytes = read_bytes(bag_path(name));
    const std::size_t full = manifest(name)["messages"].size();
    std::size_t refused = 0;
    std::vector<std::size_t> cuts = {0, 5, 13, 16, 20, 100, 4000, 4109, 4110, bytes.size() - 1};
    for (std::size_t at = 4200; at < bytes.size(); at += 613) cuts.push_back(at);
    for (const std::size_t at : cuts) {
      const std::string cut = bytes.substr(0, at);
      const std::string file = std::string("cut_at_") + std::to_string(at) + ".bag";
      const std::string e = read_all_error(cut, file);
      if (e.empty()) {
        // Only a cut between records leaves a readable bag; it holds some of the messages.
        EXPECT_LE(open_bytes(cut)->messages().size(), full);
        continue;
      }
      ++refused;
      EXPECT_TRUE(contains(e, file + ": offset ")) << at;
      if (at >= 13) {
        EXPECT_TRUE(contains(e, "rosbag reindex " + file)) << at;
      }
      // The offset named lies within the bytes there are.
      std::smatch mo;
      ASSERT_TRUE(std::regex_search(e, mo, std::regex("offset ([0-9]+)"))) << e;
      EXPECT_LE(std::stoull(mo[1]), at) << e;
    }
    EXPECT_GT(refused, cuts.size() / 2) << name;
  }
}

TEST_F(BagRos1, ACutInAChunkNamesTheChunkRecordAndTheBytesLeft) {
  const std::string bytes = read_bytes(bag_path("none"));
  const Rec first = of_op(top_level(bytes), 5).at(0);
  const std::size_t at = first.data_at + first.data_len / 2;
  const std::string e = error_of([&] { open_bytes(bytes.substr(0, at), "short.bag"); });
  // The data length (4 bytes before the data) runs past the end, with this many bytes left.
  EXPECT_TRUE(contains(e, "short.bag: offset " + std::to_string(first.data_at - 4) + ": the record's data length (" +
                              std::to_string(first.data_len) + " bytes) runs past the end (" +
                              std::to_string(at - first.data_at) + " bytes left)"));
  EXPECT_TRUE(contains(e, "`rosbag reindex short.bag`"));
}

TEST_F(BagRos1, ADamagedHeaderLengthIsRefused) {
  const std::string bytes = read_bytes(bag_path("lz4"));
  const Rec c = of_op(top_level(bytes), 5).at(3);
  std::string huge = bytes;
  put_u32(huge, c.at, 0xFFFFFF00u);
  EXPECT_TRUE(
      contains(read_all_error(huge, "huge.bag"),
               "huge.bag: offset " + std::to_string(c.at) + ": the record's header length (4294967040 bytes) runs past the end"));
  std::string shorter = bytes;
  put_u32(shorter, c.at, static_cast<std::uint32_t>(c.header_len - 1));
  const std::string e = read_all_error(shorter, "shorter.bag");
  EXPECT_TRUE(contains(e, "shorter.bag: offset "));
  EXPECT_TRUE(contains(e, "header field"));
  std::string longer = bytes;
  put_u32(longer, c.at, static_cast<std::uint32_t>(c.header_len + 3));
  EXPECT_TRUE(contains(read_all_error(longer, "longer.bag"), "longer.bag: offset "));
}

TEST_F(BagRos1, ADamagedChunkSizeIsRefused) {
  {  // An uncompressed chunk whose declared size disagrees with its data.
    std::string bytes = read_bytes(bag_path("none"));
    const Rec c = of_op(top_level(bytes), 5).at(2);
    const std::size_t size_at = value_at(bytes, c, "size");
    put_u32(bytes, size_at, u32_at(bytes, size_at) + 8);
    const std::string e = read_all_error(bytes, "none.bag");
    EXPECT_TRUE(contains(e, "none.bag: offset " + std::to_string(size_at - 9) + ": the uncompressed chunk declares " +
                                std::to_string(c.data_len + 8) + " bytes but holds " + std::to_string(c.data_len)));
  }
  for (const char* name : {"bz2", "lz4"}) {
    const std::string bytes = read_bytes(bag_path(name));
    const Rec c = of_op(top_level(bytes), 5).at(2);
    const std::size_t size_at = value_at(bytes, c, "size");
    const std::uint32_t size = u32_at(bytes, size_at);
    std::string more = bytes, less = bytes;
    put_u32(more, size_at, size + 1);
    put_u32(less, size_at, size - 1);
    const std::string chunk_at = "offset " + std::to_string(c.at) + ": the " + name + " chunk ";
    EXPECT_TRUE(contains(read_all_error(more, "more.bag"), "more.bag: " + chunk_at + "decompresses to " + std::to_string(size) +
                                                               " bytes, its header declares " + std::to_string(size + 1)));
    // lz4 stops at the declared size; bz2 is given one byte more to see the excess.
    EXPECT_TRUE(contains(read_all_error(less, "less.bag"),
                         "less.bag: " + chunk_at +
                             (std::string(name) == "lz4" ? "decompresses to more than the " + std::to_string(size - 1) + " bytes"
                                                         : "decompresses to " + std::to_string(size) +
                                                               " bytes, its header declares " + std::to_string(size - 1))));
    std::string absurd = bytes;
    put_u32(absurd, size_at, 0xFFFFFFF0u);
    if (std::string(name) == "lz4")  // bz2's bound is loose: its 4 GB would be refused only as it decompresses
      EXPECT_TRUE(contains(
          read_all_error(absurd, "absurd.bag"),
          "absurd.bag: offset " + std::to_string(size_at - 9) + ": the chunk declares 4294967280 bytes uncompressed, more than"));
    else
      EXPECT_TRUE(contains(read_all_error(absurd, "absurd.bag"), "decompresses to " + std::to_string(size)));
    // A damaged data length makes the chunk's records run into what follows it.
    std::string longer = bytes;
    put_u32(longer, c.data_at - 4, static_cast<std::uint32_t>(c.data_len + 16));
    EXPECT_TRUE(contains(read_all_error(longer, "longer.bag"), "longer.bag: offset " + std::to_string(c.at)));
  }
}

TEST_F(BagRos1, DamagedCompressedDataIsRefused) {
  for (const char* name : {"bz2", "lz4"}) {
    std::string bytes = read_bytes(bag_path(name));
    const Rec c = of_op(top_level(bytes), 5).at(4);
    bytes[c.data_at + c.data_len / 2] ^= 0x5A;
    const std::string e = read_all_error(bytes, "flipped.bag");
    EXPECT_TRUE(contains(e, "flipped.bag: offset " + std::to_string(c.at) + ": the " + name + " chunk ")) << name;
  }
}

TEST_F(BagRos1, AnUnknownCompressionIsNamed) {
  std::string bytes = read_bytes(bag_path("none"));
  const Rec c = of_op(top_level(bytes), 5).at(1);
  const std::size_t at = value_at(bytes, c, "compression");
  ASSERT_EQ(bytes.substr(at, 4), "none");
  bytes.replace(at, 4, "zstd");
  const std::string e = read_all_error(bytes, "zstd.bag");
  EXPECT_TRUE(
      contains(e, "zstd.bag: offset " + std::to_string(at - 16) + ": chunk compression \"zstd\" is not one ROS 1 bags use"));
}

TEST_F(BagRos1, AMessageOnAnUnknownConnectionIsRefused) {
  std::string bytes = read_bytes(bag_path("none"));
  const Rec c = of_op(top_level(bytes), 5).at(0);
  const Rec msg = of_op(walk(bytes, c.data_at, c.data_at + c.data_len), 2).at(0);
  put_u32(bytes, value_at(bytes, msg, "conn"), 77);
  const std::string e = read_all_error(bytes, "orphan.bag");
  EXPECT_TRUE(contains(e, "orphan.bag: offset " + std::to_string(msg.data_at) + " in the chunk at offset " +
                              std::to_string(c.at) +
                              ": a message on connection 77, which no connection record in the bag describes"));
}

TEST_F(BagRos1, AConnectionDescribedAgainWithAnotherTopicIsRefused) {
  std::string bytes = read_bytes(bag_path("none"));
  // The connection records after the chunks repeat those in them.
  const auto conns = of_op(top_level(bytes), 7);
  ASSERT_FALSE(conns.empty());
  const std::size_t at = value_at(bytes, conns.back(), "topic");
  bytes[at + 1] = 'X';
  const std::string e = read_all_error(bytes, "renamed.bag");
  EXPECT_TRUE(contains(e, "renamed.bag: offset " + std::to_string(conns.back().at) + ": connection "));
  EXPECT_TRUE(contains(e, "is described again as \"/X"));
}

TEST_F(BagRos1, NonBagBytesAreRefused) {
  EXPECT_TRUE(contains(read_all_error("# .PCD v0.7\nVERSION 0.7\n", "cloud.pcd"),
                       "cloud.pcd: offset 0: not a ROS 1 bag: expected \"#ROSBAG V2.0\", found \"# .PCD v0.7\""));
  EXPECT_TRUE(contains(read_all_error("", "empty.bag"), "empty.bag: offset 0: not a ROS 1 bag"));
  EXPECT_TRUE(
      contains(read_all_error("#ROSRECORD V1.2\n....", "old.bag"), "old.bag: offset 0: a ROS bag of another format version"));
  EXPECT_TRUE(contains(read_all_error("#ROSBAG V2.0\n", "magic_only.bag"),
                       "magic_only.bag: offset 13: a record needs a 4-byte header length, 0 bytes are left"));
}

// --- Hand-made bags. ---

TEST(BagRos1HandMade, ConnectionsAfterTheChunksAndMessagesOutsideChunksAreRead) {
  // Old recorders wrote some connection records only after the chunks; a recorder killed before
  // it wrote a chunk's length leaves the chunk's records standing on their own.
  const std::string bag = bag_start() + chunk(message(4, 10, 500, "late-described")) + message(4, 9, 0, "loose") +
                          connection(4, "/chatter", "std_msgs/String") + u32le(0);
  // The trailing 4 bytes are a record cut after its (empty) header: refused, then read without them.
  EXPECT_TRUE(contains(read_all_error(bag, "h.bag"),
                       "h.bag: offset " + std::to_string(bag.size()) + ": the record's data length needs 4 bytes, 0 are left"));
  auto r = open_bytes(bag.substr(0, bag.size() - 4));
  ASSERT_EQ(r->topics().size(), 1u);
  EXPECT_EQ(r->topics()[0].name, "/chatter");
  EXPECT_EQ(r->topics()[0].definition, "string data\n");
  EXPECT_EQ(r->topics()[0].count, 2u);
  ASSERT_EQ(r->messages().size(), 2u);
  EXPECT_EQ(r->messages()[0].time_ns, 9000000000LL);
  EXPECT_EQ(r->read(r->messages()[0]), "loose");
  EXPECT_EQ(r->messages()[1].time_ns, 10000000500LL);
  EXPECT_EQ(r->read(r->messages()[1]), "late-described");
}

TEST(BagRos1HandMade, UnknownRecordsAreSkippedAndTheLargestTimeFits) {
  const std::string odd = record(op_field(0x42) + field("x", "y"), "ignored");
  const std::string bag =
      bag_start() + odd + chunk(connection(0, "/a", "std_msgs/String") + odd + message(0, 0xFFFFFFFFu, 999999999, "last")) + odd;
  auto r = open_bytes(bag);
  ASSERT_EQ(r->messages().size(), 1u);
  EXPECT_EQ(r->messages()[0].time_ns, 4294967295LL * 1000000000 + 999999999);
  EXPECT_EQ(r->read(r->messages()[0]), "last");
}

TEST(BagRos1HandMade, MalformedRecordsAreRefusedWithTheirOffset) {
  const std::string start = bag_start();
  const std::size_t at = start.size();
  EXPECT_TRUE(contains(read_all_error(start + record(field("conn", u32le(0)), ""), "noop.bag"),
                       "noop.bag: offset " + std::to_string(at) + ": a record without an \"op\" field"));
  EXPECT_TRUE(contains(read_all_error(start + record(op_field(2) + field("conn", u32le(0)), "x"), "notime.bag"),
                       "notime.bag: offset " + std::to_string(at) + ": the message data record has no \"time\" field"));
  EXPECT_TRUE(
      contains(read_all_error(start + record(op_field(2) + field("conn", "ab") + field("time", u64le(0)), "x"), "narrow.bag"),
               "narrow.bag: offset " + std::to_string(at + 4 + 8) +
                   ": the \"conn\" field of the message data record has 2 bytes, expected 4"));
  EXPECT_TRUE(contains(read_all_error(start + record(u32le(3) + "abc", ""), "noeq.bag"),
                       "noeq.bag: offset " + std::to_string(at + 4) + ": a header field without '=' (\"abc\")"));
  EXPECT_TRUE(contains(read_all_error(start + start.substr(13), "twice.bag"),
                       "twice.bag: offset " + std::to_string(at) + ": a second bag header"));
  EXPECT_TRUE(contains(read_all_error("#ROSBAG V2.0\n" + chunk(""), "first.bag"),
                       "first.bag: offset 13: expected the bag header record (op 3), found a chunk record"));
  EXPECT_TRUE(contains(read_all_error(start + chunk(chunk("")), "nested.bag"), "a chunk record inside a chunk"));
  EXPECT_TRUE(contains(
      read_all_error(start + record(op_field(5) + field("compression", "bz2") + field("size", u32le(100)), ""), "unfinished.bag"),
      "unfinished.bag: offset " + std::to_string(at) + ": the bz2 chunk has no data"));
  const std::string enc =
      "#ROSBAG V2.0\n" + record(op_field(3) + field("index_pos", u64le(0)) + field("encryptor", "rosbag/AesCbcEncryptor"), "");
  EXPECT_TRUE(contains(read_all_error(enc, "secret.bag"), "`rosbag decrypt secret.bag`"));
}

TEST(BagRos1HandMade, OneConnectionIdForTwoTopicsIsRefused) {
  const std::string start = bag_start();
  const std::string first = chunk(connection(1, "/a", "std_msgs/String") + message(1, 1, 0, "a"));
  const std::string bag = start + first + chunk(connection(1, "/b", "std_msgs/String") + message(1, 2, 0, "b"));
  // The second connection record is the first record in the second chunk's data.
  const std::size_t second_conn = start.size() + first.size() + chunk("").size();
  EXPECT_TRUE(contains(read_all_error(bag, "twotopics.bag"),
                       "twotopics.bag: offset " + std::to_string(second_conn) + " in the chunk at offset " +
                           std::to_string(start.size() + first.size()) +
                           ": connection 1 is described again as \"/b\" (std_msgs/String), but was \"/a\""));
}

TEST(BagRos1HandMade, ReferencesFromElsewhereAreRefused) {
  auto r = open_bytes(bag_start() + chunk(connection(0, "/a", "std_msgs/String") + message(0, 1, 0, "abc")));
  pl::bag::MessageRef m = r->messages().at(0);
  m.size = 1000;
  EXPECT_TRUE(contains(error_of([&] { r->read(m); }), "hand.bag: offset "));
  m.where = 99;
  EXPECT_TRUE(contains(error_of([&] { r->read(m); }), "hand.bag: no chunk 99"));
}
