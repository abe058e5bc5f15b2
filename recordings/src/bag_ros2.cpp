// ROS 2 bags as rosbag2's sqlite3 storage writes them: a folder with metadata.yaml and SQLite .db3
// files, or one .db3 file. A file compressed whole with zstd ("x.db3.zstd", compression_mode FILE)
// is known by its first bytes and decompressed into memory. Every message is listed when the bag
// is opened, one pass over each file's messages table that reads each row's id, topic, time and
// size but not its data; read() fetches one message by its row id, and decompresses it when the
// bag compresses each message with zstd (compression_mode MESSAGE). The files are opened read-only and treated as hostile: SQLite
// reports the damage it meets, and the tables read must be plain tables whose columns hold stored values, since a view, a virtual
// table, a generated column or a computed default would run SQL of the file's choosing on every read.
#include "pl/recordings/bag.hpp"

#include <sqlite3.h>
#include <zstd.h>

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <new>
#include <string>
#include <string_view>
#include <unordered_map>
#include <utility>
#include <vector>

#include "pl/common/error.hpp"
#include "pl/common/text.hpp"
#include "ros2_metadata.hpp"
#include "zstd_frames.hpp"

namespace pl::bag {
namespace {

namespace fs = std::filesystem;

constexpr std::string_view kSqliteMagic("SQLite format 3\0", 16);
constexpr std::string_view kZstdMagic("\x28\xB5\x2F\xFD", 4);

// A decompressed message may not be larger than the largest value SQLite stores by default:
// rosbag2 could not have stored it uncompressed either.
constexpr std::uint64_t kMaxMessageBytes = 1000000000;
// Message definitions copied into the topics, in all: a hostile file could give one large
// definition to a great many topics.
constexpr std::size_t kMaxDefinitionBytes = 64u << 20;
// Files kept open at once. Reading in time order stays in one file or crosses into the next; a
// file compressed whole is held decompressed in memory while it is open.
constexpr std::size_t kMaxOpenFiles = 2;

bool starts_with(std::string_view s, std::string_view p) { return s.substr(0, p.size()) == p; }

std::string in_quotes(std::string_view s) { return "\"" + printable(s, 120) + "\""; }

std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

std::string first_bytes(const std::string& path, std::size_t n) {
  std::ifstream f(path, std::ios::binary);
  std::string s(n, '\0');
  f.read(s.data(), static_cast<std::streamsize>(n));
  s.resize(static_cast<std::size_t>(std::max<std::streamsize>(f.gcount(), 0)));
  return s;
}

// Refuses what is not a regular file before anything opens it: opening a FIFO would wait forever.
void require_regular_file(const std::string& path, const std::string& what) {
  std::error_code ec;
  const fs::file_status st = fs::status(path, ec);
  if (!fs::exists(st)) throw Error(path + ": no such file" + what);
  if (!fs::is_regular_file(st)) throw Error(path + ": not a regular file" + what);
}

// "sensor_msgs/msg/PointCloud2" -> "sensor_msgs/PointCloud2", the name ROS 1 and the decoders use.
std::string ros1_style_type(const std::string& type) {
  const std::size_t slash = type.find('/');
  if (slash == std::string::npos || type.compare(slash, 5, "/msg/") != 0) return type;
  if (type.find('/', slash + 5) != std::string::npos) return type;
  return type.substr(0, slash) + type.substr(slash + 4);
}

// SQLite's URI for a path, with ?immutable=1: the file is read without locks and without the
// write-ahead-log side files SQLite would otherwise create beside it (a reader should not write
// into a bag folder, which may be read-only).
std::string immutable_uri(const std::string& path) {
  static const char* hex = "0123456789ABCDEF";
  std::error_code ec;
  const fs::path abs = fs::absolute(path, ec);
  const std::string p = ec ? path : abs.string();
  std::string uri = p.empty() || p[0] != '/' ? "file:" : "file://";
  for (unsigned char c : p) {
    if (std::isalnum(c) || c == '/' || c == '.' || c == '_' || c == '-' || c == '~') {
      uri += static_cast<char>(c);
    } else {
      uri += '%';
      uri += hex[c >> 4];
      uri += hex[c & 15];
    }
  }
  return uri + "?immutable=1";
}

// Whether a column's default is a plain value (a number, a quoted string or blob, NULL,
// CURRENT_TIME): a default that calls a function is computed afresh, at any size, for every row
// stored before the column was added.
bool plain_default(std::string_view d) {
  char close = 0;
  for (char c : d) {
    if (close) {
      if (c == close) close = 0;
    } else if (c == '\'' || c == '"' || c == '`') {
      close = c;
    } else if (c == '[') {
      close = ']';
    } else if (c == '(') {
      return false;
    }
  }
  return true;
}

struct CloseDb {
  void operator()(sqlite3* db) const { sqlite3_close(db); }
};
struct Finalize {
  void operator()(sqlite3_stmt* st) const { sqlite3_finalize(st); }
};
using Stmt = std::unique_ptr<sqlite3_stmt, Finalize>;

std::string column_text(sqlite3_stmt* st, int i) {
  const auto* p = reinterpret_cast<const char*>(sqlite3_column_text(st, i));
  return p ? std::string(p, static_cast<std::size_t>(sqlite3_column_bytes(st, i))) : std::string();
}

// One file of the bag, open: a .db3 file on disk, or a .db3.zstd file decompressed into memory.
class Db {
 public:
  Db(const std::string& path, ZSTD_DCtx* zstd) : name_(path) {
    require_regular_file(path, "");
    const std::string head = first_bytes(path, kSqliteMagic.size());
    int rc = SQLITE_OK;
    sqlite3* db = nullptr;
    if (starts_with(head, kZstdMagic)) {
      const auto src = map_file(path);
      memory_ = unzstd(zstd, src->bytes(), UINT64_MAX, path + ": ");
      if (!starts_with(memory_, kSqliteMagic))
        throw Error(path + ": decompressed, it is not an SQLite file (a .db3.zstd file holds a rosbag2 .db3 file)");
      // A file recorded with a write-ahead log says so in its header. Its log was folded into it
      // before it was compressed, and a file in memory has none: SQLite reads it as a plain file.
      if (memory_.size() >= 20 && memory_[18] == 2 && memory_[19] == 2) memory_[18] = memory_[19] = 1;
      rc = sqlite3_open_v2(":memory:", &db, SQLITE_OPEN_READONLY, nullptr);
      db_.reset(db);
      if (rc == SQLITE_OK)
        rc = sqlite3_deserialize(db, "main", reinterpret_cast<unsigned char*>(memory_.data()),
                                 static_cast<sqlite3_int64>(memory_.size()), static_cast<sqlite3_int64>(memory_.size()),
                                 SQLITE_DESERIALIZE_READONLY);
    } else {
      if (head.empty()) throw Error(path + ": an empty file, not an SQLite file (a recording cut off before it wrote anything?)");
      if (!starts_with(head, kSqliteMagic))
        throw Error(path + ": not an SQLite file (it begins " + in_quotes(head.substr(0, 8)) +
                    ", a .db3 file \"SQLite format 3\"): give a rosbag2 .db3 file or bag folder");
      // A write-ahead log left beside the file (a recording that did not close it) holds the last
      // messages: SQLite must read it, so then the file is opened normally.
      std::error_code ec;
      const auto wal_size = fs::file_size(path + "-wal", ec);
      if (!ec && wal_size > 0)
        rc = sqlite3_open_v2(path.c_str(), &db, SQLITE_OPEN_READONLY, nullptr);
      else
        rc = sqlite3_open_v2(immutable_uri(path).c_str(), &db, SQLITE_OPEN_READONLY | SQLITE_OPEN_URI, nullptr);
      db_.reset(db);
    }
    if (!db) throw Error(path + ": cannot open it: out of memory");
    if (rc != SQLITE_OK) fail_sqlite("", rc);
    sqlite3_db_config(db, SQLITE_DBCONFIG_DEFENSIVE, 1, nullptr);
    sqlite3_db_config(db, SQLITE_DBCONFIG_TRUSTED_SCHEMA, 0, nullptr);
    // Checks each cell's size against its page as it is read: damage is found, not followed.
    rc = sqlite3_exec(db, "PRAGMA cell_size_check = ON", nullptr, nullptr, nullptr);
    if (rc != SQLITE_OK) fail_sqlite("", rc);
    check_table("topics", {"id", "name", "type", "serialization_format"}, true);
    check_table("messages", {"topic_id", "timestamp", "data"}, true);
  }

  const std::string& name() const { return name_; }

  // "FILE: WHERE: PROBLEM"
  [[noreturn]] void fail(const std::string& where, const std::string& problem) const {
    throw Error(name_ + ": " + (where.empty() ? "" : where + ": ") + problem);
  }

  // An SQLite failure at `where`, with what it means and the fix.
  [[noreturn]] void fail_sqlite(const std::string& where, int rc) const {
    const std::string msg = db_ && sqlite3_errcode(db_.get()) == rc ? sqlite3_errmsg(db_.get()) : sqlite3_errstr(rc);
    switch (rc & 0xff) {
      case SQLITE_CORRUPT:
        fail(where,
             msg + " (the file is damaged or cut short: copy it again from the recorder, or salvage what is left with `sqlite3 " +
                 name_ + " .recover | sqlite3 salvaged.db3`)");
      case SQLITE_NOTADB:
        fail(where, msg + " (not an SQLite file, or a damaged one: give a rosbag2 .db3 file)");
      case SQLITE_IOERR:
        fail(where, msg + " (cannot read the file)");
      case SQLITE_NOMEM:
        fail(where, msg + " (out of memory)");
      case SQLITE_BUSY:
      case SQLITE_LOCKED:
        fail(where, msg + " (another program holds the file: wait until the recording ends)");
      case SQLITE_CANTOPEN:
      case SQLITE_READONLY:
      case SQLITE_PERM:
        fail(where, msg + " (SQLite cannot open the file: is it readable? With a write-ahead log beside it (" +
                        fs::path(name_).filename().string() +
                        "-wal) it also needs a folder it may write in: copy the bag to one)");
      default:
        fail(where, msg);
    }
  }

  Stmt prepare(const std::string& sql, const std::string& where) const {
    sqlite3_stmt* st = nullptr;
    const int rc = sqlite3_prepare_v2(db_.get(), sql.c_str(), -1, &st, nullptr);
    Stmt owned(st);
    if (rc != SQLITE_OK) {
      if ((rc & 0xff) == SQLITE_ERROR)
        fail(where, std::string("cannot read it: ") + sqlite3_errmsg(db_.get()) + " (not a table rosbag2 writes)");
      fail_sqlite(where, rc);
    }
    return owned;
  }

  // True at a row, false at the end; an SQLite failure is thrown, naming `where`.
  bool step(sqlite3_stmt* st, const std::string& where) const {
    const int rc = sqlite3_step(st);
    if (rc == SQLITE_ROW) return true;
    if (rc == SQLITE_DONE) return false;
    fail_sqlite(where, rc);
  }

  // Whether `table` is there (a missing one refused when it is `required`) as a plain table with
  // these columns holding stored values.
  bool check_table(const std::string& table, std::initializer_list<const char*> columns, bool required) const {
    const std::string where = "table " + table;
    Stmt st = prepare("SELECT type, sql FROM sqlite_master WHERE name = ?1 COLLATE NOCASE", where);
    sqlite3_bind_text(st.get(), 1, table.c_str(), -1, SQLITE_TRANSIENT);
    if (!step(st.get(), where)) {
      if (!required) return false;
      fail("", "no table " + table + ": not a rosbag2 .db3 file (rosbag2 writes the tables topics and messages)");
    }
    const std::string type = column_text(st.get(), 0);
    const std::string sql = column_text(st.get(), 1);
    if (type != "table")
      fail("",
           table + " is " + (type == "view" ? "a view" : "an " + in_quotes(type)) + ", not a table: not a file rosbag2 wrote");
    if (starts_with(lower(sql.substr(0, 32)), "create virtual"))
      fail("", table + " is a virtual table (" + in_quotes(sql.substr(0, 60)) + "): not a file rosbag2 wrote");

    struct Column {
      bool plain;
      std::string why;
    };
    std::map<std::string, Column> found;
    Stmt cols = prepare("SELECT name, dflt_value, hidden FROM pragma_table_xinfo(?1)", where);
    sqlite3_bind_text(cols.get(), 1, table.c_str(), -1, SQLITE_TRANSIENT);
    while (step(cols.get(), where)) {
      const std::string name = lower(column_text(cols.get(), 0));
      const bool has_default = sqlite3_column_type(cols.get(), 1) != SQLITE_NULL;
      const std::string dflt = column_text(cols.get(), 1);
      const int hidden = sqlite3_column_int(cols.get(), 2);
      if (hidden != 0)
        found[name] = {false, "is computed (a generated or hidden column)"};
      else if (has_default && !plain_default(dflt))
        found[name] = {false, "has a computed default (" + in_quotes(dflt.substr(0, 60)) + ")"};
      else
        found[name] = {true, ""};
    }
    for (const char* c : columns) {
      const auto it = found.find(c);
      if (it == found.end()) fail("", "table " + table + " has no column " + c + ": not a table rosbag2 writes");
      if (!it->second.plain) fail("", "table " + table + ": column " + c + " " + it->second.why + ": not a table rosbag2 writes");
    }
    // A column named rowid would stand in for the row ids that messages are found by.
    if (table == "messages" && found.count("rowid"))
      fail("", "table messages has a column named rowid: not a table rosbag2 writes");
    return true;
  }

  // The statement that fetches one message: kept, as read() calls it for every message.
  sqlite3_stmt* read_statement() {
    if (!read_) read_ = prepare("SELECT typeof(data), data FROM messages WHERE rowid = ?1", "table messages");
    return read_.get();
  }

 private:
  std::string name_;
  std::string memory_;  // a decompressed file's bytes, which SQLite reads in place: outlives db_
  std::unique_ptr<sqlite3, CloseDb> db_;
  Stmt read_;  // finalized before db_ is closed
};

// The settings of a rosbag2 metadata.yaml (or of a .db3 file's metadata table) that this reader
// needs.
class Ros2Reader : public Reader {
 public:
  // `files`: the bag's files in order (one when a .db3 file is given alone: `single`).
  Ros2Reader(const std::string& path, std::vector<std::string> files, bool zstd_messages, bool single)
      : zstd_messages_(zstd_messages), zstd_(ZSTD_createDCtx()) {
    if (!zstd_) throw std::bad_alloc();
    path_ = path;
    for (auto& f : files) files_.push_back({std::move(f), nullptr, 0});
    std::map<std::string, std::uint32_t> topic_index;  // name '\0' type -> index into topics_
    std::size_t definition_bytes = 0;
    for (std::size_t i = 0; i < files_.size(); ++i) list(i, single, topic_index, definition_bytes);
    // By time; equal times in file order, then row order (rosbag2's order of arrival).
    std::sort(messages_.begin(), messages_.end(), [](const MessageRef& a, const MessageRef& b) {
      if (a.time_ns != b.time_ns) return a.time_ns < b.time_ns;
      if (a.where != b.where) return a.where < b.where;
      return static_cast<std::int64_t>(a.offset) < static_cast<std::int64_t>(b.offset);
    });
  }

  const char* format() const override { return "ROS 2 bag"; }

  // The message's data. In a bag whose messages are compressed one by one, MessageRef::size is the
  // compressed size (the size is known only once the message is decompressed), so the view may be
  // larger than it says.
  std::string_view read(const MessageRef& m) override {
    if (pending_) {  // the previous view is given up now
      sqlite3_reset(pending_);
      pending_ = nullptr;
    }
    if (m.where >= files_.size())
      throw Error(path_ + ": a message of file " + std::to_string(m.where) + " of " + std::to_string(files_.size()) +
                  ": not a message this reader listed");
    Db& db = open(static_cast<std::size_t>(m.where));
    const auto row = static_cast<std::int64_t>(m.offset);
    const std::string where = "table messages, row " + std::to_string(row);
    sqlite3_stmt* st = db.read_statement();
    sqlite3_bind_int64(st, 1, row);
    pending_ = st;
    if (!db.step(st, where)) db.fail(where, "the row is gone (the file changed after the bag was opened): open the bag again");
    const std::string type = column_text(st, 0);
    if (type != "blob" && type != "null")
      db.fail(where, "the data is " + type + ", not a blob (the file changed after the bag was opened)");
    const void* p = sqlite3_column_blob(st, 1);
    const auto n = static_cast<std::size_t>(sqlite3_column_bytes(st, 1));
    if (!p && n > 0) db.fail_sqlite(where, SQLITE_NOMEM);
    if (n != m.size)
      db.fail(where, "the data is " + std::to_string(n) + " bytes, " + std::to_string(m.size) +
                         " when the bag was opened (the file changed since): open the bag again");
    const std::string_view data(static_cast<const char*>(p), n);
    if (!zstd_messages_) return data;
    buffer_ = unzstd(zstd_.get(), data, kMaxMessageBytes, db.name() + ": " + where + ": ");
    sqlite3_reset(st);
    pending_ = nullptr;
    return buffer_;
  }

 private:
  struct File {
    std::string path;
    std::unique_ptr<Db> db;
    std::uint64_t last_use;
  };
  struct FreeZstd {
    void operator()(ZSTD_DCtx* z) const { ZSTD_freeDCtx(z); }
  };

  Db& open(std::size_t i) {
    File& f = files_[i];
    f.last_use = ++clock_;
    if (f.db) return *f.db;
    std::size_t open_files = 0;
    File* oldest = nullptr;
    for (File& g : files_) {
      if (!g.db) continue;
      ++open_files;
      if (!oldest || g.last_use < oldest->last_use) oldest = &g;
    }
    if (open_files >= kMaxOpenFiles && oldest) oldest->db.reset();
    f.db = std::make_unique<Db>(f.path, zstd_.get());
    return *f.db;
  }

  // Lists file i's topics (added to topics_, merged with those of earlier files by name and type)
  // and messages.
  void list(std::size_t i, bool single, std::map<std::string, std::uint32_t>& topic_index, std::size_t& definition_bytes) {
    Db& db = open(i);

    std::unordered_map<std::int64_t, std::uint32_t> ids;  // topics.id -> index into topics_
    std::multimap<std::string, std::uint32_t> by_type;    // the file's own type name -> index
    {
      const std::string where = "table topics";
      Stmt st = db.prepare("SELECT id, name, type, serialization_format FROM topics", where);
      while (db.step(st.get(), where)) {
        const std::int64_t id = sqlite3_column_int64(st.get(), 0);
        const std::string name = column_text(st.get(), 1);
        const std::string raw_type = column_text(st.get(), 2);
        const std::string format = column_text(st.get(), 3);
        // Only CDR is decoded; a topic in another serialization keeps its type behind the format's
        // name, so that no decoder takes it for its own. An empty format is CDR: older writers left
        // the default unnamed (tier4/nebula's VLS-128 capture).
        std::string type = ros1_style_type(raw_type);
        if (format != "cdr" && !format.empty()) type = format + ":" + type;
        const auto [it, fresh] = topic_index.emplace(name + '\0' + type, static_cast<std::uint32_t>(topics_.size()));
        if (fresh) topics_.push_back({name, type, Encoding::Cdr, {}, 0});
        if (!ids.emplace(id, it->second).second)
          db.fail(where, "topic id " + std::to_string(id) + " appears twice (the file is damaged or was not written by rosbag2)");
        by_type.emplace(raw_type, it->second);
      }
    }

    // The message definitions (bags of ROS 2 Iron and later), given to the topics of their type.
    if (db.check_table("message_definitions", {"topic_type", "encoding", "encoded_message_definition"}, false)) {
      const std::string where = "table message_definitions";
      Stmt st = db.prepare("SELECT topic_type, encoding, encoded_message_definition FROM message_definitions", where);
      while (db.step(st.get(), where)) {
        const std::string type = column_text(st.get(), 0);
        const std::string encoding = column_text(st.get(), 1);
        if (encoding == "unknown") continue;  // rosbag2 found no definition when it recorded
        const auto range = by_type.equal_range(type);
        for (auto it = range.first; it != range.second; ++it) {
          std::string& definition = topics_[it->second].definition;
          const auto n = static_cast<std::size_t>(sqlite3_column_bytes(st.get(), 2));
          if (!definition.empty() || n == 0 || definition_bytes + n > kMaxDefinitionBytes) continue;
          definition = column_text(st.get(), 2);
          definition_bytes += n;
        }
      }
    }

    // A .db3 file given alone says itself (ROS 2 Humble and later) whether its messages are
    // compressed, in the metadata it keeps; in a folder, metadata.yaml says so.
    if (single && db.check_table("metadata", {"metadata"}, false)) {
      const std::string where = "table metadata";
      Stmt st = db.prepare("SELECT rowid, metadata FROM metadata ORDER BY rowid DESC LIMIT 1", where);
      if (db.step(st.get(), where)) {
        const std::string name = db.name() + ": " + where + ", row " + std::to_string(sqlite3_column_int64(st.get(), 0));
        const Metadata md = parse_metadata(column_text(st.get(), 1), name, false);
        zstd_messages_ = md.zstd_messages;
      }
    }

    const std::string table = "table messages";
    // In rowid order, as a sound table gives its rows: rows that come out of order or twice are a
    // damaged b-tree (a page referenced twice), refused rather than listed twice.
    Stmt st = db.prepare("SELECT rowid, topic_id, timestamp, typeof(data), length(data) FROM messages ORDER BY rowid", table);
    std::int64_t last = 0;
    bool any = false;
    for (;;) {
      const int rc = sqlite3_step(st.get());
      if (rc == SQLITE_DONE) break;
      if (rc != SQLITE_ROW) db.fail_sqlite(any ? table + ", after row " + std::to_string(last) : table, rc);
      const std::int64_t row = sqlite3_column_int64(st.get(), 0);
      if (any && row <= last)
        db.fail(table + ", row " + std::to_string(row),
                "comes after row " + std::to_string(last) +
                    " (rows out of order or repeated: the file is damaged; copy it again from the recorder, or salvage what "
                    "is left with sqlite3's .recover)");
      last = row;
      any = true;
      const std::int64_t topic_id = sqlite3_column_int64(st.get(), 1);
      const auto topic = ids.find(topic_id);
      if (topic == ids.end())
        db.fail(table + ", row " + std::to_string(row),
                "topic_id " + std::to_string(topic_id) + " is not in table topics (the file is damaged or was edited)");
      const char* type = reinterpret_cast<const char*>(sqlite3_column_text(st.get(), 3));
      const std::string_view kind = type ? type : "";
      if (kind != "blob" && kind != "null")
        db.fail(table + ", row " + std::to_string(row),
                "the data is " + std::string(kind) + ", not a blob (not written by rosbag2)");
      MessageRef m;
      m.topic = topic->second;
      m.time_ns = sqlite3_column_int64(st.get(), 2);
      m.where = i;
      m.offset = static_cast<std::uint64_t>(row);
      m.size = static_cast<std::uint64_t>(std::max<sqlite3_int64>(0, sqlite3_column_int64(st.get(), 4)));
      messages_.push_back(m);
      ++topics_[m.topic].count;
    }
  }

  std::vector<File> files_;
  bool zstd_messages_;
  std::unique_ptr<ZSTD_DCtx, FreeZstd> zstd_;
  std::uint64_t clock_ = 0;
  sqlite3_stmt* pending_ = nullptr;  // the statement whose row the last view points into
  std::string buffer_;               // the last decompressed message
};

// The file a metadata.yaml entry names, in the bag folder. Bags before metadata version 4 name
// their files with the folder's name in front ("bag/bag_0.db3"), and a folder may have been
// renamed since: a name whose path does not lead to a file is looked for beside metadata.yaml.
// Nothing outside the folder is read.
std::string resolve_file(const fs::path& folder, const std::string& entry, const std::string& metadata) {
  if (entry.find('\0') != std::string::npos)
    throw Error(metadata + ": lists a file name with a NUL byte in it (" + in_quotes(entry) + ")");
  const fs::path p(entry);
  std::error_code ec;
  bool inside = p.is_relative() && !entry.empty();
  for (const auto& part : p)
    if (part == "..") inside = false;
  if (inside && fs::exists(folder / p, ec)) return (folder / p).string();
  const fs::path leaf = p.filename();
  if (!leaf.empty() && leaf != "." && leaf != ".." && fs::exists(folder / leaf, ec)) return (folder / leaf).string();
  throw Error(metadata + ": lists the file " + in_quotes(entry) + ", which is missing (looked for " +
              (folder / (inside ? p : leaf)).string() + "): copy the whole bag folder");
}

std::unique_ptr<Reader> open_folder(const std::string& path) {
  const fs::path folder(path);
  const std::string metadata = (folder / "metadata.yaml").string();
  std::error_code ec;
  if (!fs::exists(metadata, ec))
    throw Error(path +
                ": no metadata.yaml, so not a ROS 2 bag folder: give one of its .db3 files, or write metadata.yaml again with "
                "`ros2 bag reindex " +
                path + "`");
  require_regular_file(metadata, " (metadata.yaml must be the bag's metadata file)");
  const auto size = fs::file_size(metadata, ec);
  if (!ec && size > kMaxMetadataBytes)
    throw Error(metadata + ": " + std::to_string(size) + " bytes, far more than rosbag2 writes: not a rosbag2 metadata.yaml");
  const auto src = map_file(metadata);
  const Metadata md = parse_metadata(std::string(src->bytes()), metadata, true);
  if (md.storage == "mcap") {
    const std::string hint = md.files.empty() ? "" : " (" + (folder / fs::path(md.files[0]).filename()).string() + ")";
    throw Error(metadata + ": this bag stores MCAP files: give the .mcap file itself" + hint);
  }
  if (!md.storage.empty() && md.storage != "sqlite3")
    throw Error(metadata + ": storage_identifier " + in_quotes(md.storage) +
                " is not supported (only sqlite3 .db3 files, and .mcap files given themselves)");
  std::vector<std::string> files;
  for (const std::string& entry : md.files) {
    std::string file = resolve_file(folder, entry, metadata);
    const std::string normal = fs::path(file).lexically_normal().string();
    for (const std::string& seen : files)
      if (fs::path(seen).lexically_normal().string() == normal)
        throw Error(metadata + ": lists the file " + in_quotes(entry) + " twice");
    files.push_back(std::move(file));
  }
  return std::make_unique<Ros2Reader>(path, std::move(files), md.zstd_messages, false);
}

}  // namespace

std::unique_ptr<Reader> open_ros2(const std::string& path) {
  std::error_code ec;
  if (fs::is_directory(path, ec)) return open_folder(path);
  require_regular_file(path, " (give a ROS 2 bag folder or one of its .db3 files)");
  return std::make_unique<Ros2Reader>(path, std::vector<std::string>{path}, false, true);
}

}  // namespace pl::bag
