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
//   tile_client_version.cpp  the pinned version: adopting, signed manifests, the floor, following
#include "tile_client_impl.hpp"

namespace pl::client {

std::size_t decoded_size(const TileCloud& c) { return 24 * c.points.size() + 12 * c.normals.size() + 4 * c.intensity.size(); }

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
