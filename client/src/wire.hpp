// What the tile client reads from pl-server's answers (schema/openapi.yaml): the manifest, region-
// of-interest answers, error bodies, tile bytes and places (and the one URL whose form is the client's
// own choice: a signed manifest's after a refusal). Pure functions over the bytes that arrived, so
// that they are tested and fuzzed without a network: anything a server (or whatever sits between it
// and the vehicle) sends is refused with a WireError naming what is wrong, never trusted.
// Private to pl_client; shared by the tile client and the client_answers fuzz target.
#pragma once

#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "pl/client/tile_cache.hpp"
#include "pl/client/tile_client.hpp"
#include "pl/common/tile_codec.hpp"
#include "pl/schema/api_rules.hpp"
#include "pl/schema/signed_current.hpp"
#include "pl/schema/signed_manifest.hpp"

namespace pl::client::wire {

// An answer that is not what the API promises; what() says how (without the "about" prefix).
struct WireError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// The rules both sides agree on (pl/schema/api_rules.hpp).
using api::is_hash;
using api::valid_map_name;
using api::valid_tile_size;

// GET /v1/maps/{map}: the manifest of `map`. The version is `pin` when given, else the map's
// current one (a WireError when it has none). tile_size must be valid_tile_size.
CachedManifest parse_manifest(std::string_view body, const std::string& map, std::optional<long long> pin);

// The manifest's "bounds" as an x, y extent when the manifest is of `version` (it gives its current
// version's) and the bounds are finite with min <= max; none otherwise (the extent is only a hint).
std::optional<MapExtent> parse_manifest_extent(std::string_view body, long long version);

// GET /v1/maps: the names of the server's maps.
std::vector<std::string> parse_map_names(std::string_view body);

// The target of GET /v1/maps/{map}/versions/{version}/manifest, after `refusals` signed manifests were
// refused: then with ?refused=N, another entry of any cache on the way, so that one poisoned cache
// entry does not keep vehicles off a signed map. The tile client and pl-fleet ask by it alike.
std::string signed_manifest_target(const std::string& map, long long version, int refusals);

// GET /v1/maps/{map}/versions/{v}/manifest with fleet keys: a signed manifest
// (pl/schema/signed_manifest.hpp) that verifies against one of `trusted` and is that of `map`
// version `version` (a signed manifest of another map or version, replayed, is refused too).
signing::SignedManifest verified_manifest(std::string_view body, const std::vector<std::string>& trusted, const std::string& map,
                                          long long version);

// How far the vehicle's clock and the map service's may disagree when a current-version statement's
// times are checked, s.
inline constexpr std::int64_t kClockSkewS = 60;

// The target of GET /v1/maps/{map}/current after `refusals` statements were refused (?refused=N:
// another entry of any cache on the way, as for signed manifests).
std::string current_target(const std::string& map, int refusals);

// GET /v1/maps/{map}/current with timestamp keys: a current-version statement
// (pl/schema/signed_current.hpp) that verifies against one of `trusted`, is `map`'s, and is valid at
// `now` (Unix seconds, give or take kClockSkewS).
signing::CurrentVersion verified_current(std::string_view body, const std::vector<std::string>& trusted, const std::string& map,
                                         std::int64_t now);

// GET /v1/maps/{map}/roi?...&version=V: the tiles listed (key, hash, points). The answer must be for
// `version` and `tile_size`; every tile needs integer keys, a valid hash and points >= 0.
std::vector<CachedTile> parse_roi(std::string_view body, long long version, double tile_size);

// What an error answer says: the "error" string of a JSON error body, else the start of the body
// (made valid UTF-8, at most 200 bytes); empty for an empty body.
std::string error_text(std::string_view body);

// Tile bytes fetched for `hash`: checked against the hash before anything else, then decoded.
// Throws WireError for bytes that do not match (naming both hashes); pl::Error for bytes that do
// but do not decode (a tile the store holds broken).
TileCloud verified_tile(std::string_view bytes, const std::string& hash);

// A version's places fetched with this ETag (the header's value; empty when there was none): 1 byte
// to api::kMaxPlacesBytes, and when the ETag names a content hash ("HASH", or W/"HASH" as a proxy
// may weaken it) the bytes' SHA-256 must be that hash. Throws WireError (naming both hashes).
void check_places(std::string_view bytes, std::string_view etag);

}  // namespace pl::client::wire
