// The ROS 2 bag reader (recordings/src/bag_ros2.cpp) refuses damaged and foreign bags, each refusal
// naming the file and the problem.
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

TEST(Ros2Bag, FileThatIsNotSqliteIsRefused) {
  TempDir dir;
  write_file(dir / "x.db3", "#ROSBAG V2.0\nnot this reader's");
  const std::string e = open_error(dir / "x.db3");
  EXPECT_TRUE(contains(e, dir / "x.db3"));
  EXPECT_TRUE(contains(e, "not an SQLite file"));
  write_file(dir / "empty.db3", "");
  EXPECT_TRUE(contains(open_error(dir / "empty.db3"), dir / "empty.db3: an empty file, not an SQLite file"));
  EXPECT_TRUE(contains(open_error(dir / "none.db3"), dir / "none.db3: no such file"));
}

TEST(Ros2Bag, Db3WithoutMessagesOrTopicsTableIsRefused) {
  TempDir dir;
  write_db3(dir / "a.db3", kTopics, {{1, 1, "x"}});
  fs::copy_file(dir / "a.db3", dir / "b.db3");
  {
    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open((dir / "a.db3").c_str(), &db), SQLITE_OK);
    exec(db, "DROP TABLE messages");
    sqlite3_close(db);
    ASSERT_EQ(sqlite3_open((dir / "b.db3").c_str(), &db), SQLITE_OK);
    exec(db, "DROP TABLE topics");
    sqlite3_close(db);
  }
  EXPECT_TRUE(contains(open_error(dir / "a.db3"), dir / "a.db3: no table messages: not a rosbag2 .db3 file"));
  EXPECT_TRUE(contains(open_error(dir / "b.db3"), dir / "b.db3: no table topics: not a rosbag2 .db3 file"));
}

TEST(Ros2Bag, MessageOfAnUnknownTopicIsRefusedNamingItsRow) {
  TempDir dir;
  write_db3(dir / "u.db3", kTopics, {{1, 1, "x"}, {9, 2, "y"}});
  EXPECT_TRUE(contains(open_error(dir / "u.db3"), dir / "u.db3: table messages, row 2: topic_id 9 is not in table topics"));
}

TEST(Ros2Bag, TablesThatRunSqlOnReadingAreRefused) {
  TempDir dir;
  write_db3(dir / "v.db3", kTopics, {{1, 1, "x"}});
  fs::copy_file(dir / "v.db3", dir / "g.db3");
  fs::copy_file(dir / "v.db3", dir / "d.db3");
  fs::copy_file(dir / "v.db3", dir / "t.db3");
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open((dir / "v.db3").c_str(), &db), SQLITE_OK);
  exec(db, "ALTER TABLE messages RENAME TO m; CREATE VIEW messages AS SELECT * FROM m");
  sqlite3_close(db);
  ASSERT_EQ(sqlite3_open((dir / "g.db3").c_str(), &db), SQLITE_OK);
  exec(db,
       "ALTER TABLE messages RENAME TO m; CREATE TABLE messages(id INTEGER PRIMARY KEY, topic_id, timestamp, d, data AS "
       "(zeroblob(d)))");
  sqlite3_close(db);
  // A default computed for the rows stored before the column was there (declared by editing the
  // schema, as a crafted file can).
  ASSERT_EQ(sqlite3_open((dir / "d.db3").c_str(), &db), SQLITE_OK);
  exec(db,
       "CREATE TABLE m(id INTEGER PRIMARY KEY, topic_id, timestamp); INSERT INTO m SELECT id, topic_id, timestamp FROM messages;"
       "DROP TABLE messages; ALTER TABLE m RENAME TO messages; PRAGMA writable_schema=ON;"
       "UPDATE sqlite_master SET sql='CREATE TABLE messages(id INTEGER PRIMARY KEY, topic_id, timestamp, data BLOB DEFAULT "
       "(zeroblob(1000000)))'"
       " WHERE name='messages'");
  sqlite3_close(db);
  ASSERT_EQ(sqlite3_open((dir / "t.db3").c_str(), &db), SQLITE_OK);
  exec(db, "UPDATE messages SET data = 'text'");
  sqlite3_close(db);
  EXPECT_TRUE(contains(open_error(dir / "v.db3"), dir / "v.db3: messages is a view, not a table"));
  EXPECT_TRUE(contains(open_error(dir / "g.db3"), dir / "g.db3: table messages: column data is computed"));
  EXPECT_TRUE(contains(open_error(dir / "d.db3"), dir / "d.db3: table messages: column data has a computed default"));
  EXPECT_TRUE(contains(open_error(dir / "t.db3"), dir / "t.db3: table messages, row 1: the data is text, not a blob"));
}

TEST(Ros2Bag, TruncatedDb3IsRefusedAsMalformed) {
  TempDir dir;
  std::vector<MessageRow> rows;
  for (int i = 0; i < 400; ++i) rows.push_back({1 + i % 2, i, payload(1500, i)});
  write_db3(dir / "t.db3", kTopics, rows);
  const std::string whole = slurp(dir / "t.db3");
  ASSERT_GT(whole.size(), 400u * 1500);
  // Cut off half way, as an interrupted copy leaves it: the error comes when opening (the list of
  // messages reaches the missing pages) or at the latest when reading.
  spit(dir / "t.db3", whole.substr(0, whole.size() / 2));
  const std::string e = error_of([&] {
    auto r = pl::bag::open_ros2(dir / "t.db3");
    for (const auto& m : r->messages()) r->read(m);
  });
  EXPECT_TRUE(contains(e, dir / "t.db3: table "));
  EXPECT_TRUE(contains(e, "database disk image is malformed"));
  EXPECT_TRUE(contains(e, ".recover"));
}

TEST(Ros2Bag, FolderWithoutMetadataOrWithBadMetadataIsRefused) {
  TempDir dir;
  write_db3(dir / "bag/b_0.db3", kTopics, {{1, 1, "x"}});
  EXPECT_TRUE(contains(open_error(dir / "bag"), dir / "bag: no metadata.yaml"));
  EXPECT_TRUE(contains(open_error(dir / "bag"), "ros2 bag reindex"));
  const std::string md = dir / "bag/metadata.yaml";
  write_file(md, "rosbag2_bagfile_information:\n  version: 5\n  relative_file_paths: [b_0.db3\n  files: }\n");
  EXPECT_TRUE(contains(open_error(dir / "bag"), md + ":4: not valid YAML"));
  write_file(md, "something_else:\n  version: 5\n");
  EXPECT_TRUE(contains(open_error(dir / "bag"), md + ": no map rosbag2_bagfile_information: not a rosbag2 metadata.yaml"));
  write_file(md, "rosbag2_bagfile_information:\n  storage_identifier: sqlite3\n  relative_file_paths: []\n");
  EXPECT_TRUE(contains(open_error(dir / "bag"), "relative_file_paths lists no files"));
  write_file(md, metadata_yaml({"b_0.db3", "./b_0.db3"}));
  EXPECT_TRUE(contains(open_error(dir / "bag"), md + ": lists the file \"./b_0.db3\" twice"));
}

TEST(Ros2Bag, MetadataListingAMissingFileIsRefused) {
  TempDir dir;
  write_db3(dir / "bag/b_0.db3", kTopics, {{1, 1, "x"}});
  write_file(dir / "bag/metadata.yaml", metadata_yaml({"b_0.db3", "b_1.db3"}));
  const std::string e = open_error(dir / "bag");
  EXPECT_TRUE(contains(e, dir / "bag/metadata.yaml: lists the file \"b_1.db3\", which is missing"));
  EXPECT_TRUE(contains(e, "copy the whole bag folder"));
  // Nothing outside the folder is read, whatever the names say.
  write_db3(dir / "outside.db3", kTopics, {{1, 1, "x"}});
  write_file(dir / "bag/metadata.yaml", metadata_yaml({"../outside.db3"}));
  EXPECT_TRUE(contains(open_error(dir / "bag"), "lists the file \"../outside.db3\", which is missing"));
}

TEST(Ros2Bag, UnsupportedStorageOrCompressionIsRefused) {
  TempDir dir;
  write_db3(dir / "bag/b_0.db3", kTopics, {{1, 1, "x"}});
  const std::string md = dir / "bag/metadata.yaml";
  write_file(md, metadata_yaml({"b_0.mcap"}, "", "", "mcap"));
  EXPECT_TRUE(contains(open_error(dir / "bag"),
                       md + ": this bag stores MCAP files: give the .mcap file itself (" + (dir / "bag/b_0.mcap") + ")"));
  write_file(md, metadata_yaml({"b_0.db3"}, "", "", "rosbag_v2"));
  EXPECT_TRUE(contains(open_error(dir / "bag"), md + ": storage_identifier \"rosbag_v2\" is not supported"));
  write_file(md, metadata_yaml({"b_0.db3"}, "lz4", "FILE"));
  EXPECT_TRUE(contains(open_error(dir / "bag"), "compression_format \"lz4\" is not supported (only zstd)"));
  write_file(md, metadata_yaml({"b_0.db3"}, "zstd", "CHUNK"));
  EXPECT_TRUE(contains(open_error(dir / "bag"), "compression_mode \"CHUNK\" is not one rosbag2 writes"));
}

TEST(Ros2Bag, DamagedZstdIsRefusedNamingTheFileAndRow) {
  TempDir dir;
  // A message that is not a zstd frame, and one cut short.
  const std::string good = zstd(payload(5000, 1));
  write_db3(dir / "bag/b_0.db3", kTopics, {{1, 1, "not zstd at all"}, {1, 2, good.substr(0, good.size() - 5)}, {1, 3, good}});
  write_file(dir / "bag/metadata.yaml", metadata_yaml({"b_0.db3"}, "zstd", "MESSAGE"));
  auto r = pl::bag::open_ros2(dir / "bag");
  ASSERT_EQ(r->messages().size(), 3u);
  const auto& ms = r->messages();
  EXPECT_TRUE(contains(error_of([&] { r->read(ms[0]); }), dir / "bag/b_0.db3: table messages, row 1: damaged zstd data"));
  EXPECT_TRUE(contains(error_of([&] { r->read(ms[1]); }), dir / "bag/b_0.db3: table messages, row 2: "));
  EXPECT_EQ(r->read(ms[2]), payload(5000, 1));  // the reader goes on after a refusal

  // A .db3.zstd file cut short, and one holding something else than a .db3 file.
  const std::string whole = zstd(slurp(dir / "bag/b_0.db3"));
  spit(dir / "cut.db3.zstd", whole.substr(0, whole.size() / 2));
  EXPECT_TRUE(contains(open_error(dir / "cut.db3.zstd"), dir / "cut.db3.zstd: the zstd data is cut short"));
  spit(dir / "other.db3.zstd", zstd("plain text"));
  EXPECT_TRUE(contains(open_error(dir / "other.db3.zstd"), dir / "other.db3.zstd: decompressed, it is not an SQLite file"));
}

TEST(Ros2Bag, MessageRefOfAnotherReaderIsRefused) {
  TempDir dir;
  write_db3(dir / "a.db3", kTopics, {{1, 1, "x"}});
  auto r = pl::bag::open_ros2(dir / "a.db3");
  pl::bag::MessageRef m = r->messages().at(0);
  m.where = 3;
  EXPECT_TRUE(contains(error_of([&] { r->read(m); }), dir / "a.db3: a message of file 3 of 1: not a message this reader listed"));
  m = r->messages().at(0);
  m.offset = 99;
  EXPECT_TRUE(contains(error_of([&] { r->read(m); }), dir / "a.db3: table messages, row 99: the row is gone"));
}
