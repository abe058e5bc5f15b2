#pragma once
// Private to pl_server.

#include <sys/types.h>

#include <cstdint>
#include <mutex>
#include <optional>
#include <string>
#include <unordered_map>

namespace pl::server {

// Tile bytes appended to one file, each found by its content hash at its offset, so that responses
// go out with sendfile(2) (no copy into the socket). Tiles never change, so bytes once written are
// valid for good. The file is unlinked as soon as it is made: the system frees it when the server
// stops, however it stops. One file rather than one a tile: creating tens of thousands of files
// cost more than serving them (79 % of the server's time in the file system's inode allocation,
// serving tiles not yet in memory from PostgreSQL). Bounded by kMaxBytes; past it, the caller
// sends the bytes from memory instead.
class BlobFiles {
 public:
  static constexpr std::uint64_t kMaxBytes = std::uint64_t{4} << 30, kPage = 4096;
  struct Span {
    int fd;
    off_t offset;
  };
  BlobFiles();
  ~BlobFiles();
  BlobFiles(const BlobFiles&) = delete;
  BlobFiles& operator=(const BlobFiles&) = delete;
  // Where the bytes are, written on first use; nothing when there is no file or no room (the caller
  // copies instead).
  std::optional<Span> span_of(const std::string& hash, const std::string& bytes);

 private:
  int fd_ = -1;
  std::uint64_t end_ = 0;
  std::mutex mutex_;
  std::unordered_map<std::string, off_t> offsets_;
};

}  // namespace pl::server
