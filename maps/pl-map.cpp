// pl-map: build maps from drives, cut them into Draco tiles in a versioned SQLite store, publish.
// The pipelines are in pl_maps (gloam.hpp, import.hpp, catalog.hpp, push.hpp) and so are the
// commands (pl/maps/command.hpp); this is only the process entry point.
#include "pl/maps/command.hpp"

int main(int argc, char** argv) { return pl::maps::map_main(argc, argv); }
