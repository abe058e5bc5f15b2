// The part of a recording's dataset that stays open: its reader and where each scan lies.
#pragma once

#include <cstddef>

#include "pl/recordings/dataset.hpp"

namespace pl {

// Scan i of the recording, decoded from its PointCloud2 (with `with_rings`, rings from the cloud's ring
// field, or from its points' order where it has none but comes laser by laser; times from its time
// field). Safe from several threads (one read at a time).
Frame recording_frame(RecordingScans& recording, std::size_t i, bool with_rings);

}  // namespace pl
