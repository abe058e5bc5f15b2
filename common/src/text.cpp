#include "pl/common/text.hpp"

#include <cerrno>
#include <cstdarg>
#include <cstdio>
#include <cmath>
#include <charconv>
#include <cstdlib>
#include <cstdint>
#include <cstring>
#include <sys/stat.h>

#include "pl/common/error.hpp"

namespace pl {

LineReader::LineReader(const std::string& path) : path_(path), in_(path) {
  if (!in_) throw Error(path + ": cannot open (" + std::strerror(errno) + ")");
  // A folder opens like an empty file on Linux and would read as one: say what it is instead.
  if (dir_exists(path)) throw Error(path + ": is a folder, expected a text file");
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

std::string valid_utf8(std::string_view s) {
  std::string out;
  out.reserve(s.size());
  const auto* p = reinterpret_cast<const unsigned char*>(s.data());
  const std::size_t n = s.size();
  std::size_t i = 0;
  while (i < n) {
    const unsigned char c = p[i];
    std::size_t len = 0;
    std::uint32_t cp = 0, min = 0;
    if (c < 0x80) {
      out += static_cast<char>(c);
      ++i;
      continue;
    }
    if ((c & 0xE0) == 0xC0) len = 2, cp = c & 0x1F, min = 0x80;
    else if ((c & 0xF0) == 0xE0) len = 3, cp = c & 0x0F, min = 0x800;
    else if ((c & 0xF8) == 0xF0) len = 4, cp = c & 0x07, min = 0x10000;
    bool ok = len > 0 && i + len <= n;
    for (std::size_t k = 1; ok && k < len; ++k) {
      if ((p[i + k] & 0xC0) != 0x80) ok = false;
      else cp = (cp << 6) | (p[i + k] & 0x3F);
    }
    ok = ok && cp >= min && cp <= 0x10FFFF && !(cp >= 0xD800 && cp <= 0xDFFF);
    if (ok) {
      out.append(s.data() + i, len);
      i += len;
    } else {
      out += "\xEF\xBF\xBD";  // U+FFFD for the first byte; resynchronise at the next one
      ++i;
    }
  }
  return out;
}

std::string printable(std::string_view s, std::size_t max_length) {
  static const char* hex = "0123456789abcdef";
  std::string out;
  for (std::size_t i = 0; i < s.size(); ++i) {
    if (out.size() >= max_length) {
      out += "...";
      break;
    }
    const auto c = static_cast<unsigned char>(s[i]);
    if (c < 0x20 || c >= 0x7F || c == '\\' || c == '"') {
      out += "\\x";
      out += hex[c >> 4];
      out += hex[c & 15];
    } else {
      out += static_cast<char>(c);
    }
  }
  return out;
}

bool file_exists(const std::string& path) {
  struct stat st {};
  return ::stat(path.c_str(), &st) == 0 && S_ISREG(st.st_mode);
}

bool dir_exists(const std::string& path) {
  struct stat st {};
  return ::stat(path.c_str(), &st) == 0 && S_ISDIR(st.st_mode);
}

namespace {
std::string vformat_text(const char* fmt, va_list args) {
  va_list again;
  va_copy(again, args);
  const int n = std::vsnprintf(nullptr, 0, fmt, args);
  std::string text(n > 0 ? static_cast<std::size_t>(n) : 0, '\0');
  if (n > 0) std::vsnprintf(text.data(), text.size() + 1, fmt, again);
  va_end(again);
  return text;
}
}  // namespace

std::string format_text(const char* fmt, ...) {
  va_list args;
  va_start(args, fmt);
  std::string text = vformat_text(fmt, args);
  va_end(args);
  return text;
}

void append_format(std::string& out, const char* fmt, ...) {
  va_list args;
  va_start(args, fmt);
  out += vformat_text(fmt, args);
  va_end(args);
}

}  // namespace pl
