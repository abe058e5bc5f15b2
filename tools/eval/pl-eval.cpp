// pl-eval: accuracy (APE, KITTI relative errors) and timing evaluation. The commands live in the
// pl_eval library (pl/eval/command.hpp); this is only the process entry point.
#include "pl/common/cli.hpp"
#include "pl/eval/command.hpp"

namespace {
int body(int argc, char** argv) { return pl::eval::eval_main(argc, argv); }
}  // namespace

int main(int argc, char** argv) { return pl::run_cli("pl-eval", body, argc, argv); }
