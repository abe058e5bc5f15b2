// What the SQLite file fuzz targets (store, tile_cache) share: a private folder, the input as a
// database file at a fresh path, SQLite's own full check of it, and how a finding is reported.
#pragma once

#include <sqlite3.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

namespace pl::fuzz {

namespace fs = std::filesystem;

inline std::string* work_dir_path = nullptr;  // removed before an abort: abort() runs no destructors

[[noreturn]] inline void finding(const std::string& what) {
  std::fprintf(stderr, "FINDING: %s\n", what.c_str());
  std::error_code ec;
  if (work_dir_path) fs::remove_all(*work_dir_path, ec);
  std::abort();
}

// A wrong answer that damage only SQLite's full check finds could explain (see sqlite_finds_damage):
// a finding unless the input passes that check.
inline std::string suspicion;
inline void suspect(const std::string& what) {
  if (suspicion.empty()) suspicion = what;
}

// A private folder per process (in memory when /dev/shm exists), removed at exit.
class WorkDir {
 public:
  explicit WorkDir(const std::string& name) {
    std::string base = fs::exists("/dev/shm") ? "/dev/shm" : fs::temp_directory_path().string();
    std::string tmpl = base + "/pl-fuzz-" + name + "-XXXXXX";
    if (!mkdtemp(tmpl.data())) finding("cannot make a temporary folder in " + base);
    dir_ = tmpl;
    work_dir_path = &dir_;
  }
  ~WorkDir() {
    work_dir_path = nullptr;
    std::error_code ec;
    fs::remove_all(dir_, ec);
  }
  const std::string& dir() const { return dir_; }

 private:
  std::string dir_;
};

// The input as an SQLite file at a fresh path; removes it and SQLite's side files when done.
class InputFile {
 public:
  InputFile(const std::string& dir, const std::string& bytes) {
    static long run = 0;  // (one per process: the targets run one input at a time)
    path_ = dir + "/run-" + std::to_string(++run) + ".sqlite";
    std::ofstream out(path_, std::ios::binary);
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    if (!out) finding("cannot write " + path_);
  }
  ~InputFile() {
    std::error_code ec;
    for (const char* suffix : {"", "-wal", "-shm", "-journal"}) fs::remove(path_ + suffix, ec);
  }
  const std::string& path() const { return path_; }
  std::string bytes() const {
    std::ifstream in(path_, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }

 private:
  std::string path_;
};

// Whether SQLite's own full check (on a copy of the input) finds the file damaged. SQLite reports
// damage where it reads it, but some damage (keys out of order, an index that disagrees with its
// table) it only finds in a full check, which no open can afford on a large file; with such damage a
// read may go wrong without an error, and that is not held against the code under test.
inline bool sqlite_finds_damage(const std::string& dir, const std::string& input, const std::vector<const char*>& checks) {
  const std::string path = dir + "/check.sqlite";
  {
    std::ofstream out(path, std::ios::binary);
    out.write(input.data(), static_cast<std::streamsize>(input.size()));
  }
  sqlite3* db = nullptr;
  bool damaged = sqlite3_open(path.c_str(), &db) != SQLITE_OK;
  for (const char* check : checks) {
    sqlite3_stmt* st = nullptr;
    if (!damaged && sqlite3_prepare_v2(db, check, -1, &st, nullptr) == SQLITE_OK && sqlite3_step(st) == SQLITE_ROW) {
      const unsigned char* answer = sqlite3_column_text(st, 0);
      damaged = !answer || std::string(reinterpret_cast<const char*>(answer)) != "ok";
    } else {
      damaged = true;
    }
    sqlite3_finalize(st);
  }
  sqlite3_close(db);
  std::error_code ec;
  for (const char* suffix : {"", "-wal", "-shm", "-journal"}) fs::remove(path + suffix, ec);
  return damaged;
}

// Equal but for the header fields that SQLite's switch to WAL rewrites (read/write versions, change
// counter, size in pages, version-valid-for, SQLite version number): a refused open may do that much.
inline bool same_but_wal_switch(const std::string& a, const std::string& b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i) {
    const bool header_field = (i >= 18 && i < 20) || (i >= 24 && i < 32) || (i >= 92 && i < 100);
    if (a[i] != b[i] && !header_field) return false;
  }
  return true;
}

}  // namespace pl::fuzz
