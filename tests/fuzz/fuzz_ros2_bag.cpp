// Fuzz target: a ROS 2 bag from anywhere (a damaged disk, a torn copy, a file crafted by someone
// else), opened with open_ros2 and every listed message read. The first byte says what the rest is:
// - even: a .db3 file, given alone (SQLite reads files, so the bytes are written to one first);
// - odd: the text of a bag folder's metadata.yaml, beside valid files made once per process (plain
//   .db3 files, one in WAL mode, one compressed whole with zstd, one whose messages are compressed
//   one by one).
// Refusing with pl::Error is the reader's job; what comes back must be consistent (else abort):
// - topic indexes in range, each topic's count its number of messages, the messages in time order
//   (equal times in file order, then row order);
// - a .db3 file's message is the row's data as SQLite itself gives it on a connection of its own, or
//   (when the bag says its messages are compressed) that data's zstd decompression; when it is the
//   data itself, the view has the ref's size;
// - the folder's files are known, so each message read there must be the one its file and row hold.
// A wrong answer that only damage SQLite's full check finds could explain is not held against the
// reader (sqlite_input.hpp).
#include <sqlite3.h>
#include <zstd.h>

#include <charconv>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>
#include <vector>

#include "pl/common/error.hpp"
#include "pl/recordings/bag.hpp"
#include "sqlite_input.hpp"

namespace fs = std::filesystem;

namespace {

using pl::fuzz::finding;
using pl::fuzz::InputFile;
using pl::fuzz::suspect;
using pl::fuzz::suspicion;
using pl::fuzz::WorkDir;

constexpr std::string_view kZstdMagic("\x28\xB5\x2F\xFD", 4);

WorkDir& work() {
  static WorkDir dir("ros2_bag");
  return dir;
}

void sql(sqlite3* db, const std::string& text) {
  if (sqlite3_exec(db, text.c_str(), nullptr, nullptr, nullptr) != SQLITE_OK) finding("cannot write a fixed file: " + text);
}

// The message the folder's files hold in row `row` of the file tagged `tag`: its tag, row and time
// in words, then filler of a length that differs from row to row.
std::string known_message(char tag, std::int64_t row, std::int64_t time) {
  std::string s = "pl-fuzz ";
  s += tag;
  s += " " + std::to_string(row) + " " + std::to_string(time) + " ";
  return s + std::string(static_cast<std::size_t>(row * 37 % 300), 'x');
}

// Whether `v` is a known_message; its tag, row and time when so.
bool parse_known(std::string_view v, char& tag, std::int64_t& row, std::int64_t& time) {
  if (v.substr(0, 8) != "pl-fuzz " || v.size() < 10) return false;
  tag = v[8];
  const char* p = v.data() + 10;
  const char* end = v.data() + v.size();
  auto r = std::from_chars(p, end, row);
  if (r.ec != std::errc() || r.ptr == end || *r.ptr != ' ') return false;
  r = std::from_chars(r.ptr + 1, end, time);
  if (r.ec != std::errc() || r.ptr == end || *r.ptr != ' ') return false;
  return v == known_message(tag, row, time);
}

std::string zstd(const std::string& raw) {
  std::string out(ZSTD_compressBound(raw.size()), '\0');
  const std::size_t n = ZSTD_compress(out.data(), out.size(), raw.data(), raw.size(), 1);
  if (ZSTD_isError(n)) finding("zstd refuses to compress");
  out.resize(n);
  return out;
}

std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

// A .db3 file as rosbag2 writes it, its messages known_message()s (zstd-compressed when `compress`).
void write_fixed(const std::string& path, char tag, bool wal, bool compress, std::int64_t first_id) {
  sqlite3* db = nullptr;
  if (sqlite3_open(path.c_str(), &db) != SQLITE_OK) finding("cannot write " + path);
  sql(db, wal ? "PRAGMA journal_mode=WAL" : "PRAGMA journal_mode=MEMORY");
  sql(db,
      "CREATE TABLE schema(schema_version INTEGER PRIMARY KEY,ros_distro TEXT NOT NULL);"
      "CREATE TABLE metadata(id INTEGER PRIMARY KEY,metadata_version INTEGER NOT NULL,metadata TEXT NOT NULL);"
      "CREATE TABLE topics(id INTEGER PRIMARY KEY,name TEXT NOT NULL,type TEXT NOT NULL,serialization_format TEXT NOT NULL,"
      "offered_qos_profiles TEXT NOT NULL);"
      "CREATE TABLE messages(id INTEGER PRIMARY KEY,topic_id INTEGER NOT NULL,timestamp INTEGER NOT NULL, data BLOB NOT NULL);"
      "CREATE INDEX timestamp_idx ON messages (timestamp ASC);"
      "INSERT INTO schema VALUES (3, 'humble');");
  const std::string a = std::to_string(first_id), b = std::to_string(first_id + 1);
  sql(db, "INSERT INTO topics VALUES (" + a + ", '/points', 'sensor_msgs/msg/PointCloud2', 'cdr', '')");
  sql(db, "INSERT INTO topics VALUES (" + b + ", '/status', 'std_msgs/msg/String', 'json', '')");
  sqlite3_stmt* st = nullptr;
  sqlite3_prepare_v2(db, "INSERT INTO messages (id, timestamp, topic_id, data) VALUES (?, ?, ?, ?)", -1, &st, nullptr);
  for (std::int64_t row = 1; row <= 8; ++row) {
    const std::int64_t time = (row * 7919 + tag) % 50;  // out of order, with equal times
    std::string data = known_message(tag, row, time);
    if (compress) data = zstd(data);
    sqlite3_bind_int64(st, 1, row);
    sqlite3_bind_int64(st, 2, time);
    sqlite3_bind_int64(st, 3, row % 3 ? first_id : first_id + 1);
    sqlite3_bind_blob(st, 4, data.data(), static_cast<int>(data.size()), SQLITE_TRANSIENT);
    if (sqlite3_step(st) != SQLITE_DONE) finding("cannot write a fixed message");
    sqlite3_reset(st);
  }
  sqlite3_finalize(st);
  sqlite3_close(db);
}

// The bag folder with its files, made once: p0.db3, p1.db3 (WAL mode), f0.db3.zstd (a .db3 file
// compressed whole) and m0.db3 (each message compressed).
const std::string& bag_folder() {
  static const std::string folder = [] {
    const std::string f = work().dir() + "/bag";
    fs::create_directories(f);
    write_fixed(f + "/p0.db3", 'p', false, false, 1);
    write_fixed(f + "/p1.db3", 'q', true, false, 5);
    write_fixed(work().dir() + "/f0.db3", 'f', false, false, 3);
    std::ofstream(f + "/f0.db3.zstd", std::ios::binary) << zstd(slurp(work().dir() + "/f0.db3"));
    write_fixed(f + "/m0.db3", 'm', false, true, 2);
    return f;
  }();
  return folder;
}

// The zstd decompression of `data` if it is exactly `expected`.
bool decompresses_to(std::string_view data, std::string_view expected) {
  ZSTD_DCtx* z = ZSTD_createDCtx();
  std::string out(expected.size() + 1, '\0');  // room for one byte more than expected, to see it
  ZSTD_inBuffer in{data.data(), data.size(), 0};
  ZSTD_outBuffer o{out.data(), out.size(), 0};
  std::size_t r = 1;
  while (in.pos < in.size || r != 0) {
    const std::size_t before_in = in.pos, before_out = o.pos;
    r = ZSTD_decompressStream(z, &o, &in);
    if (ZSTD_isError(r) || (in.pos == before_in && o.pos == before_out)) break;
  }
  ZSTD_freeDCtx(z);
  return !ZSTD_isError(r) && r == 0 && in.pos == in.size && std::string_view(out.data(), o.pos) == expected;
}

// What must hold of any reader's listing.
void check_listing(const pl::bag::Reader& r) {
  std::vector<std::size_t> counts(r.topics().size(), 0);
  const pl::bag::MessageRef* prev = nullptr;
  for (const auto& m : r.messages()) {
    if (m.topic >= r.topics().size()) finding("a message's topic index is out of range");
    ++counts[m.topic];
    if (prev) {
      if (m.time_ns < prev->time_ns) finding("messages not in time order");
      if (m.time_ns == prev->time_ns &&
          (m.where < prev->where ||
           (m.where == prev->where && static_cast<std::int64_t>(m.offset) <= static_cast<std::int64_t>(prev->offset))))
        finding("messages of equal times not in file and row order");
    }
    prev = &m;
  }
  for (std::size_t i = 0; i < counts.size(); ++i)
    if (counts[i] != r.topics()[i].count) finding("a topic's count is not its number of messages");
}

// The data of row `row` of the messages table, as SQLite gives it to a connection of its own.
bool row_data(sqlite3* db, std::int64_t row, std::string& out) {
  sqlite3_stmt* st = nullptr;
  bool ok = sqlite3_prepare_v2(db, "SELECT data FROM messages WHERE rowid = ?", -1, &st, nullptr) == SQLITE_OK;
  if (ok) {
    sqlite3_bind_int64(st, 1, row);
    ok = sqlite3_step(st) == SQLITE_ROW;
    if (ok) {
      const void* p = sqlite3_column_blob(st, 0);
      out.assign(p ? static_cast<const char*>(p) : "", static_cast<std::size_t>(sqlite3_column_bytes(st, 0)));
    }
  }
  sqlite3_finalize(st);
  return ok;
}

void fuzz_db3(const std::string& bytes) {
  InputFile input(work().dir(), bytes);
  std::unique_ptr<pl::bag::Reader> r;
  try {
    r = pl::bag::open_ros2(input.path());
  } catch (const pl::Error&) {
    return;
  }
  check_listing(*r);
  // The second connection reads the same .db3 file (decompressed first when the input is a
  // .db3.zstd file).
  std::string oracle_path = input.path();
  if (bytes.substr(0, 4) == kZstdMagic) {
    const unsigned long long n = ZSTD_getFrameContentSize(bytes.data(), bytes.size());
    if (n == ZSTD_CONTENTSIZE_UNKNOWN || n == ZSTD_CONTENTSIZE_ERROR || n > (256u << 20)) return;
    std::string plain(static_cast<std::size_t>(n), '\0');
    const std::size_t got = ZSTD_decompress(plain.data(), plain.size(), bytes.data(), bytes.size());
    if (ZSTD_isError(got)) return;
    plain.resize(got);
    if (plain.size() >= 20 && plain[18] == 2 && plain[19] == 2) plain[18] = plain[19] = 1;  // as the reader reads it
    oracle_path = work().dir() + "/oracle.db3";
    std::ofstream(oracle_path, std::ios::binary | std::ios::trunc) << plain;
  }
  sqlite3* db = nullptr;
  if (sqlite3_open_v2(("file:" + oracle_path + "?immutable=1").c_str(), &db, SQLITE_OPEN_READONLY | SQLITE_OPEN_URI, nullptr) !=
      SQLITE_OK) {
    sqlite3_close(db);
    db = nullptr;
  }
  for (const auto& m : r->messages()) {
    std::string_view v;
    try {
      v = r->read(m);
    } catch (const pl::Error&) {
      continue;
    }
    if (m.where != 0) finding("a message of a .db3 file given alone is not in file 0");
    std::string data;
    if (!db || !row_data(db, static_cast<std::int64_t>(m.offset), data)) {
      suspect("read() gave a message SQLite does not find");
      continue;
    }
    if (v == data) {
      if (v.size() != m.size) finding("a view whose size differs from the message's size");
      continue;
    }
    if (data.size() == m.size && decompresses_to(data, v)) continue;  // a compressed message
    suspect("read() gave other bytes than SQLite has in the row");
  }
  sqlite3_close(db);
  if (!suspicion.empty() && !pl::fuzz::sqlite_finds_damage(work().dir(), bytes, {"PRAGMA integrity_check"})) finding(suspicion);
}

void fuzz_metadata(const std::string& text) {
  const std::string& folder = bag_folder();
  {
    std::ofstream out(folder + "/metadata.yaml", std::ios::binary | std::ios::trunc);
    out.write(text.data(), static_cast<std::streamsize>(text.size()));
    if (!out) finding("cannot write metadata.yaml");
  }
  std::unique_ptr<pl::bag::Reader> r;
  try {
    r = pl::bag::open_ros2(folder);
  } catch (const pl::Error&) {
    return;
  }
  check_listing(*r);
  for (const auto& m : r->messages()) {
    std::string_view v;
    try {
      v = r->read(m);
    } catch (const pl::Error&) {
      continue;  // m0.db3's messages read as plain, or the others' as compressed
    }
    char tag = 0;
    std::int64_t row = 0, time = 0;
    if (parse_known(v, tag, row, time)) {
      if (row != static_cast<std::int64_t>(m.offset) || time != m.time_ns) finding("a message read is not the one listed");
      if (tag != 'm' && v.size() != m.size) finding("a view whose size differs from the message's size");
    } else if (v.substr(0, 4) != kZstdMagic || v.size() != m.size) {  // else m0.db3's data read as plain
      finding("a message read is none of the folder's");
    }
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  suspicion.clear();
  const std::string rest(reinterpret_cast<const char*>(data) + 1, size - 1);
  if (data[0] & 1)
    fuzz_metadata(rest);
  else
    fuzz_db3(rest);
  return 0;
}
