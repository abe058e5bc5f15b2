// Errors that name the problem and the fix: the file, the line, and what was expected.
#pragma once

#include <stdexcept>
#include <string>

namespace pl {

class Error : public std::runtime_error {
 public:
  explicit Error(const std::string& what) : std::runtime_error(what) {}
};

// "FILE:LINE: expected WHAT, found FOUND" (line 0 leaves the line out).
[[noreturn]] void fail_at(const std::string& file, std::size_t line, const std::string& expected,
                          const std::string& found = {});

}  // namespace pl
