// Buildings and what stands between them: houses and warehouses with their street facades, walls
// and fences, and the town's backdrop, the next street's houses.
#pragma once

#include "site.hpp"

namespace pl::sim::worldgen {

// A house (or a warehouse) `side` of the frame, and a wall or a fence (or only a fence). Each returns
// the length of street it used (metres), or a shorter step on when the place was taken.
double building(Site& site, const Frame& f, float side, bool warehouse);
double boundary(Site& site, const Frame& f, float side, float length, bool fence_only);
// The town's backdrop: the next street's houses, behind the back gardens.
void second_row(Site& site);

}  // namespace pl::sim::worldgen
