// Line-oriented text parsing with errors that name the file and the line.
#pragma once

#include <cstddef>
#include <fstream>
#include <string>
#include <string_view>
#include <vector>

namespace pl {

class LineReader {
 public:
  // Throws pl::Error "PATH: cannot open ..." when the file is missing or unreadable.
  explicit LineReader(const std::string& path);
  // Next line that is neither blank nor a '#' comment; false at the end of the file.
  bool next(std::string& line);
  std::size_t line_number() const { return line_number_; }
  const std::string& path() const { return path_; }
  [[noreturn]] void fail(const std::string& expected, const std::string& found = {}) const;

 private:
  std::string path_;
  std::ifstream in_;
  std::size_t line_number_ = 0;
};

// Splits on any of the separator characters, dropping empty fields.
std::vector<std::string_view> split_fields(std::string_view text, std::string_view separators = " \t\r,");
bool parse_double(std::string_view text, double& out);
bool parse_int(std::string_view text, long long& out);
// Parses every field as a number; fails with "N numbers (WHAT)" when the count is not in [min_count, max_count].
std::vector<double> parse_numbers(const LineReader& reader, const std::string& line, std::size_t min_count,
                                  std::size_t max_count, const std::string& what,
                                  std::string_view separators = " \t\r,");

// The text with every byte sequence that is not valid UTF-8 (stray continuation bytes, overlong
// forms, surrogates, code points past U+10FFFF, truncated sequences) replaced by U+FFFD, so that it
// can go into JSON or a log. Valid text comes back unchanged.
std::string valid_utf8(std::string_view text);
// The text with control characters, backslashes, quotes and bytes >= 0x7F written as \xHH: one
// line of plain ASCII for a log, whatever a client sent.
std::string printable(std::string_view text, std::size_t max_length = 512);

// printf-style text, returned or appended to `out` (reports built line by line).
std::string format_text(const char* fmt, ...) __attribute__((format(printf, 1, 2)));
void append_format(std::string& out, const char* fmt, ...) __attribute__((format(printf, 2, 3)));

bool file_exists(const std::string& path);
bool dir_exists(const std::string& path);

}  // namespace pl
