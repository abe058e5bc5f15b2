#include "pl/common/cli.hpp"

#include <cmath>
#include <cstdio>
#include <exception>

#include "pl/common/error.hpp"
#include "pl/common/output_path.hpp"
#include "pl/common/text.hpp"

#ifndef PL_VERSION
#error "PL_VERSION (the CMake project version) must be defined"
#endif

namespace pl {

std::vector<double> parse_number_list(const std::string& text, std::size_t n, const std::string& flag) {
  std::vector<double> v;
  for (auto f : split_fields(text, ",")) {
    double d;
    if (!parse_double(f, d)) break;
    v.push_back(d);
  }
  if (v.size() != n) throw Error(flag + " takes " + std::to_string(n) + " comma-separated numbers, got \"" + text + "\"");
  return v;
}

namespace cli {

namespace {

std::string number_text(double x) {
  if (std::isinf(x)) return x > 0 ? "inf" : "-inf";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.15g", x);
  return buf;
}

bool below_lo(double x, const Bounds& b) { return b.lo_open ? !(x > b.lo) : !(x >= b.lo); }
bool above_hi(double x, const Bounds& b) { return b.hi_open ? !(x < b.hi) : !(x <= b.hi); }

// "(0,inf)", "[1,inf)", "[0,1000]": what --help shows after the type; "" without bounds.
std::string interval(const Bounds& b) {
  if (std::isinf(b.lo) && std::isinf(b.hi)) return "";
  return std::string(b.lo_open || std::isinf(b.lo) ? "(" : "[") + number_text(b.lo) + "," + number_text(b.hi) +
         (b.hi_open || std::isinf(b.hi) ? ")" : "]");
}

// "> 0", ">= 1", "in [0, 1000]": the words of the error message.
std::string range_words(const Bounds& b) {
  const bool lo = !std::isinf(b.lo), hi = !std::isinf(b.hi);
  if (lo && hi)
    return " in " + std::string(b.lo_open ? "(" : "[") + number_text(b.lo) + ", " + number_text(b.hi) + (b.hi_open ? ")" : "]");
  if (lo) return std::string(b.lo_open ? " > " : " >= ") + number_text(b.lo);
  if (hi) return std::string(b.hi_open ? " < " : " <= ") + number_text(b.hi);
  return "";
}

std::string or_list(const std::vector<std::string>& words) {
  std::string out;
  for (std::size_t i = 0; i < words.size(); ++i)
    out += (i == 0 ? "" : i + 1 == words.size() ? " or " : ", ") + words[i];
  return out;
}

}  // namespace

std::string version_line(const std::string& program) { return program + " PointLocalization " PL_VERSION; }

Tool::Tool(std::string program, const std::string& description) : program_(std::move(program)), app_(description, program_) {
  app_.set_version_flag("--version", version_line(program_), "Print the version and exit");
  // An option given twice: the last one wins (scripts append overrides), as with most tools.
  // Repeatable options (a list) take CLI::MultiOptionPolicy::TakeAll themselves.
  app_.option_defaults()->multi_option_policy(CLI::MultiOptionPolicy::TakeLast);
}

CLI::App& Tool::command(const std::string& name, const std::string& description, std::function<int()> body) {
  CLI::App* sub = app_.add_subcommand(name, description);
  app_.require_subcommand(1);
  commands_.emplace_back(sub, std::move(body));
  return *sub;
}

int Tool::main(int argc, char** argv) {
  const char* program = program_.c_str();
  std::string names;
  for (const auto& c : commands_) names += (names.empty() ? "" : "|") + c.first->get_name();
  try {
    // A missing or misspelt command: clearer than CLI11's "A subcommand is required".
    if (!commands_.empty()) {
      if (argc < 2) throw Error("missing command: " + program_ + " " + names + " ... (run " + program_ + " --help)");
      const std::string first = argv[1];
      bool known = !first.empty() && first[0] == '-';
      for (const auto& c : commands_) known = known || c.first->get_name() == first;
      if (!known) throw Error("unknown command \"" + first + "\": the commands are " + names + " (run " + program_ + " --help)");
    }
    app_.parse(argc, argv);
  } catch (const CLI::Success& e) {
    return app_.exit(e);  // --help, --version: on stdout
  } catch (const CLI::ParseError& e) {
    std::string what = e.what();
    // A validator's message names its flag already: "--poses: --poses takes ..." -> "--poses takes ...".
    const auto colon = what.find(": ");
    if (dynamic_cast<const CLI::ValidationError*>(&e) && colon != std::string::npos && what.compare(colon + 2, colon, what, 0, colon) == 0)
      what = what.substr(colon + 2);
    std::string where = program_;
    for (const CLI::App* sub : app_.get_subcommands()) where += " " + sub->get_name();
    std::fprintf(stderr, "%s: error: %s (run %s --help)\n", program, what.c_str(), where.c_str());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s: error: %s\n", program, e.what());
    return 2;
  }
  try {
    for (const auto& [sub, body] : commands_)
      if (sub->parsed()) return body();
    return body_ ? body_() : 0;
  } catch (const std::exception& e) {
    std::fflush(stdout);
    std::fprintf(stderr, "%s: error: %s\n", program, e.what());
    return 2;
  }
}

CLI::Validator number_check(const std::string& flag, const Bounds& bounds, bool whole, double type_lo, double type_hi) {
  const std::string kind = whole ? "a whole number" : "a number";
  auto check = [=](std::string& text) -> std::string {
    const std::string wanted = flag + " takes " + kind + range_words(bounds) + ", got \"" + text + "\"";
    double x = 0;
    if (whole) {
      long long n = 0;
      if (!parse_int(text, n)) return wanted;
      x = static_cast<double>(n);
    } else if (!parse_double(text, x) || !std::isfinite(x)) {
      return wanted;
    }
    if (below_lo(x, bounds) || above_hi(x, bounds)) return wanted;
    if (x < type_lo || x > type_hi) return flag + " takes at most " + number_text(type_hi) + ", got \"" + text + "\"";
    return "";
  };
  return CLI::Validator(check, interval(bounds));
}

CLI::Validator one_of(const std::string& flag, const std::vector<std::string>& words) {
  auto check = [=](std::string& text) -> std::string {
    for (const auto& w : words)
      if (text == w) return "";
    return flag + " takes " + or_list(words) + ", got \"" + text + "\"";
  };
  return CLI::Validator(check, "");
}

CLI::Option* choice(CLI::App& app, const std::string& flag, std::string& value, const std::string& help,
                    const std::vector<std::string>& choices) {
  std::string type;
  for (const auto& c : choices) type += (type.empty() ? "" : "|") + c;
  return app.add_option(flag, value, help)->check(one_of(flag, choices))->type_name(type)->capture_default_str();
}

CLI::Option* geo_option(CLI::App& app, const std::string& flag, std::string& text, const std::string& help) {
  auto check = [=](std::string& t) -> std::string {
    try {
      geo_point(t, flag);
    } catch (const Error& e) {
      return e.what();
    }
    return "";
  };
  return app.add_option(flag, text, help)->check(CLI::Validator(check, ""))->type_name("LAT,LON,ALT");
}

GeoPoint geo_point(const std::string& text, const std::string& flag) {
  const std::vector<double> v = parse_number_list(text, 3, flag);
  if (!(std::abs(v[0]) <= 90.0) || !(std::abs(v[1]) <= 180.0) || !std::isfinite(v[2]))
    throw Error(flag + " takes LAT,LON,ALT: latitude in [-90, 90] and longitude in [-180, 180] degrees, altitude in metres, got \"" +
                text + "\"");
  return GeoPoint{v[0], v[1], v[2]};
}

CLI::Option* output_file(CLI::App& app, const std::string& flag, std::string& path, const std::string& help) {
  auto check = [](std::string& p) { return output_file_problem(p); };
  return app.add_option(flag, path, help)->check(CLI::Validator(check, ""))->type_name("FILE");
}

CLI::Option* output_files(CLI::App& app, const std::string& flag, std::vector<std::string>& paths, const std::string& help) {
  auto check = [](std::string& p) { return output_file_problem(p); };
  return app.add_option(flag, paths, help)->check(CLI::Validator(check, ""))->type_name("FILE");
}

CLI::Option* output_folder(CLI::App& app, const std::string& flag, std::string& path, const std::string& help) {
  auto check = [](std::string& p) { return output_folder_problem(p); };
  return app.add_option(flag, path, help)->check(CLI::Validator(check, ""))->type_name("DIR");
}

}  // namespace cli
}  // namespace pl
