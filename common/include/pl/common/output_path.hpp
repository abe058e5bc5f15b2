// Output files are checked before a long job starts: a typo in a path must fail at once, not after
// the whole drive has been processed (and its results lost).
#pragma once

#include <string>

namespace pl {

// Throws pl::Error naming `flag`, the path and the fix when `path` cannot be written: its folder
// does not exist or is not a folder, the path is a folder, or a file cannot be created there.
// Creates nothing that was not there (a probe file is removed again).
void check_output_path(const std::string& path, const std::string& flag);

}  // namespace pl
