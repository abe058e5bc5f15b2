// pl-eval: trajectory accuracy (APE, KITTI relative errors), map accuracy against a reference,
// timing, and map top views. The commands live in the pl_eval library (pl/eval/command.hpp); this
// is only the process entry point.
#include "pl/eval/command.hpp"

int main(int argc, char** argv) { return pl::eval::eval_main(argc, argv); }
