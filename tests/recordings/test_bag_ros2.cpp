// Tests of the ROS 2 bag reader (recordings/src/bag_ros2.cpp) on bags written here with SQLite itself,
// in the tables rosbag2 writes (Humble's, and Iron's and later ones with message definitions): a
// .db3 file alone, folders of several files, zstd compression of each message or of whole files,
// and damaged or foreign files. One bag is written by Debian's Python (its sqlite3 module) instead,
// a writer independent of this file's.
#include <gtest/gtest.h>
#include <sqlite3.h>
#include <zstd.h>

#include <filesystem>
#include <fstream>
#include <set>
#include <string>
#include <vector>

#include "error_of.hpp"
#include "pl/common/error.hpp"
#include "pl/recordings/bag.hpp"
#include "test_util.hpp"

using pl::test::error_of;
using pl::test::TempDir;
using pl::test::write_file;
namespace fs = std::filesystem;

namespace {

struct TopicRow {
  std::int64_t id;
  std::string name, type, format = "cdr";
};
struct MessageRow {
  std::int64_t topic_id;
  std::int64_t time_ns;
  std::string data;
};

enum class Schema {
  Humble,  // schema version 3: schema, metadata, topics, messages
  Jazzy,   // version 4: topics.type_description_hash and the message_definitions table
};

struct Db3Options {
  Schema schema = Schema::Humble;
  std::string metadata_row;                                      // the YAML rosbag2 keeps in the metadata table (none when empty)
  bool wal = false;                                              // journal_mode WAL, as rosbag2's "resilient" preset records
  std::vector<std::pair<std::string, std::string>> definitions;  // message_definitions: type, text
};

void exec(sqlite3* db, const std::string& sql) {
  char* err = nullptr;
  const int rc = sqlite3_exec(db, sql.c_str(), nullptr, nullptr, &err);
  const std::string msg = err ? err : "";
  sqlite3_free(err);
  ASSERT_EQ(rc, SQLITE_OK) << sql << ": " << msg;
}

// Writes the rows into a new .db3 file the way rosbag2 does: its tables, its index, one row per
// message with the serialized bytes as a blob. Returns the open connection when `keep_open`.
sqlite3* write_db3(const std::string& path, const std::vector<TopicRow>& topics, const std::vector<MessageRow>& messages,
                   const Db3Options& opt = {}, bool keep_open = false) {
  fs::create_directories(fs::path(path).parent_path());
  fs::remove(path);
  sqlite3* db = nullptr;
  EXPECT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
  exec(db, opt.wal ? "PRAGMA journal_mode=WAL" : "PRAGMA journal_mode=MEMORY");
  if (keep_open) exec(db, "PRAGMA wal_autocheckpoint=0");
  const bool jazzy = opt.schema == Schema::Jazzy;
  exec(db, "CREATE TABLE schema(schema_version INTEGER PRIMARY KEY,ros_distro TEXT NOT NULL);");
  exec(db, "CREATE TABLE metadata(id INTEGER PRIMARY KEY,metadata_version INTEGER NOT NULL,metadata TEXT NOT NULL);");
  exec(db,
       std::string(
           "CREATE TABLE topics(id INTEGER PRIMARY KEY,name TEXT NOT NULL,type TEXT NOT NULL,serialization_format TEXT NOT NULL,"
           "offered_qos_profiles TEXT NOT NULL") +
           (jazzy ? ",type_description_hash TEXT NOT NULL" : "") + ");");
  if (jazzy)
    exec(db,
         "CREATE TABLE message_definitions(id INTEGER PRIMARY KEY,topic_type TEXT NOT NULL,encoding TEXT NOT NULL,"
         "encoded_message_definition TEXT NOT NULL,type_description_hash TEXT NOT NULL);");
  exec(db,
       "CREATE TABLE messages(id INTEGER PRIMARY KEY,topic_id INTEGER NOT NULL,timestamp INTEGER NOT NULL, data BLOB NOT NULL);");
  exec(db, "CREATE INDEX timestamp_idx ON messages (timestamp ASC);");
  exec(db,
       std::string("INSERT INTO schema (schema_version, ros_distro) VALUES (") + (jazzy ? "4, 'jazzy'" : "3, 'humble'") + ")");
  exec(db, "BEGIN");
  sqlite3_stmt* st = nullptr;
  for (const auto& t : topics) {
    sqlite3_prepare_v2(
        db, jazzy ? "INSERT INTO topics VALUES (?, ?, ?, ?, '', 'RIHS01_00')" : "INSERT INTO topics VALUES (?, ?, ?, ?, '')", -1,
        &st, nullptr);
    sqlite3_bind_int64(st, 1, t.id);
    sqlite3_bind_text(st, 2, t.name.c_str(), -1, SQLITE_TRANSIENT);
    sqlite3_bind_text(st, 3, t.type.c_str(), -1, SQLITE_TRANSIENT);
    sqlite3_bind_text(st, 4, t.format.c_str(), -1, SQLITE_TRANSIENT);
    EXPECT_EQ(sqlite3_step(st), SQLITE_DONE);
    sqlite3_finalize(st);
  }
  for (const auto& [type, text] : opt.definitions) {
    sqlite3_prepare_v2(
        db,
        "INSERT INTO message_definitions (topic_type, encoding, encoded_message_definition, type_description_hash) "
        "VALUES (?, 'ros2msg', ?, 'RIHS01_00')",
        -1, &st, nullptr);
    sqlite3_bind_text(st, 1, type.c_str(), -1, SQLITE_TRANSIENT);
    sqlite3_bind_text(st, 2, text.c_str(), -1, SQLITE_TRANSIENT);
    EXPECT_EQ(sqlite3_step(st), SQLITE_DONE);
    sqlite3_finalize(st);
  }
  sqlite3_prepare_v2(db, "INSERT INTO messages (timestamp, topic_id, data) VALUES (?, ?, ?);", -1, &st, nullptr);
  for (const auto& m : messages) {
    sqlite3_bind_int64(st, 1, m.time_ns);
    sqlite3_bind_int64(st, 2, m.topic_id);
    if (m.data.empty())
      sqlite3_bind_zeroblob(st, 3, 0);
    else
      sqlite3_bind_blob(st, 3, m.data.data(), static_cast<int>(m.data.size()), SQLITE_TRANSIENT);
    EXPECT_EQ(sqlite3_step(st), SQLITE_DONE);
    sqlite3_reset(st);
  }
  sqlite3_finalize(st);
  if (!opt.metadata_row.empty()) {
    sqlite3_prepare_v2(db, "INSERT INTO metadata (metadata_version, metadata) VALUES (5, ?)", -1, &st, nullptr);
    sqlite3_bind_text(st, 1, opt.metadata_row.c_str(), -1, SQLITE_TRANSIENT);
    EXPECT_EQ(sqlite3_step(st), SQLITE_DONE);
    sqlite3_finalize(st);
  }
  exec(db, "COMMIT");
  if (keep_open) return db;
  sqlite3_close(db);
  return nullptr;
}

// A rosbag2 metadata.yaml (as Humble writes it, less the per-file details this reader ignores).
std::string metadata_yaml(const std::vector<std::string>& files, const std::string& compression_format = "",
                          const std::string& compression_mode = "", const std::string& storage = "sqlite3", int version = 5) {
  std::string y =
      "rosbag2_bagfile_information:\n  version: " + std::to_string(version) + "\n  storage_identifier: " + storage +
      "\n  duration:\n    nanoseconds: 0\n  starting_time:\n    nanoseconds_since_epoch: 0\n  message_count: 0\n"
      "  topics_with_message_count:\n    - topic_metadata:\n        name: /points\n        type: sensor_msgs/msg/PointCloud2\n"
      "        serialization_format: cdr\n        offered_qos_profiles: \"\"\n      message_count: 0\n"
      "  compression_format: \"" +
      compression_format + "\"\n  compression_mode: \"" + compression_mode + "\"\n  relative_file_paths:\n";
  for (const auto& f : files) y += "    - " + f + "\n";
  y += "  files:\n";
  for (const auto& f : files)
    y += "    - path: " + f +
         "\n      starting_time:\n        nanoseconds_since_epoch: 0\n      duration:\n        nanoseconds: 0\n"
         "      message_count: 0\n";
  return y;
}

// Bytes that differ from message to message, with zero bytes and every other value in them.
std::string payload(std::size_t n, int seed) {
  std::string s(n, '\0');
  for (std::size_t i = 0; i < n; ++i) s[i] = static_cast<char>((i * 131 + static_cast<std::size_t>(seed) * 17 + i / 7) & 0xFF);
  return s;
}

std::string zstd(const std::string& raw) {
  std::string out(ZSTD_compressBound(raw.size()), '\0');
  const std::size_t n = ZSTD_compress(out.data(), out.size(), raw.data(), raw.size(), 3);
  EXPECT_FALSE(ZSTD_isError(n));
  out.resize(n);
  return out;
}

std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

void spit(const std::string& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary | std::ios::trunc).write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

testing::AssertionResult contains(const std::string& message, const std::string& part) {
  if (message.find(part) != std::string::npos) return testing::AssertionSuccess();
  return testing::AssertionFailure() << "the message \"" << message << "\"\ndoes not contain \"" << part << "\"";
}

std::string open_error(const std::string& path) {
  return error_of([&] { pl::bag::open_ros2(path); });
}

// Every message's (topic name, time, bytes), in the reader's order.
struct Read {
  std::string topic;
  std::int64_t time_ns;
  std::string data;
  bool operator==(const Read& o) const { return topic == o.topic && time_ns == o.time_ns && data == o.data; }
};
std::ostream& operator<<(std::ostream& os, const Read& r) {
  return os << r.topic << "@" << r.time_ns << "(" << r.data.size() << " bytes)";
}

std::vector<Read> read_all(pl::bag::Reader& r) {
  std::vector<Read> out;
  for (const auto& m : r.messages()) {
    const std::string_view v = r.read(m);
    out.push_back({r.topics().at(m.topic).name, m.time_ns, std::string(v)});
  }
  return out;
}

const std::vector<TopicRow> kTopics = {{1, "/points", "sensor_msgs/msg/PointCloud2"},
                                       {2, "/odom", "nav_msgs/msg/Odometry"},
                                       {3, "/status", "std_msgs/msg/String", "json"}};

}  // namespace

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

// --- Refusals: each names the file and the problem. ---

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
