#include "pl/common/text.hpp"

#include <cerrno>
#include <cmath>
#include <charconv>
#include <cstdlib>
#include <cstring>
#include <sys/stat.h>

#include "pl/common/error.hpp"

namespace pl {

LineReader::LineReader(const std::string& path) : path_(path), in_(path) {
  if (!in_) throw Error(path + ": cannot open (" + std::strerror(errno) + ")");
}

bool LineReader::next(std::string& line) {
  while (std::getline(in_, line)) {
    ++line_number_;
    std::size_t i = line.find_first_not_of(" \t\r");
    if (i == std::string::npos || line[i] == '#') continue;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    return true;
  }
  return false;
}

void LineReader::fail(const std::string& expected, const std::string& found) const {
  fail_at(path_, line_number_, expected, found);
}

std::vector<std::string_view> split_fields(std::string_view text, std::string_view separators) {
  std::vector<std::string_view> out;
  std::size_t i = 0;
  while (i < text.size()) {
    std::size_t j = text.find_first_of(separators, i);
    if (j == std::string_view::npos) j = text.size();
    if (j > i) out.push_back(text.substr(i, j - i));
    i = j + 1;
  }
  return out;
}

bool parse_double(std::string_view text, double& out) {
  if (text.empty()) return false;
  // strtod handles every spelling KITTI files use (1e-05, -8.086759e-01, nan is rejected below).
  std::string buf(text);
  char* end = nullptr;
  errno = 0;
  out = std::strtod(buf.c_str(), &end);
  if (end != buf.c_str() + buf.size() || errno == ERANGE) return false;
  return std::isfinite(out);
}

bool parse_int(std::string_view text, long long& out) {
  auto res = std::from_chars(text.data(), text.data() + text.size(), out);
  return res.ec == std::errc() && res.ptr == text.data() + text.size();
}

std::vector<double> parse_numbers(const LineReader& reader, const std::string& line, std::size_t min_count,
                                  std::size_t max_count, const std::string& what, std::string_view separators) {
  auto fields = split_fields(line, separators);
  auto expected = [&] {
    std::string n = min_count == max_count ? std::to_string(min_count)
                                           : std::to_string(min_count) + " to " + std::to_string(max_count);
    return n + " numbers (" + what + ")";
  };
  if (fields.size() < min_count || fields.size() > max_count) reader.fail(expected(), line);
  std::vector<double> values(fields.size());
  for (std::size_t i = 0; i < fields.size(); ++i) {
    if (!parse_double(fields[i], values[i])) reader.fail(expected() + "; field " + std::to_string(i + 1) + " is not a number", line);
  }
  return values;
}

bool file_exists(const std::string& path) {
  struct stat st {};
  return ::stat(path.c_str(), &st) == 0 && S_ISREG(st.st_mode);
}

bool dir_exists(const std::string& path) {
  struct stat st {};
  return ::stat(path.c_str(), &st) == 0 && S_ISDIR(st.st_mode);
}

}  // namespace pl
