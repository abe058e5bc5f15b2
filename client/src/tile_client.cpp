// The tile client: one background thread owns the HTTP connection and the disk cache connection; the
// localization loop reads the decoded tiles under a mutex and never touches the network.
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
#include <cctype>
#include <condition_variable>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <map>
#include <mutex>
#include <random>
#include <set>
#include <thread>
#include <utility>

#include "pl/schema/http_client.hpp"
#include "pl/client/tile_cache.hpp"
#include "pl/common/error.hpp"
#include "pl/schema/store.hpp"
#include "wire.hpp"

namespace pl::client {
using api::HttpClient;
using api::HttpResponse;
using api::url_encode;

using Clock = std::chrono::steady_clock;

std::size_t decoded_size(const TileCloud& c) { return 24 * c.points.size() + 12 * c.normals.size() + 4 * c.intensity.size(); }

namespace {

constexpr double kMaxRadius = 4000;     // focus and wait discs (the server answers ROI queries up to 5000 m)
constexpr double kMaxRoiRadius = 5000;  // the server's limit
constexpr std::size_t kMaxHave = 80;    // hashes in one have= (65 B each, well within the server's 8 KB of headers)
constexpr std::size_t kBytesPerPoint = 40;  // decoded_size of a point with normal and intensity: the most a tile takes

struct Disc {
  Eigen::Vector2d center;
  double radius;
};

// The test of TileGrid::keys_in_disc and of the server's ROI: does the tile's box touch the disc?
bool touches(const TileBounds& b, const Eigen::Vector2d& c, double r) {
  double dx = std::max({b.min_x - c.x(), 0.0, c.x() - b.max_x}), dy = std::max({b.min_y - c.y(), 0.0, c.y() - b.max_y});
  return dx * dx + dy * dy <= r * r;
}

double box_distance(const TileBounds& b, const Eigen::Vector2d& c) {
  double dx = std::max({b.min_x - c.x(), 0.0, c.x() - b.max_x}), dy = std::max({b.min_y - c.y(), 0.0, c.y() - b.max_y});
  return std::sqrt(dx * dx + dy * dy);
}

// Doubles in URLs: exact round trip, so the server tests the very disc the client reasons about.
std::string number(double v) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.17g", v);
  return buf;
}

std::string seconds(double s) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.1f s", s);
  return buf;
}

std::string key_name(const TileKey& k) { return std::to_string(k.tx) + "/" + std::to_string(k.ty); }

// Exponential backoff with +-20 % jitter (a fleet must not retry in step).
class Backoff {
 public:
  Backoff(double min_s, double max_s) : min_(min_s), max_(max_s), rng_(std::random_device{}()) {}
  bool allowed() const { return Clock::now() >= until_; }
  bool backing_off() const { return delay_ > 0; }
  Clock::time_point until() const { return until_; }
  double failed() {
    delay_ = delay_ == 0 ? min_ : std::min(2 * delay_, max_);
    double d = delay_ * std::uniform_real_distribution<double>(0.8, 1.2)(rng_);
    until_ = Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(d));
    return d;
  }
  void succeeded() {
    delay_ = 0;
    until_ = Clock::time_point{};
  }

 private:
  double min_, max_, delay_ = 0;
  Clock::time_point until_{};
  std::minstd_rand rng_;
};

// A failed request, already counted and described in the status: unwinds to the loop.
struct RequestFailed {};

}  // namespace

struct TileClient::Impl {
  // ---- fixed before the thread starts
  TileClientConfig cfg;
  std::size_t budget = 0;  // bytes of decoded tiles
  std::map<std::string, std::string> headers;

  // ---- the background thread's own
  std::unique_ptr<HttpClient> http;
  std::unique_ptr<TileCache> cache;
  Backoff backoff;
  int last_status = 0;                  // of the last answered request
  std::set<std::string> not_on_disk;    // hashes the disk cache does not hold
  std::set<std::string> broken;         // hashes whose bytes do not decode: skipped until the version changes
  std::map<std::string, TileKey> key_of_hash;
  bool have_usable = true;              // false once one hash shows at two keys: have= would hide one of them
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
  std::map<TileKey, CachedTile> index;  // the pinned version at each known key
  struct Slot {
    MapTile tile;
    std::size_t size = 0;        // decoded_size
    mutable std::uint64_t used;  // LRU stamp
  };
  std::map<TileKey, Slot> memory;
  std::size_t memory_bytes = 0;
  mutable std::uint64_t tick = 0;
  TileClientStatus st;  // counters, online, last_error

  std::thread thread;

  explicit Impl(TileClientConfig c) : cfg(std::move(c)), backoff(cfg.retry_min_s, cfg.retry_max_s) {}

  // ---------------------------------------------------------------------------------------------
  // Status

  void problem(const std::string& message) {
    std::lock_guard<std::mutex> lock(mu);
    st.last_error = message;
  }

  [[noreturn]] void failed(const std::string& message) {
    double wait = backoff.failed();
    {
      std::lock_guard<std::mutex> lock(mu);
      st.online = false;
      ++st.failures;
      st.last_error = message + " (retrying in " + seconds(wait) + ")";
    }
    throw RequestFailed{};
  }

  void succeeded() {
    backoff.succeeded();
    std::lock_guard<std::mutex> lock(mu);
    st.online = true;
    st.last_error.clear();
  }

  // GET on the kept-alive connection; returns 200 answers, counts and throws on anything else.
  // `about` says what was asked ("the manifest of map town"); `hint_404` what a 404 means to fix.
  HttpResponse get(const std::string& target, const std::string& about, const std::string& hint_404) {
    if (backoff.backing_off()) {
      std::lock_guard<std::mutex> lock(mu);
      ++st.retries;
    }
    HttpResponse res;
    try {
      res = http->get(target, headers);
    } catch (const std::exception& e) {
      last_status = 0;
      failed("cannot reach pl-server for " + about + " (" + e.what() +
             "): is it running and reachable? Serving the tiles in memory and in the disk cache meanwhile");
    }
    last_status = res.status;
    if (res.status == 200) {
      succeeded();
      return res;
    }
    const std::string said = wire::error_text(res.body);
    std::string what = about + ": " + cfg.server + " answered HTTP " + std::to_string(res.status) + (said.empty() ? "" : " \"" + said + "\"");
    if (res.status == 401) what += ": set TileClientConfig::token to a token with the read role";
    if (res.status == 403) what += ": the token needs the read role";
    if (res.status == 404 && !hint_404.empty()) what += ": " + hint_404;
    if (res.status >= 500) what += ": the server is failing or shutting down";
    failed(what);
  }

  // ---------------------------------------------------------------------------------------------
  // The disk cache: its failures are reported in the status, never fatal (the client goes on with
  // memory and the server).

  std::optional<CachedManifest> cached_manifest(std::optional<long long> version) {
    if (!cache) return std::nullopt;
    try {
      return version ? cache->manifest(cfg.map, *version) : cache->last_used(cfg.map);
    } catch (const Error& e) {
      problem(std::string("disk cache: ") + e.what());
      return std::nullopt;
    }
  }

  std::optional<std::string> disk_blob(const CachedTile& t) {
    bool corrupt = false;
    std::optional<std::string> bytes;
    try {
      bytes = cache->blob(t.hash, &corrupt);
    } catch (const Error& e) {
      problem(std::string("disk cache: ") + e.what());
    }
    if (corrupt) {
      std::lock_guard<std::mutex> lock(mu);
      ++st.corrupt;
      st.last_error = "disk cache " + cache->path() + ": tile " + key_name(t.key) + " of map " + cfg.map + " version " +
                      std::to_string(manifest.version) + " was damaged (its bytes no longer match SHA-256 " + t.hash +
                      "): dropped, fetching it again";
    }
    if (!bytes) not_on_disk.insert(t.hash);
    return bytes;
  }

  void disk_write(const std::function<void()>& write) {
    if (!cache) return;
    try {
      write();
    } catch (const Error& e) {
      problem(std::string("disk cache: ") + e.what() + " (going on without caching this)");
    }
  }

  // ---------------------------------------------------------------------------------------------
  // The pinned version

  // Makes `m` the pinned version: its manifest, and the index from the disk cache.
  void adopt(const CachedManifest& m) {
    if (!wire::valid_tile_size(m.tile_size))  // (a manifest from the disk cache is checked here too)
      throw Error("map " + m.map + " version " + std::to_string(m.version) + ": tile size " + std::to_string(m.tile_size) +
                  " m is not between 1 and 1000 m: delete the disk cache " + cfg.cache_path);
    TileGrid g(m.tile_size);  // throws for a bad tile size before anything changes
    std::vector<CachedTile> rows;
    if (cache) {
      try {
        rows = cache->tiles(m.map, m.version);
      } catch (const Error& e) {
        problem(std::string("disk cache: ") + e.what());
      }
    }
    disk_write([&] { cache->put_manifest(m); });
    not_on_disk.clear();
    broken.clear();
    key_of_hash.clear();
    have_usable = true;
    blocked_gen = UINT64_MAX;
    std::lock_guard<std::mutex> lock(mu);
    manifest = m;
    grid = g;
    pinned = m.version;
    index.clear();
    memory.clear();
    memory_bytes = 0;
    for (auto& r : rows) learn(std::move(r));
    ready = true;
    changed.notify_all();
  }

  // Under mu: records what the version holds at a key (a tile held for another hash goes).
  void learn(CachedTile t) {
    if (t.exists()) {
      auto [it, inserted] = key_of_hash.emplace(t.hash, t.key);
      if (!inserted && it->second != t.key) have_usable = false;
    }
    auto held = memory.find(t.key);
    if (held != memory.end() && held->second.tile.hash != t.hash) {
      memory_bytes -= held->second.size;
      memory.erase(held);
    }
    index[t.key] = std::move(t);
  }

  // Not ready yet: the pinned version's manifest from the disk cache, else the map's current version
  // from the server, else (server failing) the version last used from the disk cache.
  bool become_ready() {
    std::optional<long long> pin;
    {
      std::lock_guard<std::mutex> lock(mu);
      pin = pinned;
    }
    if (pin) {
      if (auto m = cached_manifest(pin)) {
        adopt(*m);
        return true;
      }
    }
    if (backoff.allowed()) {
      try {
        std::string about = "the manifest of map " + cfg.map;
        HttpResponse res = get("/v1/maps/" + url_encode(cfg.map), about, "check TileClientConfig::map");
        CachedManifest m;
        try {
          m = wire::parse_manifest(res.body, cfg.map, pin);
        } catch (const wire::WireError& e) {
          failed(about + ": " + e.what() + " (see the manifest in schema/openapi.yaml)");
        }
        adopt(m);
        return true;
      } catch (const RequestFailed&) {
      }
    }
    if (!pin) {
      if (auto m = cached_manifest(std::nullopt)) {
        adopt(*m);
        return true;
      }
    }
    return false;
  }

  void apply_pin(long long v) {
    CachedManifest m;
    {
      std::lock_guard<std::mutex> lock(mu);
      if (ready && manifest.version == v) return;
      pinned = v;
      if (!ready) return;  // become_ready() picks it up
      m = manifest;
    }
    m.version = v;  // the tile size and origin are the map's; the server checks the version on the first ROI
    if (auto cached = cached_manifest(v)) m = *cached;
    adopt(m);
  }

  // ---------------------------------------------------------------------------------------------
  // Planning

  struct Want {
    TileKey key;
    double distance;
  };
  struct Query {
    Disc disc;
    std::vector<std::string> have;
  };
  struct Plan {
    std::uint64_t gen = 0;
    std::vector<Want> wants;  // nearest first
    std::map<TileKey, std::size_t> rank;
    std::vector<Query> queries;  // discs with keys the index does not know
  };

  Plan make_plan() {
    std::lock_guard<std::mutex> lock(mu);
    Plan p;
    p.gen = gen;
    std::vector<Disc> discs;
    if (has_focus) {
      discs.push_back({now, cfg.radius_m});
      discs.push_back({ahead, cfg.radius_m});
    }
    for (const auto& [id, d] : waits) discs.push_back(d);
    std::map<TileKey, double> distance;
    for (const Disc& d : discs) {
      bool unknown = false;
      for (const TileKey& k : grid->keys_in_disc(d.center.x(), d.center.y(), d.radius)) {
        double dist = box_distance(grid->bounds_of(k), d.center);
        auto [it, inserted] = distance.emplace(k, dist);
        if (!inserted) it->second = std::min(it->second, dist);
        if (!index.count(k)) unknown = true;
      }
      if (!unknown) continue;
      // Ask a tile more than needed, so small moves do not ask again.
      Query q{{d.center, std::min(d.radius + std::max(manifest.tile_size, 1.0), kMaxRoiRadius)}, {}};
      if (have_usable)
        for (const TileKey& k : grid->keys_in_disc(q.disc.center.x(), q.disc.center.y(), q.disc.radius)) {
          auto it = index.find(k);
          if (it != index.end() && it->second.exists() && q.have.size() < kMaxHave) q.have.push_back(it->second.hash);
        }
      p.queries.push_back(std::move(q));
    }
    for (const auto& [k, d] : distance) p.wants.push_back({k, d});
    std::stable_sort(p.wants.begin(), p.wants.end(), [](const Want& a, const Want& b) { return a.distance < b.distance; });
    for (std::size_t i = 0; i < p.wants.size(); ++i) p.rank[p.wants[i].key] = i;
    return p;
  }

  // Under mu: the bytes that could be evicted to make room for the tile of rank `rank`: tiles
  // outside the plan, and planned tiles farther than it.
  std::size_t evictable(const Plan& plan, std::size_t rank) const {
    std::size_t n = 0;
    for (const auto& [k, slot] : memory) {
      auto r = plan.rank.find(k);
      if (r == plan.rank.end() || r->second > rank) n += slot.size;
    }
    return n;
  }

  bool fits(const Plan& plan, std::size_t rank, std::size_t size) {
    std::lock_guard<std::mutex> lock(mu);
    if (memory_bytes + size <= budget) return true;
    return memory_bytes + size <= budget + evictable(plan, rank);
  }

  // Under mu: evicts until `size` more bytes fit, least recently used outside the plan first, then
  // planned tiles farthest first. False (nothing evicted) when it cannot fit.
  bool make_room(const Plan& plan, std::size_t rank, std::size_t size) {
    if (memory_bytes + size > budget + evictable(plan, rank)) return false;
    while (memory_bytes + size > budget) {
      auto victim = memory.end();
      for (auto it = memory.begin(); it != memory.end(); ++it)
        if (!plan.rank.count(it->first) && (victim == memory.end() || it->second.used < victim->second.used)) victim = it;
      if (victim == memory.end()) {
        std::size_t worst = rank;
        for (auto it = memory.begin(); it != memory.end(); ++it) {
          std::size_t r = plan.rank.at(it->first);
          if (r > worst) worst = r, victim = it;
        }
      }
      if (victim == memory.end()) return false;
      memory_bytes -= victim->second.size;
      memory.erase(victim);
      ++st.evicted;
    }
    return true;
  }

  // ---------------------------------------------------------------------------------------------
  // Actions

  // A tile whose bytes match its hash but do not decode: left out (until the version changes).
  void undecodable(const CachedTile& t, const std::string& why) {
    broken.insert(t.hash);
    problem("tile " + key_name(t.key) + " of map " + cfg.map + " version " + std::to_string(manifest.version) + " (" + t.hash +
            ") does not decode (" + why + "): left out of the map; rebuild the tile and publish a new version");
  }

  // Decodes bytes already checked against their hash (the disk cache checks on read), then keeps the tile.
  bool keep_bytes(const CachedTile& t, const std::string& bytes, const Plan& plan, std::size_t rank, bool from_disk) {
    std::shared_ptr<const TileCloud> cloud;
    try {
      cloud = std::make_shared<const TileCloud>(decode_tile(bytes));
    } catch (const Error& e) {
      undecodable(t, e.what());
      return false;
    }
    return keep(t, std::move(cloud), bytes.size(), plan, rank, from_disk);
  }

  // Keeps a decoded tile, making room. Returns whether it was kept.
  bool keep(const CachedTile& t, std::shared_ptr<const TileCloud> cloud, std::size_t bytes, const Plan& plan, std::size_t rank,
            bool from_disk) {
    std::size_t size = decoded_size(*cloud);
    std::lock_guard<std::mutex> lock(mu);
    auto it = index.find(t.key);
    if (it == index.end() || it->second.hash != t.hash) return false;  // the version changed meanwhile
    if (!make_room(plan, rank, size)) {
      blocked_gen = plan.gen;
      return false;
    }
    memory[t.key] = Slot{MapTile{t.key, t.hash, std::move(cloud), bytes}, size, ++tick};
    memory_bytes += size;
    if (from_disk) ++st.from_disk;
    changed.notify_all();
    return true;
  }

  void fetch(const CachedTile& t, const Plan& plan, std::size_t rank) {
    std::string about = "tile " + key_name(t.key) + " (" + t.hash + ")";
    HttpResponse res;
    try {
      res = get("/v1/blobs/" + t.hash, about, "the key rows cached for map " + cfg.map + " version " + std::to_string(manifest.version) +
                                                   " are stale (was the map store rebuilt?); asking the server again");
    } catch (const RequestFailed&) {
      if (last_status == 404) {  // forget the row: the next ROI query learns the key afresh
        std::lock_guard<std::mutex> lock(mu);
        index.erase(t.key);
      }
      throw;
    }
    // The bytes are checked against the hash before anything else looks at them, then decoded;
    // only a tile that decodes is cached on disk.
    std::shared_ptr<const TileCloud> cloud;
    try {
      cloud = std::make_shared<const TileCloud>(wire::verified_tile(res.body, t.hash));
    } catch (const wire::WireError& e) {
      failed(about + ": " + e.what());
    } catch (const Error& e) {
      undecodable(t, e.what());
      return;
    }
    {
      std::lock_guard<std::mutex> lock(mu);
      ++st.fetched;
    }
    disk_write([&] { cache->put_blob(t.hash, res.body); });
    if (cache) not_on_disk.erase(t.hash);
    keep(t, std::move(cloud), res.body.size(), plan, rank, false);
  }

  void roi(const Query& q) {
    long long version = manifest.version;
    std::string about = "the tiles of map " + cfg.map + " version " + std::to_string(version) + " around (" + number(q.disc.center.x()) +
                        ", " + number(q.disc.center.y()) + ")";
    std::string target = "/v1/maps/" + url_encode(cfg.map) + "/roi?x=" + number(q.disc.center.x()) + "&y=" + number(q.disc.center.y()) +
                         "&radius=" + number(q.disc.radius) + "&version=" + std::to_string(version);
    if (!q.have.empty()) {
      target += "&have=";
      for (std::size_t i = 0; i < q.have.size(); ++i) target += (i ? "," : "") + q.have[i];
    }
    HttpResponse res = get(target, about, pinned_hint());
    std::vector<CachedTile> rows;
    std::set<TileKey> answered;
    try {
      rows = wire::parse_roi(res.body, version, manifest.tile_size);
    } catch (const wire::WireError& e) {
      failed(about + ": " + e.what() + " (see the ROI answer in schema/openapi.yaml)");
    }
    for (const auto& r : rows) answered.insert(r.key);
    // Keys of the disc that the answer leaves out and the index does not know hold no tile (have=
    // only leaves out tiles the index knows). Just inside the disc: clear of rounding at its edge.
    for (const TileKey& k : grid->keys_in_disc(q.disc.center.x(), q.disc.center.y(), std::max(0.0, q.disc.radius - 0.01)))
      if (!answered.count(k) && !index.count(k)) rows.push_back(CachedTile{k, {}, 0});
    disk_write([&] { cache->put_tiles(cfg.map, version, rows); });
    std::lock_guard<std::mutex> lock(mu);
    for (auto& r : rows) learn(std::move(r));
    changed.notify_all();
  }

  std::string pinned_hint() const {
    return "is version " + std::to_string(manifest.version) + " of map " + cfg.map + " published on this server? Pin one that is";
  }

  struct Outcome {
    bool did = false;          // something was done: plan again at once
    bool network_due = false;  // work waits for the server
  };

  Outcome step(const Plan& plan) {
    Outcome o;
    bool blocked = plan.gen == blocked_gen;
    std::vector<std::pair<CachedTile, std::size_t>> from_server;  // with their rank
    for (std::size_t rank = 0; rank < plan.wants.size() && !blocked; ++rank) {
      CachedTile t;
      {
        std::lock_guard<std::mutex> lock(mu);
        auto it = index.find(plan.wants[rank].key);
        if (it == index.end() || !it->second.exists() || memory.count(it->first)) continue;
        t = it->second;
      }
      if (broken.count(t.hash)) continue;
      if (!fits(plan, rank, kBytesPerPoint * static_cast<std::size_t>(std::max(0LL, t.points)))) {
        blocked = true;  // nor any farther tile
        break;
      }
      if (cache && !not_on_disk.count(t.hash)) {
        if (auto bytes = disk_blob(t)) {
          keep_bytes(t, *bytes, plan, rank, true);
          o.did = true;
          return o;
        }
      }
      from_server.emplace_back(std::move(t), rank);
    }
    o.network_due = !plan.queries.empty() || !from_server.empty();
    if (!o.network_due || !backoff.allowed()) return o;
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
        if (repin) apply_pin(*repin);
        bool is_ready;
        {
          std::lock_guard<std::mutex> lock(mu);
          is_ready = ready;
        }
        if (!is_ready) {
          if (!become_ready()) sleep(0, true);
          continue;
        }
        Plan plan = make_plan();
        Outcome o = step(plan);
        if (!o.did) sleep(plan.gen, o.network_due);
      } catch (const RequestFailed&) {
        // counted and described; the backoff is running and the next step works from memory and disk
      } catch (const std::exception& e) {
        problem(std::string("tile client: ") + e.what());
        std::unique_lock<std::mutex> lock(mu);
        wake.wait_for(lock, std::chrono::duration<double>(cfg.retry_max_s), [&] { return stop || pin_request.has_value(); });
      }
    }
  }

  // Sleeps until the plan changes (or stop, or a new pin), and when work waits for the server,
  // at most until the backoff ends.
  void sleep(std::uint64_t plan_gen, bool network_due) {
    std::unique_lock<std::mutex> lock(mu);
    auto woken = [&] { return stop || pin_request.has_value() || (ready && gen != plan_gen); };
    if (network_due)
      wake.wait_until(lock, backoff.until(), woken);
    else
      wake.wait(lock, woken);
  }

  // Under mu: every key of the disc is known, and each tile it holds is in memory.
  bool complete(const Disc& d) const {
    if (!ready) return false;
    for (const TileKey& k : grid->keys_in_disc(d.center.x(), d.center.y(), d.radius)) {
      auto it = index.find(k);
      if (it == index.end() || (it->second.exists() && !memory.count(k))) return false;
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
  impl_ = std::make_unique<Impl>(std::move(cfg));
  Impl& m = *impl_;
  m.budget = static_cast<std::size_t>(m.cfg.memory_mb * 1024 * 1024);
  if (!m.cfg.token.empty()) m.headers["Authorization"] = "Bearer " + m.cfg.token;
  m.http = std::make_unique<HttpClient>(m.cfg.server, m.cfg.timeout_s);  // throws for a malformed URL
  // Opened here so that a bad path fails at once; used by the background thread only from now on.
  if (!m.cfg.cache_path.empty()) m.cache = std::make_unique<TileCache>(m.cfg.cache_path);
  m.pinned = m.cfg.version;
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
  auto deadline = Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(std::max(0.0, timeout_s)));
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
  std::vector<MapTile> out;
  std::lock_guard<std::mutex> lock(impl_->mu);
  if (!impl_->ready) return out;
  for (const auto& [key, slot] : impl_->memory)
    if (touches(impl_->grid->bounds_of(key), center, radius)) {
      slot.used = ++impl_->tick;
      out.push_back(slot.tile);
    }
  return out;
}

bool TileClient::wait_for(const Eigen::Vector2d& center, double radius, double timeout_s) {
  if (!center.allFinite() || !(radius >= 0 && radius <= kMaxRadius))
    throw Error("TileClient::wait_for: the center must be finite and the radius between 0 and " + number(kMaxRadius) + " m");
  Impl& m = *impl_;
  Disc disc{center, radius};
  auto deadline = Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(std::max(0.0, timeout_s)));
  std::unique_lock<std::mutex> lock(m.mu);
  std::uint64_t id = m.next_wait++;
  m.waits[id] = disc;
  m.bump();
  bool done = m.changed.wait_until(lock, deadline, [&] { return m.stop || m.complete(disc); }) && !m.stop;
  m.waits.erase(id);
  m.bump();
  return done;
}

void TileClient::pin_version(long long version) {
  if (version < 1) throw Error("TileClient::pin_version: versions are numbered from 1, got " + std::to_string(version));
  std::lock_guard<std::mutex> lock(impl_->mu);
  impl_->pin_request = version;
  impl_->bump();
}

TileClientStatus TileClient::status() const {
  std::lock_guard<std::mutex> lock(impl_->mu);
  TileClientStatus s = impl_->st;
  s.ready = impl_->ready;
  s.version = impl_->ready ? impl_->manifest.version : 0;
  s.tile_size = impl_->ready ? impl_->manifest.tile_size : 0;
  s.tiles_in_memory = impl_->memory.size();
  s.bytes_in_memory = impl_->memory_bytes;
  return s;
}

}  // namespace pl::client
