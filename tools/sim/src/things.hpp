// Single things and their shapes: parked cars and trucks, containers, trees, and poles and signs.
// A parked vehicle finds its own place in the parking lane; the others stand where the caller put
// them, on cells it found free.
#pragma once

#include "site.hpp"

namespace pl::sim::worldgen {

// A car (or a truck) at `along` metres ahead on the `side` of the frame; false when the place is taken.
bool parked_vehicle(Site& site, const Frame& f, float side, float along, bool truck);
// A 20 ft container (40 ft with `forty`), `base_lift` metres up when stacked on another.
void container(Site& site, Vec2 c, float yaw, float base_lift, bool forty);
void tree(Site& site, Vec2 c, float scale);
void pole(Site& site, Vec2 c, bool with_sign, float yaw);

}  // namespace pl::sim::worldgen
