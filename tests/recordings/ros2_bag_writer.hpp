// Writers of ROS 2 bags for the reader's tests: .db3 files written with SQLite itself in the tables
// rosbag2 writes (Humble's, and Iron's and later ones with message definitions), metadata.yaml, zstd,
// and what the tests read back.
#pragma once

#include <gtest/gtest.h>
#include <sqlite3.h>
#include <zstd.h>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <ostream>
#include <string>
#include <utility>
#include <vector>

#include "error_of.hpp"
#include "pl/recordings/bag.hpp"

namespace pl::test::ros2bag {

namespace fs = std::filesystem;
using pl::test::error_of;

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

inline void exec(sqlite3* db, const std::string& sql) {
  char* err = nullptr;
  const int rc = sqlite3_exec(db, sql.c_str(), nullptr, nullptr, &err);
  const std::string msg = err ? err : "";
  sqlite3_free(err);
  ASSERT_EQ(rc, SQLITE_OK) << sql << ": " << msg;
}

// Writes the rows into a new .db3 file the way rosbag2 does: its tables, its index, one row per
// message with the serialized bytes as a blob. Returns the open connection when `keep_open`.
inline sqlite3* write_db3(const std::string& path, const std::vector<TopicRow>& topics, const std::vector<MessageRow>& messages,
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
inline std::string metadata_yaml(const std::vector<std::string>& files, const std::string& compression_format = "",
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
inline std::string payload(std::size_t n, int seed) {
  std::string s(n, '\0');
  for (std::size_t i = 0; i < n; ++i) s[i] = static_cast<char>((i * 131 + static_cast<std::size_t>(seed) * 17 + i / 7) & 0xFF);
  return s;
}

inline std::string zstd(const std::string& raw) {
  std::string out(ZSTD_compressBound(raw.size()), '\0');
  const std::size_t n = ZSTD_compress(out.data(), out.size(), raw.data(), raw.size(), 3);
  EXPECT_FALSE(ZSTD_isError(n));
  out.resize(n);
  return out;
}

inline std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

inline void spit(const std::string& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary | std::ios::trunc).write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

inline testing::AssertionResult contains(const std::string& message, const std::string& part) {
  if (message.find(part) != std::string::npos) return testing::AssertionSuccess();
  return testing::AssertionFailure() << "the message \"" << message << "\"\ndoes not contain \"" << part << "\"";
}

inline std::string open_error(const std::string& path) {
  return error_of([&] { pl::bag::open_ros2(path); });
}

// Every message's (topic name, time, bytes), in the reader's order.
struct Read {
  std::string topic;
  std::int64_t time_ns;
  std::string data;
  bool operator==(const Read& o) const { return topic == o.topic && time_ns == o.time_ns && data == o.data; }
};
inline std::ostream& operator<<(std::ostream& os, const Read& r) {
  return os << r.topic << "@" << r.time_ns << "(" << r.data.size() << " bytes)";
}

inline std::vector<Read> read_all(pl::bag::Reader& r) {
  std::vector<Read> out;
  for (const auto& m : r.messages()) {
    const std::string_view v = r.read(m);
    out.push_back({r.topics().at(m.topic).name, m.time_ns, std::string(v)});
  }
  return out;
}

inline const std::vector<TopicRow> kTopics = {{1, "/points", "sensor_msgs/msg/PointCloud2"},
                                       {2, "/odom", "nav_msgs/msg/Odometry"},
                                       {3, "/status", "std_msgs/msg/String", "json"}};

}  // namespace pl::test::ros2bag
