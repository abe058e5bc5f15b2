// What a map store holds, as the text pl-map prints: the maps, the versions of one map, one
// version's manifest, and the tiles two versions differ in.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

#include "pl/schema/signed_manifest.hpp"
#include "pl/schema/store.hpp"

namespace pl::maps {

// "12.34 MB".
std::string megabytes(double bytes);

// The map, or pl::Error "PATH: no map named ..." with the command that lists the maps.
store::MapInfo need_map(const store::Store& s, const std::string& name);

// One line per map: current version, grid, origin.
std::string maps_text(const store::Store& s);
// The map's grid, then one line per version (the current one starred): state, tiles, points, bytes, date, note.
std::string versions_text(const store::Store& s, const std::string& map);
// A version's manifest (0: the current one): state, origin, grid, tiles, area, points, bytes, bounds.
std::string version_text(const store::Store& s, const std::string& map, std::int64_t version);

// Publishes a staged version in one transaction with its upload log entry (by "pl-map"). With a
// key, the version's manifest (pl/schema/signed_manifest.hpp) is signed and stored with it in that
// transaction, read again under the write lock to be sure it is the one published.
void publish_version(store::Store& s, const std::string& map, std::int64_t version, const signing::SigningKey* key);
// Rolls a map back (store::Store::rollback: a new version with the content of the one the current
// version replaced, so vehicles see the number grow) in one transaction with its upload log entry,
// signed with the key when one is given, as publish_version signs. Returns the new version.
std::int64_t rollback_version(store::Store& s, const std::string& map, const signing::SigningKey* key);

struct VersionDiff {
  std::size_t added = 0, removed = 0, changed = 0, unchanged = 0;
  std::string text;  // "+ TX TY", "- TX TY", "~ TX TY" lines (with the reason an update logged), then the counts
};
VersionDiff diff_versions(const store::Store& s, const std::string& map, std::int64_t from, std::int64_t to);

}  // namespace pl::maps
