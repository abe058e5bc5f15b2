// The localizer's tile client: keeps the decoded map tiles around the vehicle in memory, fetched from
// pl-server on one background thread so that the localization loop never waits on the network.
//
// - The map version is pinned for the drive: the configured one, or the map's current version at
//   start (with the server down: the version last used from the disk cache). It changes only through
//   pin_version().
// - For the focus (where the vehicle is, and where it is predicted to be soon) the thread asks the
//   server which tiles lie within radius_m (ROI queries over one kept-alive HTTP/1.1 connection, with
//   have= naming the tiles it already knows), then loads each missing tile nearest first: from the
//   disk cache when there, else GET /v1/blobs/{hash}. Bytes are checked against their SHA-256 before
//   they are decoded, stored or kept.
// - The disk cache (optional, SQLite) keeps tile bytes, the version's manifest and every key -> hash
//   row learned, so that a restarted client localizes with the server down. A cache entry whose bytes
//   no longer match their hash is dropped and fetched again, never decoded into the map.
// - Memory holds at most memory_mb of decoded tiles; to make room the thread evicts the least
//   recently used tiles outside the focus discs first, then focus tiles farther than the one it loads.
// - While the server is down, slow or answering errors the thread retries with exponential backoff
//   (with jitter), keeps serving what memory and disk hold, and says what is wrong in status().
// - The pinned version's places (its place-recognition descriptors) are fetched on request
//   (places()), once, and kept in memory.
// - With fleet_keys (signed maps), a version is used only once its signed manifest verifies against
//   one of the fleet's public keys; its tiles and their hashes are then all known from it (no ROI
//   queries), so a tile is used only with the bytes its publisher signed. A manifest that does not
//   verify is refused and the tiles in use stay, and the next try asks by another URL
//   (.../manifest?refused=N: another HTTP cache entry, past a poisoned one); tile bytes that do
//   not match are refused, asked for once more by another URL (GET .../versions/{v}/tiles/{tx}/{ty}:
//   another HTTP cache entry), then left alone for 30 s while the other tiles come. Each refusal counts in status().rejected.
//   Unpinned, the client never starts on a version below the highest one whose signed manifest it
//   has verified (status().newest_verified, kept across starts by the disk cache): a current
//   version below it is refused (counted, said in last_error) and that highest one is used. The map
//   service's rollbacks publish new, higher versions, so only a replayed answer or a store restored
//   from an older copy goes back; a pinned version (cfg.version, pin_version) is taken as asked.
// - With timestamp_keys as well, "current" is what the map service vouches for fresh: unpinned, the
//   client starts on the version a current-version statement (pl/schema/signed_current.hpp, GET
//   /v1/maps/{map}/current) names once it verifies against one of those keys, is the map's and has
//   not expired by the vehicle's clock (give or take wire::kClockSkewS, 60 s). One that fails any of
//   that is refused (counted; it stands in last_error until a good one comes) and the client starts
//   on the newest version it has verified (its disk cache's), or waits while it has none, asking
//   again by another URL (.../current?refused=N). So an answer held back by a cache or the network
//   hides a newer version for at most the statement's lifetime (pl-server --timestamp-lifetime). The
//   statement is asked for at start; a running client stays on its version (pin_version changes it).
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "pl/client/map_tile.hpp"
#include "pl/common/geo.hpp"
#include "pl/common/tile_codec.hpp"
#include "pl/common/tile_key.hpp"

namespace pl::client {

// What a decoded tile counts against TileClientConfig::memory_mb: 24 B per point, 12 per normal,
// 4 per intensity.
std::size_t decoded_size(const TileCloud& cloud);

struct TileClientConfig {
  std::string server;                // "https://maps.example:443"; http:// only to this machine unless insecure_http
  std::string map;                   // map name
  std::optional<long long> version;  // pinned version; default: the map's current version at start
                                     // (or, with the server down, the version last used from the disk cache)
  std::string cache_path;            // SQLite disk cache file; empty = no disk cache
  double memory_mb = 256;            // bound on decoded tiles in memory (MiB, see decoded_size)
  double radius_m = 100;             // keep tiles within this radius of the focus (and of the look-ahead point)
  double timeout_s = 2.0;            // per request
  double retry_min_s = 0.2, retry_max_s = 5.0;  // exponential backoff while the server is down/erroring
  std::string token;                 // bearer token when the server requires one for reads
  std::string ca_file;               // https: PEM file of the CA the server's certificate must chain to; empty: the system's
  bool insecure_http = false;        // allow plain http:// to another machine (maps and token in clear)
  // PEM file of the fleet's Ed25519 public key(s) (pl-map key-gen). When set, a version is used only
  // once its signed manifest (pl/schema/signed_manifest.hpp) verifies against one of them, and each
  // tile only with the hash that manifest gives it: a tile or manifest altered anywhere between the
  // store and the vehicle is refused (counted in status().rejected) and never used. Empty: versions
  // are not checked for signatures (tile bytes are still checked against the server's hashes).
  std::string fleet_keys;
  // PEM file of the map service's timestamp public key(s) (the public half of pl-server
  // --timestamp-key; needs fleet_keys): unpinned, start only on the version a fresh signed
  // current-version statement names, or on the newest this vehicle has verified (above). Empty: the
  // map answer's current version is taken as it comes (above the newest verified).
  std::string timestamp_keys;
  // Seconds between asking the server which version of the map is current, while the client runs
  // (status().latest; with timestamp_keys only a fresh signed statement counts); 0: never (the
  // version is the drive's). The client stays on its version: moving is the caller's (the vehicle
  // localizer moves at a safe moment, with a second client that loads the new version first).
  double follow_s = 0;
};

struct TileClientStatus {
  bool ready = false;   // a version and tile size are known (from the server or the cache)
  bool online = false;  // the last request to the server succeeded
  long long version = 0;
  double tile_size = 0;
  GeoPoint origin;       // of the map's ENU frame (the manifest's), once ready
  std::size_t tiles_in_memory = 0, bytes_in_memory = 0;  // bytes: decoded_size of the tiles held
  std::size_t fetched = 0;    // tiles fetched from the server
  std::size_t from_disk = 0;  // tiles loaded from the disk cache
  std::size_t failures = 0;   // requests that failed (unreachable, timeout, error status, bad bytes)
  std::size_t retries = 0;    // requests sent again after a failure (one per backoff step)
  std::size_t corrupt = 0;    // disk cache entries dropped because their bytes no longer matched
  std::size_t rejected = 0;   // answers refused and never used: tile bytes that did not match their hash,
                              // signed manifests that did not verify (altered in a cache or on the network)
  std::string signed_by;      // with fleet_keys: the id of the key the version in use is signed with
  long long newest_verified = 0;  // with fleet_keys: the highest version of the map whose signed manifest
                                  // this vehicle has verified (this run or kept in its disk cache)
  long long confirmed_version = 0;  // with timestamp_keys: the version the last fresh current-version statement
  long long confirmed_until = 0;    // named, and when it expires (Unix seconds); 0: none verified this run
  long long latest = 0;       // with follow_s: the current version the server named last (0: not asked yet)
  std::size_t seeded = 0;     // tiles taken from seed() instead of loaded
  std::size_t evicted = 0;    // tiles dropped from memory to stay within memory_mb
  std::optional<MapExtent> extent;  // of the map's current version, from the server's manifest (none: not
                                    // given, or the version came from the disk cache)
  std::string last_error;     // the last problem, naming what to do; empty when fine (cleared by
                              // the next successful request, except a refusal: that stands until a
                              // version is adopted, the tile fetched or the places fetched)
};

class TileClient {
 public:
  // Checks the configuration and opens the disk cache (throws pl::Error naming the problem), then
  // starts the background thread. Never blocks on the network.
  explicit TileClient(TileClientConfig cfg);
  ~TileClient();  // stops and joins the thread (waits for at most one request's timeout)
  TileClient(const TileClient&) = delete;
  TileClient& operator=(const TileClient&) = delete;

  // Until a version and the tile size are known (from the server or the disk cache). Returns whether.
  bool wait_ready(double timeout_s);

  // Where the vehicle is and where it is predicted to be soon: the background thread fetches,
  // verifies, caches, decodes and keeps every tile within radius_m of either point, nearest first.
  // Cheap: call it every scan.
  void set_focus(const Eigen::Vector2d& now, const Eigen::Vector2d& ahead);

  // Snapshot of the decoded tiles in memory whose box intersects the disc, ordered by key. Never
  // blocks on the network.
  std::vector<MapTile> tiles_near(const Eigen::Vector2d& center, double radius) const;

  // For start-up: also loads the disc (as a focus) and blocks until every tile of it that exists in
  // the pinned version is in memory, or the timeout. Returns whether complete. Offline it completes
  // only for discs the disk cache knows (the keys a server answer covered).
  bool wait_for(const Eigen::Vector2d& center, double radius, double timeout_s);

  // Switches to another version of the map: memory is emptied and filled again for the focus
  // (from the disk cache where the versions share tiles).
  void pin_version(long long version);

  // Decoded tiles of another version of this map (another client's, tiles_near): where this
  // client's version holds a tile with the same hash, the tile is taken from here instead of the
  // disk or the server (a map update changes a few tiles; the others are the same bytes). Kept until
  // this client's version changes; the clouds are shared, not copied.
  void seed(const std::vector<MapTile>& tiles);

  // The places of the version in use (status().version): opaque bytes (the place-recognition
  // descriptors built with the map). Blocks for at most about timeout_s: until a version is known,
  // then for GET /v1/maps/{map}/versions/{v}/places on the caller's thread (over a connection of
  // its own, never the background thread's). The answer is kept in memory for the version: the
  // bytes (checked against their ETag), or that the server has none for it (HTTP 404); either is
  // returned at once by later calls, and places(0) returns only what is kept. Nothing also when the
  // server cannot be reached or fails within the timeout (status().last_error says why; the next
  // call asks again). Not kept in the disk cache. Throws pl::Error for a timeout that is not a
  // number >= 0.
  std::optional<std::string> places(double timeout_s);

  TileClientStatus status() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace pl::client
