#include "blob_files.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <filesystem>

namespace pl::server {

BlobFiles::BlobFiles() {
  std::string tmpl = (std::filesystem::temp_directory_path() / "pl-server-tiles-XXXXXX").string();
  fd_ = mkostemp(tmpl.data(), O_CLOEXEC);
  if (fd_ >= 0) ::unlink(tmpl.c_str());
}

BlobFiles::~BlobFiles() {
  if (fd_ >= 0) ::close(fd_);
}

std::optional<BlobFiles::Span> BlobFiles::span_of(const std::string& hash, const std::string& bytes) {
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = offsets_.find(hash);
  if (it != offsets_.end()) return Span{fd_, it->second};
  // Each tile starts on a page: sendfile(2) then moves it in as few pages as it fills.
  const std::uint64_t start = (end_ + kPage - 1) / kPage * kPage;
  if (fd_ < 0 || start + bytes.size() > kMaxBytes) return std::nullopt;
  const auto at = static_cast<off_t>(start);
  for (std::size_t done = 0; done < bytes.size();) {
    const ssize_t n = ::pwrite(fd_, bytes.data() + done, bytes.size() - done, at + static_cast<off_t>(done));
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return std::nullopt;  // a full disk: from memory, and the next tile tries again
    done += static_cast<std::size_t>(n);
  }
  end_ = start + bytes.size();
  offsets_.emplace(hash, at);
  return Span{fd_, at};
}

}  // namespace pl::server
