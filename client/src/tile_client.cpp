// The tile client: one background thread owns the HTTP connection (TileServer) and the disk cache
// connection (DiskCache); the localization loop reads the decoded tiles under a mutex and never
// touches the network. This file is the orchestration: the shared state, the thread's loop and the
// public API. Its parts, each in its own header:
//   fetch_plan.hpp     which tiles are wanted, nearest first, and which discs to ask the server about
//   tile_memory.hpp    the decoded tiles held within the memory budget, and what to evict for a tile
//   tile_index.hpp     what the pinned version holds at each known key
//   tile_server.hpp    requests to pl-server, their checks and the backoff (backoff.hpp)
//   disk_cache.hpp     the disk cache, its failures reported and never fatal
//   client_status.hpp  the counters and last problem behind status()
// places() is apart from the thread: the caller's own request (fetch_places in tile_server.hpp),
// its answer kept per version.
//
// The thread repeats one step at a time, re-planning after each (so a new focus takes effect at
// once): plan the wanted keys (the discs around the focus points and any wait_for disc, nearest
// first), then do the first of
//   1. load a wanted tile that the index knows and the disk cache holds,
//   2. ask the server about a wanted disc with keys the index does not know (ROI query),
//   3. fetch a wanted tile that the index knows but the disk cache does not hold,
// and sleep when there is nothing to do (until the focus changes) or the server is backing off
// (until the backoff ends). The index maps each known key of the pinned version to its tile's hash
// or to "no tile here"; it comes from ROI answers and the disk cache.
#include "pl/client/tile_client.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdint>
#include <map>
#include <mutex>
#include <set>
#include <thread>
#include <utility>

#include "client_status.hpp"
#include "client_text.hpp"
#include "disk_cache.hpp"
#include "fetch_plan.hpp"
#include "pl/common/error.hpp"
#include "pl/schema/signed_manifest.hpp"
#include "pl/schema/store.hpp"
#include "tile_index.hpp"
#include "tile_memory.hpp"
#include "tile_server.hpp"
#include "wire.hpp"

namespace pl::client {

using Clock = std::chrono::steady_clock;

std::size_t decoded_size(const TileCloud& c) { return 24 * c.points.size() + 12 * c.normals.size() + 4 * c.intensity.size(); }

namespace {

constexpr double kMaxRadius = 4000;         // focus and wait discs (the server answers ROI queries up to 5000 m)
constexpr std::size_t kBytesPerPoint = 40;  // decoded_size of a point with normal and intensity: the most a tile takes
// A tile whose bytes were refused by both its URLs is left alone this long (the others come meanwhile).
constexpr std::chrono::seconds kHoldBack{30};

Clock::time_point deadline_in(double timeout_s) {
  return Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(std::max(0.0, timeout_s)));
}

}  // namespace

struct TileClient::Impl {
  // ---- fixed before the thread starts
  TileClientConfig cfg;
  std::vector<std::string> trusted;  // the fleet's public keys (cfg.fleet_keys); empty: signatures not checked
  std::vector<std::string> current_keys;  // the timestamp keys (cfg.timestamp_keys); empty: the map answer's current version
  bool confirmed_current = false;         // (the thread's) a fresh statement verified this run
  Backoff recheck;                        // (the thread's) the pace of asking again after a refused statement

  // ---- the background thread's own (status reports are read by status())
  ClientStatus reports;
  TileServer server;
  DiskCache disk;
  std::set<std::string> broken;            // hashes whose bytes do not decode: skipped until the version changes
  // Hashes whose fetched bytes did not match: asked for by their key's URL next (another entry of
  // any HTTP cache on the way), and when that fails too, left alone for a while so that the other
  // tiles come meanwhile.
  std::set<std::string> by_key;
  std::map<std::string, Clock::time_point> held_back;
  std::optional<long long> pending_pin;  // a pin whose signed manifest could not be had yet: the old version serves meanwhile
  std::uint64_t blocked_gen = UINT64_MAX;  // a tile did not fit in memory for this plan: wait for a change

  // ---- shared with the caller's threads, under mu (the thread reads its own writes without it)
  mutable std::mutex mu;
  std::condition_variable wake;     // the thread: a change to act on
  std::condition_variable changed;  // waiters: ready, tiles arrived, keys learned
  bool stop = false;
  std::uint64_t gen = 0;  // bumped by every change of focus, wait discs or pinned version
  bool has_focus = false;
  Eigen::Vector2d now = Eigen::Vector2d::Zero(), ahead = Eigen::Vector2d::Zero();
  std::map<std::uint64_t, Disc> waits;
  std::uint64_t next_wait = 0;
  std::optional<long long> pin_request;
  std::optional<long long> pinned;
  bool ready = false;
  CachedManifest manifest;
  std::optional<TileGrid> grid;
  TileIndex index;    // the pinned version at each known key
  TileMemory memory;  // the decoded tiles

  // ---- places(): its callers, one at a time under places_mu
  std::mutex places_mu;
  std::optional<long long> places_version;  // the version whose answer is kept
  std::optional<std::string> places_bytes;  // that answer: the bytes, or nothing (it has none)
  std::string signed_by;                    // under mu: the key id of the version in use (with fleet keys)
  // Under mu. With fleet keys: the highest version of the map whose signed manifest this client has
  // verified (the newest kept in the disk cache, checked at the first start, then every version
  // adopted). Unpinned, a current version below it is refused: a cache or network replaying an old
  // answer cannot take the vehicle back to an older map. (A rollback publishes a new, higher
  // version with the old content: store::Store::rollback.)
  long long newest_verified = 0;
  bool floor_loaded = false;  // the background thread's own: the disk cache's newest was looked at
  // The background thread's own: floor()'s verified manifest and its body, kept until the start has
  // adopted a version, so adopting the floor version does not read and verify it again.
  std::optional<std::pair<signing::SignedManifest, std::string>> floor_manifest;
  std::optional<std::string> signed_places; // under mu: with fleet keys, the places' hash the version's manifest gives (none: it has none)

  // Under mu: seed()'s tiles by hash.
  std::map<std::string, MapTile> seeds;
  std::size_t seeded = 0;  // under mu
  long long latest = 0;    // under mu: the current version the server named last (cfg.follow_s)
  // The thread's: when to ask which version is current next (cfg.follow_s).
  Clock::time_point follow_at = Clock::time_point::min();

  std::thread thread;

  // Throws pl::Error for a malformed server URL, then for a disk cache it cannot open.
  Impl(TileClientConfig c, std::vector<std::string> keys, std::vector<std::string> timestamp_keys)
      : cfg(std::move(c)),
        trusted(std::move(keys)),
        current_keys(std::move(timestamp_keys)),
        recheck(cfg.retry_min_s, cfg.retry_max_s),
        server(cfg, reports),
        disk(cfg.cache_path, reports),
        pinned(cfg.version),
        memory(static_cast<std::size_t>(cfg.memory_mb * 1024 * 1024)) {}

  // ---------------------------------------------------------------------------------------------
  // The pinned version

  // Makes `m` the pinned version: its manifest, and the index: the whole version's rows when given
  // (from its signed manifest), else the rows the disk cache learned.
  // `key` and `places`: a signed version's key id and places hash.
  void adopt(const CachedManifest& m, std::optional<std::vector<CachedTile>> all_rows = std::nullopt, const std::string& key = "",
             const std::optional<std::string>& places = std::nullopt) {
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

  // ---- signed versions (with fleet keys)

  // Makes a verified signed manifest the pinned version, its tiles the whole index; keeps its body
  // in the disk cache for a start with the server down.
  void adopt_signed(const signing::SignedManifest& sm, const std::string& body) {
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
  long long floor() {
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

  void refuse_older(long long offered, long long newest) {
    reports.refused("map " + cfg.map + ": the server names version " + std::to_string(offered) + " as the current one, older than version " +
                    std::to_string(newest) + " whose signed manifest this vehicle has verified: an old answer replayed by a cache or "
                    "the network, or a map store restored from an older copy. Version " + std::to_string(newest) +
                    " is used; to take an older version on purpose, pin it (TileClientConfig::version, pl-localize --map-version)");
  }

  // The version's signed manifest from the disk cache, verified again (one that does not verify is
  // reported and left: the server's is fetched instead).
  bool adopt_signed_from_disk(long long version) {
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
  void adopt_signed_from_server(long long version) {
    auto [sm, body] = server.signed_manifest(version, trusted);
    adopt_signed(sm, body);
  }

  // Under mu: records what the version holds at a key (a tile held for another hash goes).
  void learn(CachedTile t) {
    const MapTile* held = memory.find(t.key);
    if (held && held->hash != t.hash) memory.drop(t.key);
    index.learn(std::move(t));
  }

  // Not ready yet: the pinned version's manifest from the disk cache, else the map's current version
  // from the server, else (server failing) the version last used from the disk cache.
  bool become_ready() {
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
  bool become_ready_signed(std::optional<long long> pin) {
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
  long long confirm_current(Backoff* own = nullptr) {
    const long long v = server.current(current_keys, own);
    confirmed_current = true;
    return v;
  }

  // Started (unpinned, with timestamp keys) without a fresh statement, on the newest verified
  // version because the statement was refused or the server was out of reach: asks again after
  // each backoff until one verifies, so that a refusal does not outlive the hold-back and status()
  // says which version is current (a newer one than in use is the integrator's to pin). Returns
  // whether it asked. Throws RequestFailed.
  bool unconfirmed() const { return !current_keys.empty() && !confirmed_current && !cfg.version; }
  bool recheck_current() {
    if (!unconfirmed() || !server.may_ask() || !recheck.allowed()) return false;
    confirm_current(&recheck);
    return true;
  }

  // With cfg.follow_s: asks which version is current when it is time (a fresh signed statement with
  // timestamp keys, else the map answer). Returns whether it asked. Throws RequestFailed.
  bool follow() {
    if (cfg.follow_s <= 0 || Clock::now() < follow_at || !server.may_ask()) return false;
    follow_at = Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(cfg.follow_s));
    const long long v = !current_keys.empty() ? server.current(current_keys, nullptr) : server.manifest(std::nullopt).version;
    std::lock_guard<std::mutex> lock(mu);
    latest = v;
    return true;
  }

  // Returns false while a signed version's manifest cannot be had (the old version serves meanwhile).
  bool apply_pin(long long v) {
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

  // ---------------------------------------------------------------------------------------------
  // Actions

  FetchPlan plan() {
    std::lock_guard<std::mutex> lock(mu);
    std::vector<Disc> discs;
    if (has_focus) {
      discs.push_back({now, cfg.radius_m});
      discs.push_back({ahead, cfg.radius_m});
    }
    for (const auto& [id, d] : waits) discs.push_back(d);
    return make_plan(*grid, discs, index, gen);
  }

  // A tile whose bytes match its hash but do not decode: left out (until the version changes).
  void undecodable(const CachedTile& t, const std::string& why) {
    broken.insert(t.hash);
    reports.problem("tile " + key_name(t.key) + " of map " + cfg.map + " version " + std::to_string(manifest.version) + " (" + t.hash +
                    ") does not decode (" + why + "): left out of the map; rebuild the tile and publish a new version");
  }

  // Keeps a decoded tile, making room. Returns whether it was kept.
  bool keep(const CachedTile& t, std::shared_ptr<const TileCloud> cloud, std::size_t bytes, const FetchPlan& plan, std::size_t rank,
            bool from_disk) {
    std::size_t size = decoded_size(*cloud);
    std::lock_guard<std::mutex> lock(mu);
    const CachedTile* row = index.find(t.key);
    if (!row || row->hash != t.hash) return false;  // the version changed meanwhile
    auto evicted = memory.make_room(plan, rank, size);
    if (!evicted) {
      blocked_gen = plan.gen;
      return false;
    }
    if (!evicted->empty()) reports.tiles_evicted(evicted->size());
    memory.put(MapTile{t.key, t.hash, std::move(cloud), bytes}, size);
    if (from_disk) reports.tile_from_disk();
    changed.notify_all();
    return true;
  }

  // Decodes bytes from the disk cache (which checked them against their hash), then keeps the tile.
  void load_from_disk(const CachedTile& t, const std::string& bytes, const FetchPlan& plan, std::size_t rank) {
    std::shared_ptr<const TileCloud> cloud;
    try {
      cloud = std::make_shared<const TileCloud>(decode_tile(bytes));
    } catch (const Error& e) {
      undecodable(t, e.what());
      return;
    }
    keep(t, std::move(cloud), bytes.size(), plan, rank, true);
  }

  // Fetches a tile from the server (checked against its hash, decoded), caches it on disk, keeps it.
  void fetch(const CachedTile& t, const FetchPlan& plan, std::size_t rank) {
    std::optional<TileServer::Blob> blob;
    const bool second_try = by_key.count(t.hash) > 0;
    try {
      blob = server.blob(t, manifest.version, second_try);
    } catch (const RequestFailed&) {
      if (server.last_rejected()) {
        if (second_try) {
          by_key.erase(t.hash);
          held_back[t.hash] = Clock::now() + kHoldBack;
        } else {
          by_key.insert(t.hash);
        }
      } else if (server.last_status() == 404 && !index.complete()) {  // forget the row: the next ROI query learns the key afresh
        std::lock_guard<std::mutex> lock(mu);
        index.forget(t.key);
      }
      throw;
    } catch (const UndecodableTile& e) {
      undecodable(t, e.what());
      return;
    }
    by_key.erase(t.hash);
    reports.tile_fetched();
    disk.put_blob(t.hash, blob->bytes);  // only a tile that decodes is cached
    keep(t, std::make_shared<const TileCloud>(std::move(blob->cloud)), blob->bytes.size(), plan, rank, false);
  }

  // Whether a tile whose bytes were refused twice is still left alone.
  bool is_held_back(const std::string& hash) {
    auto it = held_back.find(hash);
    if (it == held_back.end()) return false;
    if (Clock::now() < it->second) return true;
    held_back.erase(it);
    return false;
  }

  // Asks the server about a disc and learns its keys.
  void roi(const RoiQuery& q) {
    long long version = manifest.version;
    std::vector<CachedTile> listed = server.roi(q, version, manifest.tile_size);
    // Just inside the disc: clear of rounding at its edge.
    std::vector<CachedTile> rows =
        rows_of_answer(std::move(listed), grid->keys_in_disc(q.disc.center.x(), q.disc.center.y(), std::max(0.0, q.disc.radius - 0.01)), index);
    disk.put_tiles(cfg.map, version, rows);
    std::lock_guard<std::mutex> lock(mu);
    for (auto& r : rows) learn(std::move(r));
    changed.notify_all();
  }

  struct Outcome {
    bool did = false;          // something was done: plan again at once
    bool network_due = false;  // work waits for the server
  };

  Outcome step(const FetchPlan& plan) {
    Outcome o;
    bool blocked = plan.gen == blocked_gen;
    std::vector<std::pair<CachedTile, std::size_t>> from_server;  // with their rank
    for (std::size_t rank = 0; rank < plan.wants.size() && !blocked; ++rank) {
      CachedTile t;
      {
        std::lock_guard<std::mutex> lock(mu);
        const CachedTile* row = index.find(plan.wants[rank].key);
        if (!row || !row->exists() || memory.holds(row->key) || broken.count(row->hash) || is_held_back(row->hash)) continue;
        if (!memory.fits(plan, rank, kBytesPerPoint * static_cast<std::size_t>(std::max(0LL, row->points)))) {
          blocked = true;  // nor any farther tile
          break;
        }
        t = *row;
        const auto seed = seeds.find(t.hash);
        if (seed != seeds.end()) {  // the same bytes another version's client holds decoded
          const MapTile tile = seed->second;
          seeds.erase(seed);
          std::size_t size = decoded_size(*tile.cloud);
          auto evicted = memory.make_room(plan, rank, size);
          if (!evicted) {
            blocked_gen = plan.gen;
            return o;
          }
          if (!evicted->empty()) reports.tiles_evicted(evicted->size());
          memory.put(MapTile{t.key, t.hash, tile.cloud, tile.bytes}, size);
          ++seeded;
          changed.notify_all();
          o.did = true;
          return o;
        }
      }
      if (disk.may_hold(t.hash)) {
        if (auto bytes = disk.blob(t, cfg.map, manifest.version)) {
          load_from_disk(t, *bytes, plan, rank);
          o.did = true;
          return o;
        }
      }
      from_server.emplace_back(std::move(t), rank);
    }
    o.network_due = !plan.queries.empty() || !from_server.empty();
    if (!o.network_due || !server.may_ask()) return o;
    o.did = true;
    if (!plan.queries.empty())
      roi(plan.queries.front());
    else
      fetch(from_server.front().first, plan, from_server.front().second);
    return o;
  }

  // ---------------------------------------------------------------------------------------------
  // The thread

  void run() {
    while (true) {
      std::optional<long long> repin;
      {
        std::lock_guard<std::mutex> lock(mu);
        if (stop) return;
        repin = std::exchange(pin_request, std::nullopt);
      }
      try {
        if (repin) pending_pin = *repin;
        if (pending_pin && apply_pin(*pending_pin)) pending_pin.reset();
        bool is_ready;
        {
          std::lock_guard<std::mutex> lock(mu);
          is_ready = ready;
        }
        if (!is_ready) {
          if (!become_ready()) sleep(0, true);
          continue;
        }
        if (recheck_current()) continue;
        if (follow()) continue;
        FetchPlan p = plan();
        Outcome o = step(p);
        auto wake_at = unconfirmed() ? recheck.until() : kNever;
        if (cfg.follow_s > 0) wake_at = std::min(wake_at, follow_at);
        if (!o.did) sleep(p.gen, o.network_due || pending_pin.has_value(), wake_at);
      } catch (const RequestFailed&) {
        // counted and described; the backoff is running and the next step works from memory and disk
      } catch (const std::exception& e) {
        reports.problem(std::string("tile client: ") + e.what());
        std::unique_lock<std::mutex> lock(mu);
        wake.wait_for(lock, std::chrono::duration<double>(cfg.retry_max_s), [&] { return stop || pin_request.has_value(); });
      }
    }
  }

  // Sleeps until the plan changes (or stop, or a new pin); when work waits for the server, at most
  // until the backoff ends; and at most until `recheck_at` (a current-version statement to ask for
  // again), or the backoff's end if later.
  static constexpr Backoff::Clock::time_point kNever = Backoff::Clock::time_point::max();
  void sleep(std::uint64_t plan_gen, bool network_due, Backoff::Clock::time_point recheck_at = kNever) {
    std::unique_lock<std::mutex> lock(mu);
    auto woken = [&] { return stop || pin_request.has_value() || (ready && gen != plan_gen); };
    auto until = network_due ? server.retry_at() : kNever;
    if (recheck_at != kNever) until = std::min(until, std::max(recheck_at, server.retry_at()));
    if (until != kNever)
      wake.wait_until(lock, until, woken);
    else
      wake.wait(lock, woken);
  }

  // Under mu: every key of the disc is known, and each tile it holds is in memory.
  bool complete(const Disc& d) const {
    if (!ready) return false;
    for (const TileKey& k : grid->keys_in_disc(d.center.x(), d.center.y(), d.radius)) {
      const CachedTile* row = index.find(k);
      if (!row || (row->exists() && !memory.holds(k))) return false;
    }
    return true;
  }

  void bump() {  // under mu
    ++gen;
    wake.notify_all();
  }
};

// -------------------------------------------------------------------------------------------------
TileClient::TileClient(TileClientConfig cfg) {
  auto need = [](bool ok, const std::string& what) {
    if (!ok) throw Error("TileClientConfig: " + what);
  };
  need(wire::valid_map_name(cfg.map), "map must be a map name ([A-Za-z0-9_.-], 1 to 64 characters), got \"" + cfg.map + "\"");
  need(!cfg.version || *cfg.version >= 1, "version must be 1 or more (or left empty for the map's current version)");
  need(cfg.memory_mb > 0 && std::isfinite(cfg.memory_mb), "memory_mb must be a positive number of MiB");
  need(cfg.radius_m >= 0 && cfg.radius_m <= kMaxRadius, "radius_m must be between 0 and " + number(kMaxRadius) + " m");
  need(cfg.timeout_s > 0 && std::isfinite(cfg.timeout_s), "timeout_s must be a positive number of seconds");
  need(cfg.retry_min_s > 0 && cfg.retry_max_s >= cfg.retry_min_s && std::isfinite(cfg.retry_max_s),
       "retry_min_s must be positive and retry_max_s at least retry_min_s");
  need(cfg.follow_s >= 0 && std::isfinite(cfg.follow_s), "follow_s must be 0 (stay on the version) or a number of seconds");
  // The disk cache is opened here so that a bad path fails at once; used by the background thread
  // only from now on.
  auto load = [](const std::string& file, const char* name) {
    try {
      return file.empty() ? std::vector<std::string>{} : signing::load_public_keys(file);
    } catch (const Error& e) {
      throw Error(std::string("TileClientConfig: ") + name + ": " + e.what());
    }
  };
  std::vector<std::string> keys = load(cfg.fleet_keys, "fleet_keys"), timestamp_keys = load(cfg.timestamp_keys, "timestamp_keys");
  need(timestamp_keys.empty() || !keys.empty(),
       "timestamp_keys needs fleet_keys too: a statement that a version is current is worth something only for versions whose signed "
       "manifests are checked");
  impl_ = std::make_unique<Impl>(std::move(cfg), std::move(keys), std::move(timestamp_keys));
  Impl& m = *impl_;
  m.thread = std::thread([&m] { m.run(); });
}

TileClient::~TileClient() {
  {
    std::lock_guard<std::mutex> lock(impl_->mu);
    impl_->stop = true;
    impl_->wake.notify_all();
    impl_->changed.notify_all();
  }
  impl_->thread.join();
}

bool TileClient::wait_ready(double timeout_s) {
  std::unique_lock<std::mutex> lock(impl_->mu);
  auto deadline = deadline_in(timeout_s);
  impl_->changed.wait_until(lock, deadline, [&] { return impl_->ready || impl_->stop; });
  return impl_->ready;
}

void TileClient::set_focus(const Eigen::Vector2d& now, const Eigen::Vector2d& ahead) {
  if (!now.allFinite() || !ahead.allFinite()) throw Error("TileClient::set_focus: the positions must be finite (is the pose estimate diverging?)");
  std::lock_guard<std::mutex> lock(impl_->mu);
  if (impl_->has_focus && impl_->now == now && impl_->ahead == ahead) return;
  impl_->has_focus = true;
  impl_->now = now;
  impl_->ahead = ahead;
  impl_->bump();
}

std::vector<MapTile> TileClient::tiles_near(const Eigen::Vector2d& center, double radius) const {
  std::lock_guard<std::mutex> lock(impl_->mu);
  if (!impl_->ready) return {};
  return impl_->memory.use_near(*impl_->grid, center, radius);
}

bool TileClient::wait_for(const Eigen::Vector2d& center, double radius, double timeout_s) {
  if (!center.allFinite() || !(radius >= 0 && radius <= kMaxRadius))
    throw Error("TileClient::wait_for: the center must be finite and the radius between 0 and " + number(kMaxRadius) + " m");
  Impl& m = *impl_;
  Disc disc{center, radius};
  auto deadline = deadline_in(timeout_s);
  std::unique_lock<std::mutex> lock(m.mu);
  std::uint64_t id = m.next_wait++;
  m.waits[id] = disc;
  m.bump();
  bool done = m.changed.wait_until(lock, deadline, [&] { return m.stop || m.complete(disc); }) && !m.stop;
  m.waits.erase(id);
  m.bump();
  return done;
}

void TileClient::seed(const std::vector<MapTile>& tiles) {
  std::lock_guard<std::mutex> lock(impl_->mu);
  for (const MapTile& t : tiles)
    if (t.cloud) impl_->seeds.emplace(t.hash, t);
  impl_->bump();
}

void TileClient::pin_version(long long version) {
  if (version < 1) throw Error("TileClient::pin_version: versions are numbered from 1, got " + std::to_string(version));
  std::lock_guard<std::mutex> lock(impl_->mu);
  impl_->pin_request = version;
  impl_->bump();
}

std::optional<std::string> TileClient::places(double timeout_s) {
  if (!(timeout_s >= 0) || !std::isfinite(timeout_s))
    throw Error("TileClient::places: the timeout must be a number of seconds >= 0, got " + number(timeout_s));
  Impl& m = *impl_;
  const auto deadline = deadline_in(timeout_s);
  // One caller at a time (a second one waits for the first's fetch, itself bounded by its timeout).
  // A plain mutex: ThreadSanitizer misreads std::timed_mutex's timed lock as an unlock of an
  // unlocked mutex.
  std::lock_guard<std::mutex> one_at_a_time(m.places_mu);
  long long version = 0;
  std::optional<std::string> signed_hash;
  {
    std::unique_lock<std::mutex> lock(m.mu);
    if (!m.changed.wait_until(lock, deadline, [&] { return m.ready || m.stop; }) || m.stop) return std::nullopt;
    version = m.manifest.version;
    signed_hash = m.signed_places;
  }
  if (m.places_version == version) return m.places_bytes;
  const double left = std::chrono::duration<double>(deadline - Clock::now()).count();
  if (left <= 0) return std::nullopt;
  try {
    std::optional<std::string> got;
    if (m.trusted.empty() || signed_hash) got = fetch_places(m.cfg, version, left);  // (a signed version without places has none)
    if (got && !m.trusted.empty() && store::content_hash(*got) != *signed_hash) {
      m.reports.refused(Refused::places, "the places of map " + m.cfg.map + " version " + std::to_string(version) + " refused: their SHA-256 is not the " +
                  *signed_hash + " the version's signed manifest gives (altered in a cache or on the network?); ask again later");
      return std::nullopt;
    }
    m.places_version = version;
    m.places_bytes = std::move(got);
    m.reports.places_fetched();
  } catch (const Error& e) {
    m.reports.problem(e.what());
    return std::nullopt;
  }
  return m.places_bytes;
}

TileClientStatus TileClient::status() const {
  std::lock_guard<std::mutex> lock(impl_->mu);
  TileClientStatus s = impl_->reports.snapshot();
  s.ready = impl_->ready;
  s.version = impl_->ready ? impl_->manifest.version : 0;
  s.tile_size = impl_->ready ? impl_->manifest.tile_size : 0;
  if (impl_->ready) s.origin = impl_->manifest.origin;
  s.signed_by = impl_->signed_by;
  s.newest_verified = impl_->newest_verified;
  s.tiles_in_memory = impl_->memory.count();
  s.bytes_in_memory = impl_->memory.bytes();
  s.latest = impl_->latest;
  s.seeded = impl_->seeded;
  return s;
}

}  // namespace pl::client
