#include "pl/recordings/bag.hpp"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "pl/common/error.hpp"

namespace fs = std::filesystem;

namespace pl::bag {
namespace {

class Mapped : public Source {
 public:
  Mapped(const std::string& path, const void* data, std::size_t size) : Source(path), data_(data), size_(size) {}
  ~Mapped() override {
    if (size_) munmap(const_cast<void*>(data_), size_);
  }
  std::string_view bytes() const override { return {static_cast<const char*>(data_), size_}; }

 private:
  const void* data_;
  std::size_t size_;
};

class Held : public Source {
 public:
  Held(std::string bytes, const std::string& name) : Source(name), bytes_(std::move(bytes)) {}
  std::string_view bytes() const override { return bytes_; }

 private:
  std::string bytes_;
};

constexpr std::string_view kRos1Magic = "#ROSBAG V2.0\n";
constexpr std::string_view kMcapMagic = "\x89MCAP0\r\n";
constexpr std::string_view kSqliteMagic = std::string_view("SQLite format 3\0", 16);
constexpr std::string_view kZstdMagic = "\x28\xb5\x2f\xfd";

// A ROS 2 bag file compressed whole (rosbag2's FILE mode): NAME.db3.zstd.
bool is_compressed_db3(const std::string& path, std::string_view head) {
  const std::string suffix = ".db3.zstd";
  return path.size() > suffix.size() && path.compare(path.size() - suffix.size(), suffix.size(), suffix) == 0 && head.substr(0, 4) == kZstdMagic;
}

std::string first_bytes(const std::string& path, std::size_t n) {
  std::ifstream f(path, std::ios::binary);
  std::string s(n, '\0');
  f.read(s.data(), static_cast<std::streamsize>(n));
  s.resize(static_cast<std::size_t>(f.gcount()));
  return s;
}

bool starts_with(std::string_view s, std::string_view p) { return s.substr(0, p.size()) == p; }

}  // namespace

std::shared_ptr<const Source> map_file(const std::string& path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) throw Error(path + ": cannot open: " + std::strerror(errno));
  struct stat st {};
  if (fstat(fd, &st) != 0) {
    const int e = errno;
    ::close(fd);
    throw Error(path + ": cannot read its size: " + std::strerror(e));
  }
  if (!S_ISREG(st.st_mode)) {
    ::close(fd);
    throw Error(path + ": not a regular file");
  }
  const std::size_t size = static_cast<std::size_t>(st.st_size);
  void* data = nullptr;
  if (size > 0) {
    data = mmap(nullptr, size, PROT_READ, MAP_PRIVATE, fd, 0);
    if (data == MAP_FAILED) {
      const int e = errno;
      ::close(fd);
      throw Error(path + ": cannot map it into memory: " + std::strerror(e));
    }
    madvise(data, size, MADV_SEQUENTIAL);
  }
  ::close(fd);
  return std::make_shared<Mapped>(path, data, size);
}

std::shared_ptr<const Source> hold_bytes(std::string bytes, const std::string& name) {
  return std::make_shared<Held>(std::move(bytes), name);
}

bool is_recording(const std::string& path) {
  std::error_code ec;
  if (fs::is_directory(path, ec)) return fs::exists(fs::path(path) / "metadata.yaml", ec);
  const std::string head = first_bytes(path, 16);
  return starts_with(head, kRos1Magic) || starts_with(head, kMcapMagic) || starts_with(head, kSqliteMagic) || is_compressed_db3(path, head);
}

std::unique_ptr<Reader> open(const std::string& path) {
  std::error_code ec;
  if (fs::is_directory(path, ec)) {
    if (!fs::exists(fs::path(path) / "metadata.yaml", ec))
      throw Error(path + ": a folder without metadata.yaml is not a ROS 2 bag (give the bag's folder, or a .bag, .mcap or .db3 file)");
    return open_ros2(path);
  }
  if (!fs::exists(path, ec)) throw Error(path + ": no such file");
  const std::string head = first_bytes(path, 16);
  if (starts_with(head, kRos1Magic)) return open_ros1(map_file(path));
  if (starts_with(head, kMcapMagic)) return open_mcap(map_file(path));
  if (starts_with(head, kSqliteMagic) || is_compressed_db3(path, head)) return open_ros2(path);
  if (starts_with(head, "#ROSBAG V1"))
    throw Error(path + ": a ROS bag of format 1.x: convert it with `rosbag fix` (or `rosbag reindex`) to format 2.0");
  throw Error(path + ": not a recording: expected a ROS 1 bag (\"#ROSBAG V2.0\"), an MCAP file or a ROS 2 .db3 file");
}

}  // namespace pl::bag
