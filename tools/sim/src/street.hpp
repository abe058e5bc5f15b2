// The street itself: the road and its driving lanes marked in the occupancy grid, the ground mesh
// along the path (asphalt, pavement, grass) and the curbs.
#pragma once

#include "site.hpp"

namespace pl::sim::worldgen {

void mark_roads(Site& site);  // first, so that nothing else is placed on the road
void add_ground(Site& site);
void curbs(Site& site);

}  // namespace pl::sim::worldgen
