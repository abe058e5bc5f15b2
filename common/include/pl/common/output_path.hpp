// Checks that an output can be written, made before a long job starts: a path under a missing folder
// or under a file fails at once, not after hours of work.
#pragma once

#include <string>

namespace pl {

// What stops a file from being written at `path`, or "" when nothing does: the path is a folder,
// its folder is missing (or is a file), or the file or its folder is not writable. The text starts
// with "cannot write PATH: " and ends with the fix.
std::string output_file_problem(const std::string& path);
// The same for a folder a tool creates (with its missing parents) or writes into.
std::string output_folder_problem(const std::string& path);

// Throw pl::Error with the text above.
void check_output_file(const std::string& path);
void check_output_folder(const std::string& path);

// The file written beside `path`: its path with `ext` (".places", say) for its extension, or added
// when it has none ("maps/town.pcd" -> "maps/town.places").
std::string beside(const std::string& path, const std::string& ext);

}  // namespace pl
