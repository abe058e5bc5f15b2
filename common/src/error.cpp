#include "pl/common/error.hpp"

namespace pl {

void fail_at(const std::string& file, std::size_t line, const std::string& expected, const std::string& found) {
  std::string msg = file;
  if (line > 0) msg += ":" + std::to_string(line);
  msg += ": expected " + expected;
  if (!found.empty()) {
    std::string shown = found.size() > 80 ? found.substr(0, 77) + "..." : found;
    msg += ", found \"" + shown + "\"";
  }
  throw Error(msg);
}

}  // namespace pl
