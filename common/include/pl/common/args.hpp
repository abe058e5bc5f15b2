// DEPRECATED: the hand-written command-line parser the pl-* tools used before CLI11
// (pl/common/cli.hpp). Only pl-localize still uses it; it goes once pl-localize moves to CLI11.
// `--flag VALUE`, `--flag=VALUE`, switches and positionals, with errors that say which flag is wrong.
#pragma once

#include <optional>
#include <set>
#include <string>
#include <vector>

namespace pl {

class Args {
 public:
  // Parses argv[first..]; `switches` are the flags that take no value.
  Args(int argc, char** argv, int first, std::set<std::string> switches = {});

  bool has(const std::string& flag) const;                          // marks the flag as known
  std::optional<std::string> get(const std::string& flag) const;    // marks the flag as known
  // Every value of a flag that may be repeated (--traj A --traj B), in order; marks it as known.
  std::vector<std::string> get_all(const std::string& flag) const;
  std::string get_or(const std::string& flag, const std::string& fallback) const;
  std::string require(const std::string& flag, const std::string& what) const;
  double get_double(const std::string& flag, double fallback) const;
  long long get_int(const std::string& flag, long long fallback) const;
  const std::vector<std::string>& positional() const { return positional_; }

  // Throws pl::Error naming every flag that no getter asked for (a typo, or a flag of another command).
  void finish() const;

 private:
  std::vector<std::pair<std::string, std::optional<std::string>>> flags_;
  std::vector<std::string> positional_;
  std::set<std::string> switches_;
  mutable std::set<std::string> known_;
};

// Runs a CLI body, printing pl::Error (and other exceptions) as "PROGRAM: error: ..." with exit code 2.
// (The CLI11 tools use pl::cli::Tool::main, which does the same around the parse.)
int run_cli(const char* program, int (*body)(int, char**), int argc, char** argv);

}  // namespace pl
