#include "pl/common/args.hpp"

#include <cstdio>
#include <exception>

#include "pl/common/error.hpp"
#include "pl/common/text.hpp"

namespace pl {

Args::Args(int argc, char** argv, int first, std::set<std::string> switches) : switches_(std::move(switches)) {
  for (int i = first; i < argc; ++i) {
    std::string a = argv[i];
    if (a.rfind("--", 0) == 0 && a.size() > 2) {
      auto eq = a.find('=');
      if (eq != std::string::npos) {
        flags_.emplace_back(a.substr(0, eq), a.substr(eq + 1));
      } else if (switches_.count(a)) {
        flags_.emplace_back(a, std::nullopt);
      } else {
        if (i + 1 >= argc) throw Error(a + " needs a value (" + a + " VALUE)");
        flags_.emplace_back(a, std::string(argv[++i]));
      }
    } else {
      positional_.push_back(a);
    }
  }
}

bool Args::has(const std::string& flag) const {
  known_.insert(flag);
  for (const auto& f : flags_)
    if (f.first == flag) return true;
  return false;
}

std::optional<std::string> Args::get(const std::string& flag) const {
  known_.insert(flag);
  std::optional<std::string> out;
  for (const auto& f : flags_) {
    if (f.first != flag) continue;
    if (!f.second) throw Error(flag + " needs a value (" + flag + " VALUE)");
    out = f.second;  // the last one wins, as in most tools
  }
  return out;
}

std::vector<std::string> Args::get_all(const std::string& flag) const {
  known_.insert(flag);
  std::vector<std::string> out;
  for (const auto& f : flags_) {
    if (f.first != flag) continue;
    if (!f.second) throw Error(flag + " needs a value (" + flag + " VALUE)");
    out.push_back(*f.second);
  }
  return out;
}

std::string Args::get_or(const std::string& flag, const std::string& fallback) const {
  auto v = get(flag);
  return v ? *v : fallback;
}

std::string Args::require(const std::string& flag, const std::string& what) const {
  auto v = get(flag);
  if (!v) throw Error("missing " + flag + " " + what);
  return *v;
}

double Args::get_double(const std::string& flag, double fallback) const {
  auto v = get(flag);
  if (!v) return fallback;
  double d = 0;
  if (!parse_double(*v, d)) throw Error(flag + " takes a number, got \"" + *v + "\"");
  return d;
}

long long Args::get_int(const std::string& flag, long long fallback) const {
  auto v = get(flag);
  if (!v) return fallback;
  long long n = 0;
  if (!parse_int(*v, n)) throw Error(flag + " takes a whole number, got \"" + *v + "\"");
  return n;
}

void Args::finish() const {
  std::string unknown;
  for (const auto& f : flags_)
    if (!known_.count(f.first)) unknown += (unknown.empty() ? "" : ", ") + f.first;
  if (!unknown.empty()) throw Error("unknown option " + unknown + " (see --help)");
}

int run_cli(const char* program, int (*body)(int, char**), int argc, char** argv) {
  try {
    return body(argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s: error: %s\n", program, e.what());
    return 2;
  }
}

}  // namespace pl
