// The tile client's use of its optional disk cache (TileCache, SQLite): every failure is reported in
// the ClientStatus and never fatal (the client goes on with memory and the server); a damaged entry
// is counted and reported as it is dropped; the hashes found missing are remembered, so that they are
// fetched rather than looked up again. Without a cache file every read finds nothing and every write
// does nothing. Used by the background thread only. Private to pl_client.
#pragma once

#include <memory>
#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <vector>

#include "client_status.hpp"
#include "pl/client/tile_cache.hpp"

namespace pl::client {

class DiskCache {
 public:
  // Opens the cache file (none when `path` is empty); throws pl::Error naming a file it cannot use.
  DiskCache(const std::string& path, ClientStatus& status);

  bool enabled() const { return cache_ != nullptr; }

  // The manifest of `version` of the map, or (no version) the one last used.
  std::optional<CachedManifest> manifest(const std::string& map, std::optional<long long> version);
  // The key -> hash rows known of the version (none when they cannot be read).
  std::vector<CachedTile> rows(const std::string& map, long long version);
  // Whether the blob of `hash` may be on disk: a cache is open and the hash was not found missing.
  bool may_hold(const std::string& hash) const { return cache_ && !missing_.count(hash); }
  // The bytes of the tile `t` of (map, version) as stored (checked against the hash on read); empty
  // when not there or damaged (then dropped). Either way the hash is remembered as missing.
  std::optional<std::string> blob(const CachedTile& t, const std::string& map, long long version);

  // A version's signed manifest as the server sent it (the caller verifies it).
  std::optional<std::string> signed_manifest(const std::string& map, long long version);
  void put_signed_manifest(const std::string& map, long long version, std::string_view body);
  // The highest version of the map whose signed manifest is kept (the caller verifies it).
  std::optional<long long> newest_signed_version(const std::string& map);

  void put_manifest(const CachedManifest& m);
  void put_tiles(const std::string& map, long long version, const std::vector<CachedTile>& rows);
  void put_blob(const std::string& hash, std::string_view bytes);  // no longer counted missing, stored or not

  // Forgets the hashes found missing (another version is pinned).
  void forget_missing() { missing_.clear(); }

 private:
  template <typename F>
  void write(F&& f);

  ClientStatus& status_;
  std::unique_ptr<TileCache> cache_;
  std::set<std::string> missing_;  // hashes the disk cache does not hold
};

}  // namespace pl::client
