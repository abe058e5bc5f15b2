// The figures `pl-eval --plot DIR` writes. Each function creates DIR if needed and returns the
// paths of the files it wrote.
#pragma once

#include <string>
#include <vector>

#include "pl/eval/ape.hpp"
#include "pl/eval/kitti_metrics.hpp"
#include "pl/eval/timing.hpp"

namespace pl::eval {

// trajectory.svg (top view, estimate vs ground truth), error_over_distance.svg, error_histogram.svg.
std::vector<std::string> write_ape_figures(const ApeResult& result, const std::string& dir);
// kitti_errors.svg (translation error % by segment length).
std::vector<std::string> write_kitti_figures(const KittiResult& result, const std::string& dir);
// timing_histogram.svg.
std::vector<std::string> write_timing_figures(const TimingColumn& column, const TimingStats& stats,
                                              const std::string& dir);

// Creates `dir` (and parents); pl::Error when that fails or it is a file.
void make_output_dir(const std::string& dir);

}  // namespace pl::eval
