#include "ros2_metadata.hpp"

#include <yaml-cpp/yaml.h>

#include <cctype>

#include "pl/common/error.hpp"
#include "pl/common/text.hpp"

namespace pl::bag {
namespace {

std::string in_quotes(std::string_view s) { return "\"" + printable(s, 120) + "\""; }

std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

std::string line_of(const YAML::Node& n, const std::string& name) {
  const YAML::Mark m = n.Mark();
  return m.line >= 0 ? name + ":" + std::to_string(m.line + 1) : name;
}

// A text field of a map; empty when it is missing or null.
std::string text_field(const YAML::Node& map, const char* key, const std::string& name) {
  const YAML::Node v = map[key];
  if (!v.IsDefined() || v.IsNull()) return {};
  if (!v.IsScalar()) throw Error(line_of(v, name) + ": " + key + " must be text, found a " + (v.IsSequence() ? "list" : "map"));
  return v.Scalar();
}

}  // namespace

Metadata parse_metadata(const std::string& text, const std::string& name, bool need_files) {
  if (text.size() > kMaxMetadataBytes)
    throw Error(name + ": " + std::to_string(text.size()) + " bytes, far more than rosbag2 writes: not a rosbag2 metadata.yaml");
  Metadata md;
  try {
    const YAML::Node root = YAML::Load(text);
    if (!root.IsMap()) throw Error(name + ": expected a YAML map of the bag's metadata: not rosbag2's metadata");
    // (A YAML::Node assigned to another takes on its content: each is bound once here.)
    const YAML::Node info = need_files ? root["rosbag2_bagfile_information"] : root;
    if (!info.IsDefined() || !info.IsMap())
      throw Error(name + ": no map rosbag2_bagfile_information: not a rosbag2 metadata.yaml");
    md.storage = text_field(info, "storage_identifier", name);
    // What storage and compression say matters more than the file list: an MCAP bag's files are
    // not ours to read whatever they are.
    if (md.storage == "mcap") {
      const YAML::Node files = info["relative_file_paths"];
      if (files.IsSequence() && files.size() > 0 && files[0].IsScalar()) md.files.push_back(files[0].Scalar());
      return md;
    }
    const std::string format = lower(text_field(info, "compression_format", name));
    std::string mode = text_field(info, "compression_mode", name);
    for (char& c : mode) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
    if (!mode.empty() && mode != "NONE") {
      if (mode != "FILE" && mode != "MESSAGE")
        throw Error(line_of(info["compression_mode"], name) + ": compression_mode " + in_quotes(mode) +
                    " is not one rosbag2 writes (FILE, MESSAGE or NONE)");
      if (format != "zstd")
        throw Error(line_of(info, name) + ": compression_format " + in_quotes(format) +
                    " is not supported (only zstd): decompress the bag with `ros2 bag convert`");
      md.zstd_messages = mode == "MESSAGE";
    }
    if (!need_files) return md;
    const YAML::Node files = info["relative_file_paths"];
    if (!files.IsDefined() || !files.IsSequence())
      throw Error(line_of(info, name) + ": no list relative_file_paths: not a rosbag2 metadata.yaml");
    // The names may not add up to more than the text: YAML aliases could repeat one long name
    // without end.
    std::size_t bytes = 0;
    for (const YAML::Node& f : files) {
      if (!f.IsScalar()) throw Error(line_of(f, name) + ": relative_file_paths must list file names");
      bytes += f.Scalar().size();
      if (bytes > text.size())
        throw Error(line_of(f, name) + ": relative_file_paths repeats names through YAML aliases: not a rosbag2 metadata.yaml");
      md.files.push_back(f.Scalar());
    }
    if (md.files.empty()) throw Error(line_of(files, name) + ": relative_file_paths lists no files: the bag has no data");
  } catch (const YAML::Exception& e) {
    throw Error(name + (e.mark.line >= 0 ? ":" + std::to_string(e.mark.line + 1) : "") + ": not valid YAML (" + e.msg + ")");
  }
  return md;
}

}  // namespace pl::bag
