// The MCAP reader (recordings/src/bag_mcap.cpp) on files written by the tests' own MCAP writer
// (mcap_test_writer.hpp): topics, types, time order across chunks, each compression. The damaged files
// are in test_bag_mcap_damage.cpp.
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

}  // namespace
