// The tile client's state and its background thread's steps (TileClient::Impl), shared by
// tile_client.cpp (the actions, the thread's loop, the public API) and tile_client_version.cpp (the
// pinned version). Private to pl_client.
#pragma once

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
#include "tile_normals.hpp"
#include "tile_server.hpp"
#include "wire.hpp"

namespace pl::client {

using Clock = std::chrono::steady_clock;



constexpr double kMaxRadius = 4000;         // focus and wait discs (the server answers ROI queries up to 5000 m)
constexpr std::size_t kBytesPerPoint = 40;  // decoded_size of a point with normal and intensity: the most a tile takes
// A tile whose bytes were refused by both its URLs is left alone this long (the others come meanwhile).
constexpr std::chrono::seconds kHoldBack{30};

inline Clock::time_point deadline_in(double timeout_s) {
  return Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(std::max(0.0, timeout_s)));
}

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
  void adopt(const CachedManifest& m, std::optional<std::vector<CachedTile>> all_rows = std::nullopt, const std::string& key = "", const std::optional<std::string>& places = std::nullopt);

  // ---- signed versions (with fleet keys)

  // Makes a verified signed manifest the pinned version, its tiles the whole index; keeps its body
  // in the disk cache for a start with the server down.
  void adopt_signed(const signing::SignedManifest& sm, const std::string& body);

  // The newest signed manifest the disk cache keeps, verified: where a restarted vehicle's floor
  // starts. Once per client.
  long long floor();

  void refuse_older(long long offered, long long newest);

  // The version's signed manifest from the disk cache, verified again (one that does not verify is
  // reported and left: the server's is fetched instead).
  bool adopt_signed_from_disk(long long version);

  // The version from the server, its signed manifest verified. Throws RequestFailed.
  void adopt_signed_from_server(long long version);

  // Under mu: records what the version holds at a key (a tile held for another hash goes).
  void learn(CachedTile t);

  // Not ready yet: the pinned version's manifest from the disk cache, else the map's current version
  // from the server, else (server failing) the version last used from the disk cache.
  bool become_ready();

  // The same with fleet keys: only a version whose signed manifest verifies (the map's JSON
  // manifest only says which version is current).
  // Unpinned, never a version below the newest verified one (floor()); a pin is the integrator's
  // choice and is followed.
  bool become_ready_signed(std::optional<long long> pin);

  // With timestamp keys: the version a fresh current-version statement names, on the backoff every
  // request waits for or, for a recheck, on `own`. Throws RequestFailed.
  long long confirm_current(Backoff* own = nullptr);

  // Started (unpinned, with timestamp keys) without a fresh statement, on the newest verified
  // version because the statement was refused or the server was out of reach: asks again after
  // each backoff until one verifies, so that a refusal does not outlive the hold-back and status()
  // says which version is current (a newer one than in use is the integrator's to pin). Returns
  // whether it asked. Throws RequestFailed.
  bool unconfirmed() const { return !current_keys.empty() && !confirmed_current && !cfg.version; }
  bool recheck_current();

  // With cfg.follow_s: asks which version is current when it is time (a fresh signed statement with
  // timestamp keys, else the map answer). Returns whether it asked. Throws RequestFailed.
  bool follow();

  // Returns false while a signed version's manifest cannot be had (the old version serves meanwhile).
  bool apply_pin(long long v);

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
      cloud = with_normals(decode_tile(bytes), manifest.voxel_size);
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
    keep(t, with_normals(std::move(blob->cloud), manifest.voxel_size), blob->bytes.size(), plan, rank, false);
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

}  // namespace pl::client
