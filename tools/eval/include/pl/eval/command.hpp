// The pl-eval command line: `pl-eval ape|kitti|timing|map|topview ...` over CLI11. Kept in the
// library so that tests can run it in-process; tools/eval/pl-eval.cpp only calls eval_main.
#pragma once

#include <ostream>

#include "pl/common/cli.hpp"

namespace pl::eval {

// Adds the commands ape, kitti, timing, map and topview to a pl-eval tool; their output goes to `out`.
void add_commands(cli::Tool& tool, std::ostream& out);
// Runs pl-eval with argv (argv[0] is the program) and returns the exit code: 0, or 2 for bad
// input, printed on stderr as "pl-eval: error: ..." (pl::cli::Tool::main).
int eval_main(int argc, char** argv, std::ostream& out);
int eval_main(int argc, char** argv);  // writes to std::cout

}  // namespace pl::eval
