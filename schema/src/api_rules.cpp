#include "pl/schema/api_rules.hpp"

#include <algorithm>

namespace pl::api {

bool valid_map_name(std::string_view name) {
  return !name.empty() && name.size() <= kMaxMapNameLength && std::all_of(name.begin(), name.end(), [](char c) {
    return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_' || c == '.' || c == '-';
  });
}

bool is_hash(std::string_view s) {
  return s.size() == 64 && std::all_of(s.begin(), s.end(), [](char c) { return (c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'); });
}

bool valid_tile_size(double metres) { return metres >= kMinTileSizeM && metres <= kMaxTileSizeM; }

}  // namespace pl::api
