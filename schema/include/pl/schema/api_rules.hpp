// The rules pl-server and its clients (the vehicle's tile client, pl-map push, the disk cache) must
// agree on, written once: what a map name, a content hash and a tile size may be, how large a
// region-of-interest query may get and how large a version's places may be. schema/openapi.yaml
// states the same in words.
#pragma once

#include <cstddef>
#include <string_view>

namespace pl::api {

// A map name: 1 to 64 of [A-Za-z0-9_.-] (safe in URLs and file names as it is).
constexpr std::size_t kMaxMapNameLength = 64;
bool valid_map_name(std::string_view name);

// A content hash (a tile's ETag, a blob's name): SHA-256 as 64 lowercase hex digits.
bool is_hash(std::string_view text);

// The tile sizes maps are made with. A tiny size from a hostile server or a crafted cache would make
// a 100 m disc billions of tile keys.
constexpr double kMinTileSizeM = 1.0, kMaxTileSizeM = 1000.0;
bool valid_tile_size(double metres);

// The largest radius a region-of-interest query may ask for.
constexpr double kMaxRoiRadiusM = 5000.0;

// The largest places blob of a map version (its place-recognition descriptors): what the store
// keeps, pl-server takes in a PUT and the tile client accepts.
constexpr std::size_t kMaxPlacesBytes = std::size_t{64} << 20;

}  // namespace pl::api
