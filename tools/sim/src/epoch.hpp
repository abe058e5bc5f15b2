// Epoch 1, six months later: movable things moved, removed or grown, and new ones added.
#pragma once

#include "site.hpp"

namespace pl::sim::worldgen {

void six_months_later(Site& site);

}  // namespace pl::sim::worldgen
