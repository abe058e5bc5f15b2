// pl-eval: trajectory accuracy (APE, KITTI relative errors), map accuracy against a reference,
// timing, and map top views. The commands live in the pl_eval library (pl/eval/command.hpp); this
// is only the process entry point.
#include "pl/common/cli.hpp"
#include "pl/eval/command.hpp"

namespace {
int body(int argc, char** argv) { return pl::eval::eval_main(argc, argv); }
}  // namespace

int main(int argc, char** argv) { return pl::run_cli("pl-eval", body, argc, argv); }
