// Fuzz target: the bytes are the vehicle's disk cache file (a power cut, a failing card, a file
// put there by someone else), opened and used as the tile client uses it. Refusing with a
// pl::Error is fine; what must hold (else abort):
// - blob() returns only bytes whose SHA-256 is the hash asked for;
// - rows and manifests keep the promises of tile_cache.hpp (hashes of 64 hex digits or none,
//   positive finite tile sizes, finite origins);
// - refusing to open leaves the file as it was (at most the header fields of the switch to WAL);
// - what put_blob, put_tiles and put_manifest stored is read back as it was stored.
#include <sqlite3.h>
#include <unistd.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <optional>
#include <string>
#include <vector>

#include "pl/client/tile_cache.hpp"
#include "pl/common/error.hpp"
#include "pl/schema/store.hpp"

namespace fs = std::filesystem;
using pl::client::CachedManifest;
using pl::client::CachedTile;
using pl::client::TileCache;

namespace {

std::string* work_dir_path = nullptr;  // removed before an abort: abort() runs no destructors

[[noreturn]] void finding(const std::string& what) {
  std::fprintf(stderr, "FINDING: %s\n", what.c_str());
  std::error_code ec;
  if (work_dir_path) fs::remove_all(*work_dir_path, ec);
  std::abort();
}

// A wrong answer that damage only SQLite's full check finds could explain (see sqlite_finds_damage):
// a finding unless the input passes that check.
std::string suspicion;
void suspect(const std::string& what) {
  if (suspicion.empty()) suspicion = what;
}

// A private folder per process (in memory when /dev/shm exists), removed at exit.
class WorkDir {
 public:
  WorkDir() {
    std::string base = fs::exists("/dev/shm") ? "/dev/shm" : fs::temp_directory_path().string();
    std::string tmpl = base + "/pl-fuzz-cache-XXXXXX";
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

// The input as a cache file at a fresh path; removes it and SQLite's side files when done.
class InputFile {
 public:
  InputFile(const std::string& dir, const std::string& bytes) {
    static long run = 0;
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
bool sqlite_finds_damage(const std::string& dir, const std::string& input) {
  const std::string path = dir + "/check.sqlite";
  {
    std::ofstream out(path, std::ios::binary);
    out.write(input.data(), static_cast<std::streamsize>(input.size()));
  }
  sqlite3* db = nullptr;
  bool damaged = sqlite3_open(path.c_str(), &db) != SQLITE_OK;
  for (const char* check : {"PRAGMA integrity_check"}) {
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

template <typename F>
void attempt(F&& f) {
  try {
    f();
  } catch (const pl::Error&) {
  }
}

// Equal but for the header fields that SQLite's switch to WAL rewrites.
bool same_but_wal_switch(const std::string& a, const std::string& b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i) {
    bool header_field = (i >= 18 && i < 20) || (i >= 24 && i < 32) || (i >= 92 && i < 100);
    if (a[i] != b[i] && !header_field) return false;
  }
  return true;
}

bool is_hash(const std::string& s) {
  if (s.size() != 64) return false;
  for (char c : s)
    if (!((c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'))) return false;
  return true;
}

void check_manifest(const std::optional<CachedManifest>& m) {
  if (!m) return;
  if (!(m->tile_size > 0) || !std::isfinite(m->tile_size) || !std::isfinite(m->voxel_size))
    finding("a manifest whose tile size is not a positive number");
  if (!std::isfinite(m->origin.lat_deg) || !std::isfinite(m->origin.lon_deg) || !std::isfinite(m->origin.alt_m))
    finding("a manifest whose origin is not finite");
}

void check_blob(TileCache& c, const std::string& hash) {
  attempt([&] {
    c.has_blob(hash);
    bool corrupt = false;
    auto bytes = c.blob(hash, &corrupt);
    if (bytes && pl::store::content_hash(*bytes) != hash) finding("blob() returned bytes that do not hash to their hash");
    if (bytes && corrupt) finding("blob() returned bytes and said they were corrupt");
  });
}

// What the tile client reads: manifests (pinned and last used), key rows, blobs.
void read(TileCache& c, const std::string& known_hash) {
  for (const char* map : {"town", "depot"}) {
    attempt([&] { check_manifest(c.last_used(map)); });
    for (long long v : {1, 2, 7}) attempt([&] { check_manifest(c.manifest(map, v)); });
    for (long long v : {1, 2}) {
      std::vector<CachedTile> rows;
      attempt([&] { rows = c.tiles(map, v); });
      std::size_t n = 0;
      for (const auto& t : rows) {
        if (t.exists() && !is_hash(t.hash)) finding("a key row whose hash is not 64 lowercase hex digits");
        if (t.exists() && ++n <= 4) check_blob(c, t.hash);
      }
    }
  }
  check_blob(c, known_hash);
  attempt([&] { c.blob_count(); });
}

// What the tile client writes, read back.
void write(TileCache& c) {
  const std::string bytes = "fresh tile bytes from the server";
  const std::string hash = pl::store::content_hash(bytes);
  attempt([&] {
    c.put_blob(hash, bytes);
    bool corrupt = false;
    auto back = c.blob(hash, &corrupt);
    if (!back || *back != bytes) suspect("put_blob's bytes are not read back");
  });
  attempt([&] {
    c.put_tiles("town", 3, {{{5, -6}, hash, 42}, {{-7, 8}, "", 0}});
    bool five = false, seven = false;
    for (const auto& t : c.tiles("town", 3)) {
      five |= t.key == pl::TileKey{5, -6} && t.hash == hash && t.points == 42;
      seven |= t.key == pl::TileKey{-7, 8} && !t.exists();
    }
    if (!five || !seven) suspect("put_tiles' rows are not read back");
  });
  attempt([&] {
    c.put_manifest({"town", 3, 20.0, 0.2, pl::GeoPoint{49.0, 8.4, 110.0}});
    auto last = c.last_used("town");
    if (!last || last->version != 3 || last->tile_size != 20.0) suspect("put_manifest's manifest is not the last used");
  });
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static WorkDir work;
  static const std::string known_hash = pl::store::content_hash("cached tile 0/0 of town v1");
  const std::string input(reinterpret_cast<const char*>(data), size);
  InputFile file(work.dir(), input);
  suspicion.clear();
  bool opened = false;
  attempt([&] {
    TileCache cache(file.path());
    opened = true;
    read(cache, known_hash);
    write(cache);
  });
  if (!opened && !same_but_wal_switch(input, file.bytes())) finding("a refused open changed the file");
  if (!suspicion.empty() && !sqlite_finds_damage(work.dir(), input)) finding(suspicion);
  return 0;
}
