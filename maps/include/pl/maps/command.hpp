// The pl-map command line: `pl-map build|tile|publish|...|update ...` over CLI11. Kept in the
// library so that tests can run it in-process; maps/pl-map.cpp only calls map_main.
#pragma once

#include <ostream>

#include "pl/common/cli.hpp"

namespace pl::maps {

// Adds every pl-map command to a pl-map tool, in the order --help lists them; their output goes to
// `out` (progress bars and token-add's note to stderr).
void add_commands(cli::Tool& tool, std::ostream& out);
// Runs pl-map with argv (argv[0] is the program) and returns the exit code: 0, 1 when check finds
// the store damaged, or 2 for bad input, printed on stderr as "pl-map: error: ..." (pl::cli::Tool::main).
int map_main(int argc, char** argv, std::ostream& out);
int map_main(int argc, char** argv);  // writes to std::cout

}  // namespace pl::maps
