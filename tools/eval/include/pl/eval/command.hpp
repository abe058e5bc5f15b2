// The pl-eval command line: `pl-eval ape|kitti|timing|map|topview ...`. Kept in the library so that tests can
// run it in-process; tools/eval/pl-eval.cpp only wraps it in pl::run_cli.
#pragma once

#include <ostream>
#include <string>

namespace pl::eval {

std::string usage();
// Runs pl-eval with argv[1..] (argv[0] is the program). Returns the exit code; bad input throws
// pl::Error (pl::run_cli turns it into "pl-eval: error: ..." and exit code 2).
int eval_main(int argc, char** argv, std::ostream& out);
int eval_main(int argc, char** argv);  // writes to std::cout

}  // namespace pl::eval
