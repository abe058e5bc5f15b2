// What stands beside the town's road: poles and signs at the kerb, avenue trees, front gardens'
// hedges and bushes, back gardens' trees.
#pragma once

#include "site.hpp"

namespace pl::sim::worldgen {

// Poles and signs at the kerb, and trees in a `tree_share` of the avenue's places.
void street_furniture(Site& site, float tree_share);
void gardens(Site& site);

}  // namespace pl::sim::worldgen
