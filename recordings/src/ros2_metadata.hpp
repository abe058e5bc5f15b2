// A ROS 2 bag's metadata as rosbag2 writes it: metadata.yaml beside the files, or the metadata row
// of a .db3 file. Private to pl_common.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

namespace pl::bag {

// rosbag2 writes a few hundred bytes of metadata per topic; YAML takes many times its text in
// memory, so far larger text is refused before it is parsed.
constexpr std::size_t kMaxMetadataBytes = 16u << 20;
struct Metadata {
  std::string storage;             // storage_identifier
  std::vector<std::string> files;  // relative_file_paths, in order
  bool zstd_messages = false;      // compression_mode MESSAGE
};

// `text`: a whole metadata.yaml (the fields under rosbag2_bagfile_information), or a .db3 file's
// metadata row (the fields themselves). `name` names the text in errors.
Metadata parse_metadata(const std::string& text, const std::string& name, bool need_files);

}  // namespace pl::bag
