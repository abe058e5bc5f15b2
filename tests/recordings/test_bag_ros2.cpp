// Tests of the ROS 2 bag reader (recordings/src/bag_ros2.cpp) on bags written here with SQLite itself
// (ros2_bag_writer.hpp): a .db3 file alone, folders of several files, zstd compression of each message
// or of whole files. One bag is written by Debian's Python (its sqlite3 module) instead, a writer
// independent of this file's. Damaged and foreign bags: test_bag_ros2_refusals.cpp.
#include <gtest/gtest.h>
#include <sqlite3.h>

#include <filesystem>
#include <fstream>
#include <set>
#include <string>
#include <vector>

#include "error_of.hpp"
#include "pl/common/error.hpp"
#include "pl/recordings/bag.hpp"
#include "ros2_bag_writer.hpp"
#include "test_util.hpp"

using namespace pl::test::ros2bag;
using pl::test::error_of;
using pl::test::TempDir;
using pl::test::write_file;
namespace fs = std::filesystem;

TEST(Ros2Bag, Db3AloneListsTopicsWithTypesEncodingsAndCounts) {
  TempDir dir;
  write_db3(dir / "b.db3", kTopics, {{1, 30, "a"}, {2, 10, "b"}, {1, 20, "c"}, {3, 40, "{}"}});
  auto r = pl::bag::open_ros2(dir / "b.db3");
  EXPECT_STREQ(r->format(), "ROS 2 bag");
  EXPECT_EQ(r->path(), dir / "b.db3");
  ASSERT_EQ(r->topics().size(), 3u);
  EXPECT_EQ(r->topics()[0].name, "/points");
  EXPECT_EQ(r->topics()[0].type, "sensor_msgs/PointCloud2");
  EXPECT_EQ(r->topics()[0].encoding, pl::bag::Encoding::Cdr);
  EXPECT_EQ(r->topics()[0].count, 2u);
  EXPECT_EQ(r->topics()[0].definition, "");
  EXPECT_EQ(r->topics()[1].name, "/odom");
  EXPECT_EQ(r->topics()[1].type, "nav_msgs/Odometry");
  EXPECT_EQ(r->topics()[1].count, 1u);
  // A topic in another serialization than CDR keeps its type behind the format's name.
  EXPECT_EQ(r->topics()[2].type, "json:std_msgs/String");
  EXPECT_EQ(r->topics()[2].count, 1u);
  EXPECT_EQ(r->messages().size(), 4u);
}

TEST(Ros2Bag, AnUnnamedSerializationFormatIsCdr) {
  // Older rosbag2 writers left the default format empty (tier4/nebula's VLS-128 capture).
  TempDir dir;
  write_db3(dir / "b.db3", {{1, "/velodyne_packets", "velodyne_msgs/msg/VelodyneScan", ""}}, {{1, 10, "a"}});
  auto r = pl::bag::open_ros2(dir / "b.db3");
  ASSERT_EQ(r->topics().size(), 1u);
  EXPECT_EQ(r->topics()[0].type, "velodyne_msgs/VelodyneScan");
  EXPECT_EQ(r->topics()[0].encoding, pl::bag::Encoding::Cdr);
}

TEST(Ros2Bag, Db3AloneGivesEveryMessagesBytesAndTimeBackInTimeOrder) {
  TempDir dir;
  // Out of time order as written, equal times (kept in row order), an empty message, one that
  // fits a page, ones that spill into SQLite's overflow pages, and times before 1970.
  const std::vector<MessageRow> rows = {{1, 5000, payload(3000, 1)},  {2, 100, payload(0, 2)},
                                        {1, 100, payload(200000, 3)}, {2, 100, payload(17, 4)},
                                        {1, -7, payload(9000, 5)},    {2, 1700000000123456789, payload(1, 6)}};
  write_db3(dir / "b.db3", kTopics, rows);
  auto r = pl::bag::open_ros2(dir / "b.db3");
  const std::vector<Read> expected = {{"/points", -7, rows[4].data},   {"/odom", 100, rows[1].data},
                                      {"/points", 100, rows[2].data},  {"/odom", 100, rows[3].data},
                                      {"/points", 5000, rows[0].data}, {"/odom", 1700000000123456789, rows[5].data}};
  EXPECT_EQ(read_all(*r), expected);
  for (const auto& m : r->messages()) {
    EXPECT_EQ(m.where, 0u);
    EXPECT_EQ(m.size, r->read(m).size());
  }
  // Row ids are the messages' offsets: rows 5, 2, 3, 4, 1, 6 in time order.
  std::vector<std::uint64_t> offsets;
  for (const auto& m : r->messages()) offsets.push_back(m.offset);
  EXPECT_EQ(offsets, (std::vector<std::uint64_t>{5, 2, 3, 4, 1, 6}));
  // Reading again, out of order, gives the same bytes; a view lasts until the next read.
  const auto& ms = r->messages();
  const std::string_view last = r->read(ms[5]);
  EXPECT_EQ(last, rows[5].data);
  EXPECT_EQ(r->read(ms[2]), rows[2].data);
}

TEST(Ros2Bag, FolderReadsItsFilesInMetadataOrderAndSortsAcrossThem) {
  TempDir dir;
  const std::string bag = dir / "drive";
  // The files' topic ids differ, and their names sort the other way round from the bag's order.
  write_db3(bag + "/z_0.db3", {{1, "/points", "sensor_msgs/msg/PointCloud2"}, {2, "/odom", "nav_msgs/msg/Odometry"}},
            {{1, 10, "p10"}, {2, 15, "o15"}, {1, 30, "p30"}});
  write_db3(bag + "/a_1.db3",
            {{5, "/odom", "nav_msgs/msg/Odometry"},
             {7, "/points", "sensor_msgs/msg/PointCloud2"},
             {9, "/gps", "sensor_msgs/msg/NavSatFix"}},
            {{7, 20, "p20"}, {5, 30, "o30"}, {9, 40, "g40"}});
  write_file(bag + "/metadata.yaml", metadata_yaml({"z_0.db3", "a_1.db3"}));
  auto r = pl::bag::open_ros2(bag);
  EXPECT_EQ(r->path(), bag);
  ASSERT_EQ(r->topics().size(), 3u);
  EXPECT_EQ(r->topics()[0].name, "/points");
  EXPECT_EQ(r->topics()[0].count, 3u);
  EXPECT_EQ(r->topics()[1].name, "/odom");
  EXPECT_EQ(r->topics()[1].count, 2u);
  EXPECT_EQ(r->topics()[2].name, "/gps");
  EXPECT_EQ(r->topics()[2].type, "sensor_msgs/NavSatFix");
  EXPECT_EQ(r->topics()[2].count, 1u);
  const std::vector<Read> expected = {{"/points", 10, "p10"}, {"/odom", 15, "o15"}, {"/points", 20, "p20"},
                                      {"/points", 30, "p30"}, {"/odom", 30, "o30"}, {"/gps", 40, "g40"}};
  EXPECT_EQ(read_all(*r), expected);
  // where: the file's place in relative_file_paths (equal times: the earlier file first).
  std::vector<std::uint64_t> where;
  for (const auto& m : r->messages()) where.push_back(m.where);
  EXPECT_EQ(where, (std::vector<std::uint64_t>{0, 0, 1, 0, 1, 1}));
}

TEST(Ros2Bag, ManyFilesAreReadWhateverOrderTheMessagesAskForThem) {
  TempDir dir;
  const std::string bag = dir / "bag";
  std::vector<std::string> names;
  std::vector<Read> expected;
  // Five files whose messages interleave in time, so reading in time order goes from file to file
  // and back (more files than the reader keeps open at once).
  for (int f = 0; f < 5; ++f) {
    names.push_back("bag_" + std::to_string(f) + ".db3");
    std::vector<MessageRow> rows;
    for (int k = 0; k < 4; ++k) rows.push_back({1, k * 10 + f, payload(100 + static_cast<std::size_t>(f), k * 5 + f)});
    write_db3(bag + "/" + names.back(), {{1, "/points", "sensor_msgs/msg/PointCloud2"}}, rows);
  }
  for (int k = 0; k < 4; ++k)
    for (int f = 0; f < 5; ++f)
      expected.push_back({"/points", k * 10 + f, payload(100 + static_cast<std::size_t>(f), k * 5 + f)});
  write_file(bag + "/metadata.yaml", metadata_yaml(names));
  auto r = pl::bag::open_ros2(bag);
  EXPECT_EQ(read_all(*r), expected);
  EXPECT_EQ(r->topics().at(0).count, 20u);
}

TEST(Ros2Bag, OldMetadataNamingFilesWithTheFolderInFrontStillFindsThem) {
  TempDir dir;
  // Before metadata version 4, rosbag2 wrote "rosbag2_2020/rosbag2_2020_0.db3"; the folder has been
  // renamed since.
  const std::string bag = dir / "renamed";
  write_db3(bag + "/rosbag2_2020_0.db3", {{1, "/points", "sensor_msgs/msg/PointCloud2"}}, {{1, 1, "x"}});
  write_file(bag + "/metadata.yaml", metadata_yaml({"rosbag2_2020/rosbag2_2020_0.db3"}, "", "", "sqlite3", 3));
  auto r = pl::bag::open_ros2(bag);
  ASSERT_EQ(r->messages().size(), 1u);
  EXPECT_EQ(r->read(r->messages()[0]), "x");
}

TEST(Ros2Bag, DefinitionsComeFromTheMessageDefinitionsTable) {
  TempDir dir;
  Db3Options opt;
  opt.schema = Schema::Jazzy;
  const std::string odom_def = "std_msgs/Header header\nstring child_frame_id\n";
  opt.definitions = {{"nav_msgs/msg/Odometry", odom_def}};
  write_db3(dir / "j.db3",
            {{1, "/points", "sensor_msgs/msg/PointCloud2"},
             {2, "/odom", "nav_msgs/msg/Odometry"},
             {3, "/odom2", "nav_msgs/msg/Odometry"}},
            {{2, 1, "o"}, {1, 2, "p"}}, opt);
  auto r = pl::bag::open_ros2(dir / "j.db3");
  ASSERT_EQ(r->topics().size(), 3u);
  EXPECT_EQ(r->topics()[0].definition, "");  // none stored for its type
  EXPECT_EQ(r->topics()[1].definition, odom_def);
  EXPECT_EQ(r->topics()[2].definition, odom_def);
  EXPECT_EQ(r->topics()[2].count, 0u);  // a topic without messages is listed too
  EXPECT_EQ(read_all(*r), (std::vector<Read>{{"/odom", 1, "o"}, {"/points", 2, "p"}}));
}

TEST(Ros2Bag, WalModeFileIsReadWithoutWritingBesideIt) {
  TempDir dir;
  Db3Options opt;
  opt.wal = true;
  write_db3(dir / "bag/w.db3", kTopics, {{1, 1, payload(5000, 1)}, {2, 2, "b"}}, opt);
  ASSERT_EQ(slurp(dir / "bag/w.db3")[18], 2);  // the header says WAL
  auto r = pl::bag::open_ros2(dir / "bag/w.db3");
  EXPECT_EQ(read_all(*r), (std::vector<Read>{{"/points", 1, payload(5000, 1)}, {"/odom", 2, "b"}}));
  std::set<std::string> names;
  for (const auto& e : fs::directory_iterator(dir / "bag")) names.insert(e.path().filename().string());
  EXPECT_EQ(names, std::set<std::string>{"w.db3"});
}

TEST(Ros2Bag, WriteAheadLogLeftByAnUnfinishedRecordingIsRead) {
  TempDir dir;
  Db3Options opt;
  opt.wal = true;
  // The writer still has the file open, with its messages only in the log: copying both files is
  // what a recording cut off by a crash leaves.
  sqlite3* writer = write_db3(dir / "live/r.db3", kTopics, {{1, 1, "first"}, {2, 2, "second"}}, opt, true);
  ASSERT_NE(writer, nullptr);
  ASSERT_GT(fs::file_size(dir / "live/r.db3-wal"), 0u);
  fs::create_directories(dir / "copy");
  fs::copy_file(dir / "live/r.db3", dir / "copy/r.db3");
  fs::copy_file(dir / "live/r.db3-wal", dir / "copy/r.db3-wal");
  sqlite3_close(writer);
  auto r = pl::bag::open_ros2(dir / "copy/r.db3");
  EXPECT_EQ(read_all(*r), (std::vector<Read>{{"/points", 1, "first"}, {"/odom", 2, "second"}}));
}

TEST(Ros2Bag, MessageCompressedBagGivesTheDecompressedBytes) {
  TempDir dir;
  const std::string bag = dir / "mc";
  const std::vector<std::string> raw = {payload(100000, 1), payload(3, 2), payload(0, 3), std::string(300000, '\0')};
  write_db3(bag + "/mc_0.db3", kTopics, {{1, 1, zstd(raw[0])}, {2, 2, zstd(raw[1])}});
  write_db3(bag + "/mc_1.db3", kTopics, {{2, 3, zstd(raw[2])}, {1, 4, zstd(raw[3])}});
  write_file(bag + "/metadata.yaml", metadata_yaml({"mc_0.db3", "mc_1.db3"}, "zstd", "MESSAGE"));
  auto r = pl::bag::open_ros2(bag);
  EXPECT_EQ(read_all(*r),
            (std::vector<Read>{{"/points", 1, raw[0]}, {"/odom", 2, raw[1]}, {"/odom", 3, raw[2]}, {"/points", 4, raw[3]}}));
  // MessageRef::size is the stored (compressed) size: the decompressed one is known only on read.
  EXPECT_EQ(r->messages()[0].size, zstd(raw[0]).size());
  EXPECT_EQ(r->messages()[3].size, zstd(raw[3]).size());
}

TEST(Ros2Bag, Db3AloneSaysInItsMetadataTableThatItsMessagesAreCompressed) {
  TempDir dir;
  Db3Options opt;
  // What rosbag2 keeps in the file: the bag's metadata without the rosbag2_bagfile_information key.
  opt.metadata_row =
      "version: 5\nstorage_identifier: sqlite3\ncompression_format: zstd\ncompression_mode: MESSAGE\nrelative_file_paths:\n  - "
      "m_0.db3\n";
  write_db3(dir / "m_0.db3", kTopics, {{1, 1, zstd(payload(4000, 1))}}, opt);
  auto r = pl::bag::open_ros2(dir / "m_0.db3");
  EXPECT_EQ(read_all(*r), (std::vector<Read>{{"/points", 1, payload(4000, 1)}}));
  // Without that row the same bytes come back as stored.
  write_db3(dir / "n_0.db3", kTopics, {{1, 1, zstd(payload(4000, 1))}});
  auto n = pl::bag::open_ros2(dir / "n_0.db3");
  EXPECT_EQ(read_all(*n), (std::vector<Read>{{"/points", 1, zstd(payload(4000, 1))}}));
}

TEST(Ros2Bag, FileCompressedBagIsDecompressedInMemory) {
  TempDir dir;
  const std::string bag = dir / "fc";
  Db3Options wal;
  wal.wal = true;
  write_db3(dir / "plain/fc_0.db3", kTopics, {{1, 10, payload(70000, 1)}, {2, 30, "odom"}});
  write_db3(dir / "plain/fc_1.db3", kTopics, {{1, 20, payload(10, 2)}}, wal);  // a WAL-mode file
  fs::create_directories(bag);
  spit(bag + "/fc_0.db3.zstd", zstd(slurp(dir / "plain/fc_0.db3")));
  spit(bag + "/fc_1.db3.zstd", zstd(slurp(dir / "plain/fc_1.db3")));
  write_file(bag + "/metadata.yaml", metadata_yaml({"fc_0.db3.zstd", "fc_1.db3.zstd"}, "zstd", "FILE"));
  auto r = pl::bag::open_ros2(bag);
  EXPECT_EQ(read_all(*r),
            (std::vector<Read>{{"/points", 10, payload(70000, 1)}, {"/points", 20, payload(10, 2)}, {"/odom", 30, "odom"}}));
  // Nothing was decompressed to disk.
  std::set<std::string> names;
  for (const auto& e : fs::directory_iterator(bag)) names.insert(e.path().filename().string());
  EXPECT_EQ(names, (std::set<std::string>{"fc_0.db3.zstd", "fc_1.db3.zstd", "metadata.yaml"}));
  // A .db3.zstd file given alone is read too.
  auto one = pl::bag::open_ros2(bag + "/fc_1.db3.zstd");
  EXPECT_EQ(read_all(*one), (std::vector<Read>{{"/points", 20, payload(10, 2)}}));
}

// A bag written by Python's sqlite3 module, the way rosbag2 writes one, with a metadata.yaml.
TEST(Ros2Bag, BagWrittenByPythonIsReadAsWritten) {
  ASSERT_TRUE(fs::exists("/usr/bin/python3")) << "no /usr/bin/python3: apt-get install python3 (./pl test installs it)";
  TempDir dir;
  write_file(dir / "make_bag.py", R"PY(
import os, sqlite3, sys
bag = sys.argv[1]
os.makedirs(bag)
db = sqlite3.connect(os.path.join(bag, "py_0.db3"))
db.executescript("""
CREATE TABLE schema(schema_version INTEGER PRIMARY KEY,ros_distro TEXT NOT NULL);
CREATE TABLE metadata(id INTEGER PRIMARY KEY,metadata_version INTEGER NOT NULL,metadata TEXT NOT NULL);
CREATE TABLE topics(id INTEGER PRIMARY KEY,name TEXT NOT NULL,type TEXT NOT NULL,serialization_format TEXT NOT NULL,offered_qos_profiles TEXT NOT NULL);
CREATE TABLE messages(id INTEGER PRIMARY KEY,topic_id INTEGER NOT NULL,timestamp INTEGER NOT NULL, data BLOB NOT NULL);
CREATE INDEX timestamp_idx ON messages (timestamp ASC);
INSERT INTO schema VALUES (3, 'humble');
""")
db.execute("INSERT INTO topics VALUES (1, '/velodyne_points', 'sensor_msgs/msg/PointCloud2', 'cdr', '')")
db.execute("INSERT INTO topics VALUES (2, '/imu', 'sensor_msgs/msg/Imu', 'cdr', '')")
for i in range(50):
    data = bytes((i * 31 + j * 7) % 256 for j in range(i * 97))
    db.execute("INSERT INTO messages (timestamp, topic_id, data) VALUES (?, ?, ?)", (1000 - i * 10, 1 + i % 2, data))
db.commit()
db.close()
with open(os.path.join(bag, "metadata.yaml"), "w") as f:
    f.write("rosbag2_bagfile_information:\n  version: 5\n  storage_identifier: sqlite3\n"
            "  compression_format: ''\n  compression_mode: ''\n  relative_file_paths:\n  - py_0.db3\n")
)PY");
  const auto res = pl::test::run("/usr/bin/python3 " + (dir / "make_bag.py") + " " + (dir / "py"));
  ASSERT_EQ(res.exit_code, 0) << res.output;
  auto r = pl::bag::open_ros2(dir / "py");
  ASSERT_EQ(r->topics().size(), 2u);
  EXPECT_EQ(r->topics()[0].name, "/velodyne_points");
  EXPECT_EQ(r->topics()[0].type, "sensor_msgs/PointCloud2");
  EXPECT_EQ(r->topics()[0].count, 25u);
  EXPECT_EQ(r->topics()[1].type, "sensor_msgs/Imu");
  EXPECT_EQ(r->topics()[1].count, 25u);
  ASSERT_EQ(r->messages().size(), 50u);
  // Written newest first: in time order, message i is the one written last but i.
  for (int k = 0; k < 50; ++k) {
    const int i = 49 - k;
    const auto& m = r->messages()[static_cast<std::size_t>(k)];
    std::string data;
    for (int j = 0; j < i * 97; ++j) data += static_cast<char>((i * 31 + j * 7) % 256);
    EXPECT_EQ(m.time_ns, 1000 - i * 10);
    EXPECT_EQ(m.topic, static_cast<std::uint32_t>(i % 2));
    EXPECT_EQ(m.offset, static_cast<std::uint64_t>(i + 1));
    EXPECT_EQ(r->read(m), data) << "message " << i;
  }
}
