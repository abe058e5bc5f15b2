// The command lines of the pl-* tools, over CLI11: one Tool per program (its sub-commands, --help,
// --version), options whose values are checked while parsing (numbers in range, one of a few
// words, coordinates, output paths that can be written), and one way to report bad input:
// "PROGRAM: error: WHAT" on stderr with exit code 2.
#pragma once

#include <CLI/CLI.hpp>

#include <cstddef>
#include <functional>
#include <limits>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "pl/common/geo.hpp"

namespace pl {

// "a,b,c" as exactly n numbers; throws pl::Error naming the flag otherwise.
std::vector<double> parse_number_list(const std::string& text, std::size_t n, const std::string& flag);

namespace cli {

// "PROGRAM PointLocalization X.Y.Z" (the CMake project version).
std::string version_line(const std::string& program);

// A program: a CLI11 app with --help and --version, and either sub-commands (each with the body it
// runs) or one body of its own.
class Tool {
 public:
  Tool(std::string program, const std::string& description);
  Tool(const Tool&) = delete;
  Tool& operator=(const Tool&) = delete;

  CLI::App& app() { return app_; }
  const std::string& program() const { return program_; }
  // A sub-command; once it is parsed, `body` runs and its return value is the exit code.
  CLI::App& command(const std::string& name, const std::string& description, std::function<int()> body);
  // The body of a program without sub-commands.
  void body(std::function<int()> body) { body_ = std::move(body); }

  // Parses argv and runs the chosen body. --help and --version print to stdout and return 0. A
  // parse error prints "PROGRAM: error: CLI11's message (run PROGRAM [COMMAND] --help)"; an
  // exception from a body "PROGRAM: error: what()". Both return 2.
  int main(int argc, char** argv);

 private:
  std::string program_;
  CLI::App app_;
  std::vector<std::pair<CLI::App*, std::function<int()>>> commands_;
  std::function<int()> body_;
};

// The values a number may take. Bounds are closed unless marked open; the default is any finite number.
struct Bounds {
  double lo = -std::numeric_limits<double>::infinity();
  double hi = std::numeric_limits<double>::infinity();
  bool lo_open = false, hi_open = false;
};
inline Bounds above(double lo) { return {lo, std::numeric_limits<double>::infinity(), true, false}; }
inline Bounds at_least(double lo) { return {lo, std::numeric_limits<double>::infinity(), false, false}; }
inline Bounds between(double lo, double hi) { return {lo, hi, false, false}; }
inline Bounds above_up_to(double lo, double hi) { return {lo, hi, true, false}; }

// Checks that the text is a finite number (a whole one when `whole`) within the bounds, and within
// [type_lo, type_hi] (the variable's type); the error names the flag: "--voxel takes a number > 0,
// got \"-1\"".
CLI::Validator number_check(const std::string& flag, const Bounds& bounds, bool whole,
                            double type_lo = -std::numeric_limits<double>::max(),
                            double type_hi = std::numeric_limits<double>::max());

// A numeric option, range-checked, its default (the variable's value, e.g. from a config struct)
// shown by --help.
template <class T>
CLI::Option* number(CLI::App& app, const std::string& flag, T& value, const std::string& help, Bounds bounds) {
  static_assert(std::is_arithmetic_v<T> && !std::is_same_v<T, bool>, "a number");
  const auto type_lo = static_cast<double>(std::numeric_limits<T>::lowest());
  const auto type_hi = static_cast<double>(std::numeric_limits<T>::max());
  return app.add_option(flag, value, help)
      ->check(number_check(flag, bounds, std::is_integral_v<T>, type_lo, type_hi))
      ->capture_default_str();
}

// A word out of `choices` ("--poses takes gt or lidar, got \"odometry\""); --help shows them.
CLI::Option* choice(CLI::App& app, const std::string& flag, std::string& value, const std::string& help,
                    const std::vector<std::string>& choices);
// The same for a word that names an enum value, mapped while parsing.
template <typename E>
CLI::Option* choice(CLI::App& app, const std::string& flag, E& value, const std::string& help,
                    const std::vector<std::pair<std::string, E>>& words);
// The check of both: `text` is one of `words`, or the error names them.
CLI::Validator one_of(const std::string& flag, const std::vector<std::string>& words);

// LAT,LON,ALT (degrees, degrees, metres) into `text`; parse it with geo_point() after parsing.
CLI::Option* geo_option(CLI::App& app, const std::string& flag, std::string& text, const std::string& help);
GeoPoint geo_point(const std::string& text, const std::string& flag);

// A file the program writes, checked while parsing (pl::output_file_problem); a folder the program
// creates or writes into (pl::output_folder_problem).
CLI::Option* output_file(CLI::App& app, const std::string& flag, std::string& path, const std::string& help);
// The same, given once or more (each path checked).
CLI::Option* output_files(CLI::App& app, const std::string& flag, std::vector<std::string>& paths, const std::string& help);
CLI::Option* output_folder(CLI::App& app, const std::string& flag, std::string& path, const std::string& help);

template <typename E>
CLI::Option* choice(CLI::App& app, const std::string& flag, E& value, const std::string& help,
                    const std::vector<std::pair<std::string, E>>& words) {
  std::vector<std::string> names;
  std::string type, shown;
  for (const auto& [name, e] : words) {
    names.push_back(name);
    type += (type.empty() ? "" : "|") + name;
    if (e == value) shown = name;
  }
  // transform() puts each validator first: the word is checked, then mapped (CLI11 alone would also
  // take the enum's number).
  return app.add_option(flag, value, help)
      ->transform(CLI::CheckedTransformer(words).description(""))
      ->transform(one_of(flag, names))
      ->type_name(type)
      ->default_str(shown);
}

}  // namespace cli
}  // namespace pl
