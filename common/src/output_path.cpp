#include "pl/common/output_path.hpp"

#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>

#include "pl/common/error.hpp"

namespace pl {

void check_output_path(const std::string& path, const std::string& flag) {
  namespace fs = std::filesystem;
  if (path.empty()) throw Error(flag + ": the output path is empty");
  const fs::path p(path);
  const fs::path dir = p.has_parent_path() ? p.parent_path() : fs::path(".");
  std::error_code ec;
  if (!fs::is_directory(dir, ec))
    throw Error(flag + " " + path + ": the folder " + dir.string() + " does not exist (create it, or write somewhere else)");
  if (fs::is_directory(p, ec)) throw Error(flag + " " + path + ": is a folder; give a file name");
  const bool existed = fs::exists(p, ec);
  // Opening for append creates nothing new when the file is there and leaves its bytes alone.
  std::FILE* f = std::fopen(path.c_str(), "a");
  if (!f) throw Error(flag + " " + path + ": cannot be written (" + std::strerror(errno) + ")");
  std::fclose(f);
  if (!existed) ::unlink(path.c_str());
}

}  // namespace pl
