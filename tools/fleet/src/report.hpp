// The fleet's figures: latency percentiles, the cache's answers counted by X-Cache, and the report
// as JSON and as text (report_json and report_text, declared in pl/fleet/fleet.hpp).
#pragma once

#include <string>
#include <vector>

#include "pl/fleet/fleet.hpp"

namespace pl::fleet {

// Nearest-rank percentiles, the largest and the mean of latencies in milliseconds.
Latency summarize(std::vector<float> v);

// Counts one answer with its X-Cache header's value ("" when absent).
void tally(CacheCounts& c, const std::string& value);

// Adds one set of counts to another.
void merge(CacheCounts& into, const CacheCounts& c);

}  // namespace pl::fleet
