#include "pl/common/output_path.hpp"

#include <unistd.h>

#include <filesystem>
#include <system_error>

#include "pl/common/error.hpp"

namespace pl {

namespace {

namespace fs = std::filesystem;

fs::file_type type_of(const fs::path& p) {
  std::error_code ec;
  return fs::status(p, ec).type();  // not_found also for a path through a file (ENOTDIR)
}

bool writable(const fs::path& p, bool folder) { return ::access(p.c_str(), folder ? (W_OK | X_OK) : W_OK) == 0; }

// The problem with creating `p` (and its missing parents): the nearest existing ancestor must be a
// writable folder.
std::string creation_problem(const fs::path& p, const std::string& head) {
  fs::path parent = p.parent_path();
  if (parent.empty()) parent = ".";
  fs::path existing = parent;
  while (type_of(existing) == fs::file_type::not_found && existing.has_parent_path() && existing != existing.parent_path())
    existing = existing.parent_path();
  const fs::file_type t = type_of(existing);
  if (t == fs::file_type::not_found)
    return head + "the folder " + parent.string() + " does not exist (create it, or choose another path)";
  if (t != fs::file_type::directory)
    return head + existing.string() + " is a file, not a folder (choose a path in an existing folder)";
  if (existing != parent)
    return head + "the folder " + parent.string() + " does not exist (create it with mkdir -p " + parent.string() +
           ", or choose another path)";
  if (!writable(existing, true))
    return head + "the folder " + existing.string() + " is not writable (choose another folder, or change its permissions)";
  return "";
}

}  // namespace

std::string output_file_problem(const std::string& path) {
  if (path.empty()) return "cannot write an empty path: give a file name";
  const std::string head = "cannot write " + path + ": ";
  const fs::path p(path);
  switch (type_of(p)) {
    case fs::file_type::not_found:
      return creation_problem(p, head);
    case fs::file_type::directory:
      return head + "it is a folder (give a file name, e.g. " + (p / "out").string() + ")";
    default:
      if (!writable(p, false)) return head + "the file is not writable (choose another path, or change its permissions)";
      return "";
  }
}

std::string output_folder_problem(const std::string& path) {
  if (path.empty()) return "cannot write an empty path: give a folder name";
  const std::string head = "cannot write " + path + ": ";
  const fs::path p(path);
  switch (type_of(p)) {
    case fs::file_type::not_found: {
      // The tool creates the folder with its parents: the nearest existing ancestor must be a folder.
      fs::path existing = p;
      while (type_of(existing) == fs::file_type::not_found && existing.has_parent_path() && existing != existing.parent_path())
        existing = existing.parent_path();
      const fs::file_type t = type_of(existing);
      if (t == fs::file_type::not_found) return "";  // a relative path whose first part is created here
      if (t != fs::file_type::directory)
        return head + existing.string() + " is a file, not a folder (choose a path in an existing folder)";
      if (!writable(existing, true))
        return head + "the folder " + existing.string() + " is not writable (choose another folder, or change its permissions)";
      return "";
    }
    case fs::file_type::directory:
      if (!writable(p, true)) return head + "the folder is not writable (choose another folder, or change its permissions)";
      return "";
    default:
      return head + "it is a file, not a folder (remove it, or choose another path)";
  }
}

void check_output_file(const std::string& path) {
  const std::string problem = output_file_problem(path);
  if (!problem.empty()) throw Error(problem);
}

void check_output_folder(const std::string& path) {
  const std::string problem = output_folder_problem(path);
  if (!problem.empty()) throw Error(problem);
}

std::string beside(const std::string& path, const std::string& ext) {
  const std::size_t slash = path.find_last_of('/');
  const std::size_t dot = path.find_last_of('.');
  const bool has_ext = dot != std::string::npos && (slash == std::string::npos || dot > slash + 1);
  return (has_ext ? path.substr(0, dot) : path) + ext;
}

}  // namespace pl
