// The tile client's pinned version: adopting a version (its manifest and index), signed manifests
// and the floor of verified versions, current-version statements, following and pinning.
#include "tile_client_impl.hpp"

namespace pl::client {

// Makes `m` the pinned version: its manifest, and the index: the whole version's rows when given
// (from its signed manifest), else the rows the disk cache learned.
// `key` and `places`: a signed version's key id and places hash.
void TileClient::Impl::adopt(const CachedManifest& m, std::optional<std::vector<CachedTile>> all_rows, const std::string& key, const std::optional<std::string>& places) {
  if (!wire::valid_tile_size(m.tile_size))  // (a manifest from the disk cache is checked here too)
    throw Error("map " + m.map + " version " + std::to_string(m.version) + ": tile size " + std::to_string(m.tile_size) +
                " m is not between 1 and 1000 m: delete the disk cache " + cfg.cache_path);
  TileGrid g(m.tile_size);  // throws for a bad tile size before anything changes
  const bool complete = all_rows.has_value();
  std::vector<CachedTile> rows = complete ? std::move(*all_rows) : disk.rows(m.map, m.version);
  disk.put_manifest(m);
  disk.forget_missing();
  broken.clear();
  by_key.clear();
  held_back.clear();
  blocked_gen = UINT64_MAX;
  std::lock_guard<std::mutex> lock(mu);
  if (ready && manifest.version != m.version) seeds.clear();  // a re-pin: the seeds were for the first version
  manifest = m;
  grid = g;
  pinned = m.version;
  index.clear();
  memory.clear();
  for (auto& r : rows) learn(std::move(r));
  if (complete) index.set_complete();
  signed_by = key;
  signed_places = places;
  ready = true;
  reports.version_adopted();
  changed.notify_all();
}

// Makes a verified signed manifest the pinned version, its tiles the whole index; keeps its body
// in the disk cache for a start with the server down.
void TileClient::Impl::adopt_signed(const signing::SignedManifest& sm, const std::string& body) {
  floor_manifest.reset();  // a version is adopted: what floor() kept is no longer needed
  const signing::Manifest& s = sm.manifest;
  CachedManifest m;
  m.map = cfg.map;
  m.version = s.version;
  m.tile_size = s.tile_size;
  m.voxel_size = s.voxel_size;
  m.origin = s.origin;
  std::vector<CachedTile> rows;
  rows.reserve(s.tiles.size());
  for (const auto& t : s.tiles) rows.push_back(CachedTile{t.key, t.hash, t.points});
  disk.put_signed_manifest(cfg.map, s.version, body);
  {
    std::lock_guard<std::mutex> lock(mu);
    newest_verified = std::max<long long>(newest_verified, s.version);
  }
  adopt(m, std::move(rows), signing::key_id(sm.public_key), s.places);
}

// The newest signed manifest the disk cache keeps, verified: where a restarted vehicle's floor
// starts. Once per client.
long long TileClient::Impl::floor() {
  if (!floor_loaded) {
    floor_loaded = true;
    const auto v = disk.newest_signed_version(cfg.map);
    const auto body = v ? disk.signed_manifest(cfg.map, *v) : std::nullopt;
    if (body) {
      try {
        floor_manifest.emplace(wire::verified_manifest(*body, trusted, cfg.map, *v), std::move(*body));
        std::lock_guard<std::mutex> lock(mu);
        newest_verified = std::max(newest_verified, *v);
      } catch (const wire::WireError& e) {
        reports.refused(Refused::manifest, "disk cache " + cfg.cache_path + ": the signed manifest of map " + cfg.map + " version " + std::to_string(*v) +
                        " kept there is refused (" + e.what() + "): it sets no floor");
      }
    }
  }
  std::lock_guard<std::mutex> lock(mu);
  return newest_verified;
}

void TileClient::Impl::refuse_older(long long offered, long long newest) {
  reports.refused("map " + cfg.map + ": the server names version " + std::to_string(offered) + " as the current one, older than version " +
                  std::to_string(newest) + " whose signed manifest this vehicle has verified: an old answer replayed by a cache or "
                  "the network, or a map store restored from an older copy. Version " + std::to_string(newest) +
                  " is used; to take an older version on purpose, pin it (TileClientConfig::version, pl-localize --map-version)");
}

// The version's signed manifest from the disk cache, verified again (one that does not verify is
// reported and left: the server's is fetched instead).
bool TileClient::Impl::adopt_signed_from_disk(long long version) {
  if (floor_manifest && floor_manifest->first.manifest.version == version) {
    const auto kept = std::move(*floor_manifest);
    floor_manifest.reset();
    adopt_signed(kept.first, kept.second);
    return true;
  }
  auto body = disk.signed_manifest(cfg.map, version);
  if (!body) return false;
  try {
    adopt_signed(wire::verified_manifest(*body, trusted, cfg.map, version), *body);
    return true;
  } catch (const wire::WireError& e) {
    reports.refused(Refused::manifest, "disk cache " + cfg.cache_path + ": the signed manifest of map " + cfg.map + " version " + std::to_string(version) +
                    " kept there is refused (" + e.what() + "): fetching it again");
    return false;
  }
}

// The version from the server, its signed manifest verified. Throws RequestFailed.
void TileClient::Impl::adopt_signed_from_server(long long version) {
  auto [sm, body] = server.signed_manifest(version, trusted);
  adopt_signed(sm, body);
}

// Under mu: records what the version holds at a key (a tile held for another hash goes).
void TileClient::Impl::learn(CachedTile t) {
  const MapTile* held = memory.find(t.key);
  if (held && held->hash != t.hash) memory.drop(t.key);
  index.learn(std::move(t));
}

// Not ready yet: the pinned version's manifest from the disk cache, else the map's current version
// from the server, else (server failing) the version last used from the disk cache.
bool TileClient::Impl::become_ready() {
  std::optional<long long> pin;
  {
    std::lock_guard<std::mutex> lock(mu);
    pin = pinned;
  }
  if (!trusted.empty()) return become_ready_signed(pin);
  if (pin) {
    if (auto m = disk.manifest(cfg.map, pin)) {
      adopt(*m);
      return true;
    }
  }
  if (server.may_ask()) {
    try {
      adopt(server.manifest(pin));
      return true;
    } catch (const RequestFailed&) {
    }
  }
  if (!pin) {
    if (auto m = disk.manifest(cfg.map, std::nullopt)) {
      adopt(*m);
      return true;
    }
  }
  return false;
}

// The same with fleet keys: only a version whose signed manifest verifies (the map's JSON
// manifest only says which version is current).
// Unpinned, never a version below the newest verified one (floor()); a pin is the integrator's
// choice and is followed.
bool TileClient::Impl::become_ready_signed(std::optional<long long> pin) {
  if (pin && adopt_signed_from_disk(*pin)) return true;
  const long long newest = pin ? 0 : floor();
  if (server.may_ask()) {
    try {
      long long version = pin ? *pin : !current_keys.empty() ? confirm_current() : server.manifest(std::nullopt).version;
      if (version < newest) {
        refuse_older(version, newest);
        if (adopt_signed_from_disk(newest)) return true;
        version = newest;
      }
      adopt_signed_from_server(version);
      return true;
    } catch (const RequestFailed&) {
    }
  }
  if (!pin) {
    if (newest > 0 && adopt_signed_from_disk(newest)) return true;
    if (auto m = disk.manifest(cfg.map, std::nullopt))
      if (m->version >= newest && adopt_signed_from_disk(m->version)) return true;
  }
  return false;
}

// With timestamp keys: the version a fresh current-version statement names, on the backoff every
// request waits for or, for a recheck, on `own`. Throws RequestFailed.
long long TileClient::Impl::confirm_current(Backoff* own) {
  const long long v = server.current(current_keys, own);
  confirmed_current = true;
  return v;
}

// Started (unpinned, with timestamp keys) without a fresh statement, on the newest verified
// version because the statement was refused or the server was out of reach: asks again after
// each backoff until one verifies, so that a refusal does not outlive the hold-back and status()
// says which version is current (a newer one than in use is the integrator's to pin). Returns
// whether it asked. Throws RequestFailed.
bool TileClient::Impl::recheck_current() {
  if (!unconfirmed() || !server.may_ask() || !recheck.allowed()) return false;
  confirm_current(&recheck);
  return true;
}

// With cfg.follow_s: asks which version is current when it is time (a fresh signed statement with
// timestamp keys, else the map answer). Returns whether it asked. Throws RequestFailed.
bool TileClient::Impl::follow() {
  if (cfg.follow_s <= 0 || Clock::now() < follow_at || !server.may_ask()) return false;
  follow_at = Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(cfg.follow_s));
  const long long v = !current_keys.empty() ? server.current(current_keys, nullptr) : server.manifest(std::nullopt).version;
  std::lock_guard<std::mutex> lock(mu);
  latest = v;
  return true;
}

// Returns false while a signed version's manifest cannot be had (the old version serves meanwhile).
bool TileClient::Impl::apply_pin(long long v) {
  CachedManifest m;
  {
    std::lock_guard<std::mutex> lock(mu);
    if (ready && manifest.version == v) return true;
    if (!ready) {
      pinned = v;
      return true;  // become_ready() picks it up
    }
    m = manifest;
  }
  if (!trusted.empty()) {
    if (adopt_signed_from_disk(v)) return true;
    if (!server.may_ask()) return false;
    try {
      adopt_signed_from_server(v);
      return true;
    } catch (const RequestFailed&) {
      return false;
    }
  }
  m.version = v;  // the tile size and origin are the map's; the server checks the version on the first ROI
  if (auto cached = disk.manifest(cfg.map, v)) m = *cached;
  adopt(m);
  return true;
}

}  // namespace pl::client
