// Each origin replica's pl_requests_total, scraped from its /metrics before and after the run: how
// many of the vehicles' requests reached the origin, by kind of route.
#pragma once

#include <map>
#include <string>
#include <utility>

#include "pl/fleet/fleet.hpp"

namespace pl::fleet {

using Counters = std::map<std::pair<std::string, std::string>, double>;  // (route, status) -> count

// GET the replica's /metrics (or the path the URL names): pl_requests_total by route and status.
// Throws pl::Error when it cannot be read.
Counters scrape(const std::string& url, const FleetOptions& o);

// The increase from `before` to `after`, by kind of route; not ok when a counter went down.
OriginCounts origin_delta(const std::string& url, const Counters& before, const Counters& after);

}  // namespace pl::fleet
