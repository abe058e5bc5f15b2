// A virtual vehicle: its clock and driving, what it asks next, its answers and its memory bound.
// Its life, on its strand:
//   1. at its start time (spread over ramp_s) it asks for the map's manifest (GET /v1/maps/{map};
//      with fleet keys then the version's signed manifest), as the tile client does before it is ready;
//   2. parked at its route's start, it focuses there (set_focus(xy, xy) and wait_for the localizer's
//      ROI disc, as VehicleLocalizer starts) until every tile of that disc is there, or start_wait_s;
//   3. then it drives: each scan moves it along its route, focuses on (xy, xy + lookahead_s * v)
//      and counts the tiles of the localizer's ROI disc it lacks.
// Between scans its one connection does what the tile client's thread does, one request at a time,
// re-planning after each: the first ROI query of the plan, else the nearest wanted tile the index
// knows and memory lacks; nothing while backing off.
#include "vehicle.hpp"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <mutex>
#include <utility>

#include "pl/schema/http_client.hpp"
#include "pl/schema/signed_current.hpp"
#include "pl/schema/signed_manifest.hpp"
#include "pl/schema/store.hpp"
#include "report.hpp"
#include "wire.hpp"

namespace pl::fleet {

namespace net = boost::asio;
namespace beast = boost::beast;
using client::CachedManifest;
using client::CachedTile;
using client::FetchPlan;
using client::TileIndex;

namespace {

constexpr std::size_t kBytesPerPoint = 40;           // the tile client's bound on a decoded point
constexpr auto kHoldBack = std::chrono::seconds(30);  // a tile refused by both its URLs is left this long

std::string num(double v) {
  char b[64];
  std::snprintf(b, sizeof b, "%.3f", v);
  return b;
}

}  // namespace

Vehicle::Vehicle(net::io_context& ioc, Shared& sh, int id)
    : sh_(sh),
      strand_(net::make_strand(ioc)),
      conn_(strand_, sh),
      tick_(strand_),
      wake_(strand_),
      rng_(seeded(sh.o.seed, id)),
      backoff_(sh.o.retry_min_s, sh.o.retry_max_s, static_cast<unsigned>(rng_())) {
  rep_.id = id;
  rep_.speed = std::uniform_real_distribution<double>(sh.o.speed_min, sh.o.speed_max)(rng_);
  rep_.start_s = std::uniform_real_distribution<double>(0, sh.o.ramp_s)(rng_);
  route_.emplace(sh.extent, sh.o.block_m, rep_.speed * sh.o.duration_s + 200, rng_);
  pos_ = route_->start();
}

void Vehicle::go() {
  tick_.expires_at(sh_.start + dur(rep_.start_s));
  tick_.async_wait([self = shared_from_this()](beast::error_code ec) { self->on_tick(ec); });
}

VehicleReport Vehicle::report() {
  rep_.tile_latency = summarize(tile_ms_);
  rep_.roi_latency = summarize(roi_ms_);
  return rep_;
}

// Each vehicle's own random numbers: the same for the same seed and vehicle, whatever the threads.
std::mt19937_64 Vehicle::seeded(unsigned long long seed, int id) {
  std::seed_seq seq{static_cast<std::uint32_t>(seed), static_cast<std::uint32_t>(seed >> 32), static_cast<std::uint32_t>(id), 0x666c74u};
  return std::mt19937_64(seq);
}

// ---- the clock: one tick a scan
void Vehicle::on_tick(const beast::error_code& ec) {
  if (ec || phase_ == Phase::Stopped) return;
  const auto now = Clock::now();
  if (now >= sh_.end) {  // the end: no more requests; the one in flight is answered first
    stopping_ = true;
    if (!busy_) stop();
    return;
  }
  if (phase_ == Phase::Waiting) {
    phase_ = Phase::Starting;
    started_ = now;
  }
  if (phase_ == Phase::Starting) {
    focus_now_ = focus_ahead_ = pos_;
    const bool complete = ready_ && start_complete();
    if (complete || secs(now - started_) >= sh_.o.start_wait_s) {
      phase_ = Phase::Driving;
      driving_since_ = last_scan_ = now;
      rep_.driving_s = secs(now - sh_.start);
      sh_.driving.fetch_add(1, std::memory_order_relaxed);
    }
  }
  if (phase_ == Phase::Driving) scan(now);
  pump();
  // The next scan a period after this one was due (a late one does not shift the rest), never in
  // the past (a vehicle that fell behind skips the scans it missed).
  tick_.expires_at(std::max(tick_.expiry() + dur(1.0 / sh_.o.scan_hz), now));
  tick_.async_wait([self = shared_from_this()](beast::error_code e) { self->on_tick(e); });
}

void Vehicle::stop() {
  phase_ = Phase::Stopped;
  conn_.stop();
  wake_.cancel();
}

// A scan: move along the route, focus, count the needed tiles missing.
void Vehicle::scan(Clock::time_point now) {
  const Eigen::Vector2d last = pos_;
  pos_ = route_->at(rep_.speed * secs(now - driving_since_));
  const double dt = secs(now - last_scan_);
  const Eigen::Vector2d v = dt > 0 ? Eigen::Vector2d((pos_ - last) / dt) : Eigen::Vector2d::Zero();
  rep_.distance_m += (pos_ - last).norm();
  last_scan_ = now;
  focus_now_ = pos_;
  focus_ahead_ = pos_ + sh_.o.lookahead_s * v;
  ++rep_.scans;
  sh_.scans.fetch_add(1, std::memory_order_relaxed);
  std::size_t missing = 0;
  for (const TileKey& k : truth_grid_.keys_in_disc(pos_.x(), pos_.y(), sh_.o.roi_radius_m)) {
    auto t = sh_.truth.find(k);
    if (t == sh_.truth.end()) continue;
    auto p = present_.find(k);
    if (p == present_.end() || p->second.hash != t->second) ++missing;
  }
  if (missing) {
    ++rep_.stalled_scans;
    rep_.missing_tiles += missing;
    sh_.stalled.fetch_add(1, std::memory_order_relaxed);
  }
}

// wait_for's test at the start: every key of the localizer's disc known, each tile there present.
bool Vehicle::start_complete() const {
  for (const TileKey& k : grid_->keys_in_disc(pos_.x(), pos_.y(), sh_.o.roi_radius_m)) {
    const CachedTile* row = index_->find(k);
    if (!row || (row->exists() && !present_.count(k))) return false;
  }
  return true;
}

// ---- what to ask next: the tile client's step()
void Vehicle::pump() {
  if (busy_ || stopping_ || phase_ == Phase::Stopped || phase_ == Phase::Waiting) return;
  const auto now = Clock::now();
  if (!backoff_.allowed(now)) return arm_wake(backoff_.until());
  if (!ready_) {
    if (!version_ && !sh_.current_keys.empty())
      return send(Kind::Current, client::wire::current_target(sh_.o.map, current_refusals_));
    if (!version_)
      return send(Kind::Manifest, "/v1/maps/" + api::url_encode(sh_.o.map));
    // After a refusal, by another URL (another cache entry), as the tile client asks.
    return send(Kind::Signed, client::wire::signed_manifest_target(sh_.o.map, *version_, manifest_refusals_));
  }
  const FetchPlan& plan = current_plan(now);
  if (!plan.queries.empty()) {
    const client::RoiQuery& q = plan.queries.front();
    std::string target = "/v1/maps/" + api::url_encode(sh_.o.map) + "/roi?x=" + num(q.disc.center.x()) + "&y=" +
                         num(q.disc.center.y()) + "&radius=" + num(q.disc.radius) + "&version=" + std::to_string(manifest_.version);
    if (!q.have.empty()) {
      target += "&have=";
      for (std::size_t i = 0; i < q.have.size(); ++i) target += (i ? "," : "") + q.have[i];
      ++rep_.roi_with_have;
    }
    roi_disc_ = q.disc;
    return send(Kind::Roi, target);
  }
  // Nearest first. The tiles before plan_cursor_ are in memory or absent from the version: for one
  // plan that stays so (memory drops only tiles outside the discs), so the next look starts there.
  bool advance = true;
  for (std::size_t i = plan_cursor_; i < plan.wants.size(); ++i) {
    const CachedTile* row = index_->find(plan.wants[i].key);
    if (!row || !row->exists() || present_.count(plan.wants[i].key)) {
      if (advance) plan_cursor_ = i + 1;
      continue;
    }
    if (held_back(row->hash, now)) {
      advance = false;
      continue;
    }
    asked_ = *row;
    asked_by_key_ = by_key_.count(row->hash) > 0;
    const std::string target = asked_by_key_ ? "/v1/maps/" + api::url_encode(sh_.o.map) + "/versions/" + std::to_string(manifest_.version) +
                                                   "/tiles/" + std::to_string(row->key.tx) + "/" + std::to_string(row->key.ty)
                                             : "/v1/blobs/" + row->hash;
    return send(Kind::Tile, target);
  }
}

// make_plan for the focus discs. Its result depends only on the discs and the index, so it is kept
// until either changes (the tile client plans again after every step; the plan it gets is the
// same). A vehicle whose discs hold nothing to do is not planned for at all: what the plan would
// say, found for a fraction of make_plan's cost (thousands of vehicles scan at 10 Hz).
const FetchPlan& Vehicle::current_plan(Clock::time_point now) {
  static const FetchPlan kNothing;
  if (plan_ && planned_now_ == focus_now_ && planned_ahead_ == focus_ahead_ && planned_index_ == index_gen_) return *plan_;
  plan_.reset();
  if (!anything_to_do(now)) {
    plan_cursor_ = 0;
    return kNothing;
  }
  plan_ = client::make_plan(*grid_, {{focus_now_, sh_.o.radius_m}, {focus_ahead_, sh_.o.radius_m}}, *index_);
  plan_cursor_ = 0;
  planned_now_ = focus_now_, planned_ahead_ = focus_ahead_, planned_index_ = index_gen_;
  return *plan_;
}

// Whether a focus disc holds a key the index does not know (an ROI query to make) or a known tile
// not in memory and not held back (a tile to fetch).
bool Vehicle::anything_to_do(Clock::time_point now) {
  for (const Eigen::Vector2d& c : {focus_now_, focus_ahead_})
    for (const TileKey& k : grid_->keys_in_disc(c.x(), c.y(), sh_.o.radius_m)) {
      const CachedTile* row = index_->find(k);
      if (!row) return true;
      if (row->exists() && !present_.count(k) && !held_back(row->hash, now)) return true;
    }
  return false;
}

TileIndex& Vehicle::index_w() {
  if (own_ != index_) {
    own_ = std::make_shared<TileIndex>(*index_);
    index_ = own_;
  }
  return *own_;
}

bool Vehicle::held_back(const std::string& hash, Clock::time_point now) {
  auto it = held_.find(hash);
  if (it == held_.end()) return false;
  if (now < it->second) return true;
  held_.erase(it);
  return false;
}

void Vehicle::arm_wake(Clock::time_point at) {
  if (wake_armed_) return;
  wake_armed_ = true;
  wake_.expires_at(at);
  wake_.async_wait([self = shared_from_this()](beast::error_code ec) {
    self->wake_armed_ = false;
    if (!ec) self->pump();
  });
}

// ---- one request on the kept-alive connection, and its outcome
void Vehicle::send(Kind kind, std::string target) {
  busy_ = true;
  kind_ = kind;
  target_ = std::move(target);
  if (backoff_.backing_off()) ++rep_.retries;
  switch (kind) {
    case Kind::Manifest:
    case Kind::Current:
    case Kind::Signed: ++rep_.manifest_requests; break;
    case Kind::Roi:
      ++rep_.roi_queries;
      sh_.roi_queries.fetch_add(1, std::memory_order_relaxed);
      break;
    case Kind::Tile:
      ++rep_.tile_requests;
      sh_.tile_requests.fetch_add(1, std::memory_order_relaxed);
      break;
  }
  sent_at_ = Clock::now();
  resent_ = false;
  exchange();
}

void Vehicle::exchange() {
  conn_.get(target_, [self = shared_from_this()](const beast::error_code& ec) {
    if (ec) return self->transport_failed(ec);
    self->answered();
  });
}

void Vehicle::transport_failed(const beast::error_code& ec) {
  conn_.disconnect();
  // A kept-alive connection the server has since closed fails on first use: once more, fresh
  // (as the client's HttpClient does).
  if (!conn_.fresh() && !resent_ && !stopping_) {
    resent_ = true;
    return exchange();
  }
  failed(ec == beast::error::timeout ? "timeout" : ec.message());
}

// `why`: a short name of the kind of failure ("HTTP 503", "timeout", "Connection refused", ...).
// A failed request: counted, then backed off; `now`: the first refusal of an object, asked again at
// once by its other URL (TileServer::refused's other_url_next).
void Vehicle::failed(const std::string& why, bool now) {
  ++rep_.failures;
  ++failure_kinds_[why];
  sh_.failures.fetch_add(1, std::memory_order_relaxed);
  if (!now) backoff_.failed();
  done();
}

void Vehicle::done() {
  busy_ = false;
  if (stopping_) return stop();
  pump();
}

void Vehicle::rejected() {
  ++rep_.rejected;
  sh_.rejected.fetch_add(1, std::memory_order_relaxed);
}

void Vehicle::answered() {
  const float ms = static_cast<float>(secs(Clock::now() - sent_at_) * 1e3);
  VehicleConnection::Answer res = conn_.take_answer();
  if (!res.keep_alive()) conn_.disconnect();
  rep_.bytes += res.body().size();
  const auto xc = res[beast::string_view("X-Cache")];
  const std::string x_cache(xc.data(), xc.size());
  const int status = static_cast<int>(res.result_int());
  switch (kind_) {
    case Kind::Manifest:
    case Kind::Current:
    case Kind::Signed: tally(cache_.manifests, x_cache); break;
    case Kind::Roi:
      tally(cache_.roi, x_cache);
      roi_ms_.push_back(ms);
      break;
    case Kind::Tile:
      tally(cache_.tiles, x_cache);
      tile_ms_.push_back(ms);
      break;
  }
  if (status != 200) {
    if (kind_ == Kind::Tile && status == 404 && !index_->complete()) {
      index_w().forget(asked_.key);
      ++index_gen_;
    }
    return failed("HTTP " + std::to_string(status));
  }
  std::string body = std::move(res.body());
  try {
    switch (kind_) {
      case Kind::Manifest: return on_manifest(body);
      case Kind::Current: return on_current(body);
      case Kind::Signed: return on_signed(body);
      case Kind::Roi: return on_roi(body);
      case Kind::Tile: return on_tile(body);
    }
  } catch (const client::wire::WireError&) {  // not what the API promises: a failure, as for the client
    return failed("unreadable answer");
  }
}

// ---- the answers
void Vehicle::become_ready(const CachedManifest& m) {
  manifest_ = m;
  grid_.emplace(m.tile_size);
  ready_ = true;
  rep_.ready_s = secs(Clock::now() - sh_.start);
  sh_.ready.fetch_add(1, std::memory_order_relaxed);
  backoff_.succeeded();
  done();
}

void Vehicle::on_manifest(const std::string& body) {
  CachedManifest m = client::wire::parse_manifest(body, sh_.o.map, sh_.o.version);
  if (sh_.trusted.empty()) return become_ready(m);
  version_ = m.version;  // the signed manifest of that version is next
  backoff_.succeeded();
  done();
}

// With timestamp keys: the version a fresh signed statement names (the tile client's
// TileServer::current). One refused (altered, forged, expired) is counted and asked again by
// another URL; a vehicle without a disk cache has no verified version to fall back on, and waits.
void Vehicle::on_current(const std::string& body) {
  const auto now = signing::unix_now();
  try {
    version_ = client::wire::verified_current(body, sh_.current_keys, sh_.o.map, now).version;
  } catch (const client::wire::WireError&) {
    ++current_refusals_;
    rejected();
    return failed("refused current version", current_refusals_ == 1);
  }
  backoff_.succeeded();
  done();
}

void Vehicle::on_signed(const std::string& body) {
  const std::pair<std::string, long long> id{store::content_hash(body), *version_};
  std::optional<Shared::Checked> known;
  {
    std::lock_guard<std::mutex> lock(sh_.checked_mutex);
    auto it = sh_.checked.find(id);
    if (it != sh_.checked.end()) known = it->second;
  }
  if (!known) {
    known.emplace();
    try {
      const signing::SignedManifest sm = client::wire::verified_manifest(body, sh_.trusted, sh_.o.map, *version_);
      auto built = std::make_shared<TileIndex>();
      for (const auto& t : sm.manifest.tiles) built->learn(CachedTile{t.key, t.hash, t.points});
      built->set_complete();
      known->index = std::move(built);
      known->manifest.map = sh_.o.map;
      known->manifest.version = sm.manifest.version;
      known->manifest.tile_size = sm.manifest.tile_size;
    } catch (const client::wire::WireError&) {  // altered, or of another version: refused, never used
    }
    std::lock_guard<std::mutex> lock(sh_.checked_mutex);
    sh_.checked.emplace(id, *known);
  }
  if (!known->index) {
    ++manifest_refusals_;
    rejected();
    return failed("refused manifest", manifest_refusals_ == 1);
  }
  index_ = known->index;
  ++index_gen_;
  become_ready(known->manifest);
}

void Vehicle::on_roi(const std::string& body) {
  std::vector<CachedTile> listed = client::wire::parse_roi(body, manifest_.version, manifest_.tile_size);
  const auto keys = grid_->keys_in_disc(roi_disc_.center.x(), roi_disc_.center.y(), std::max(0.0, roi_disc_.radius - 0.01));
  for (CachedTile& r : client::rows_of_answer(std::move(listed), keys, *index_)) {
    auto p = present_.find(r.key);
    if (p != present_.end() && p->second.hash != r.hash) drop(p);
    index_w().learn(std::move(r));
  }
  ++index_gen_;
  backoff_.succeeded();
  done();
}

void Vehicle::on_tile(const std::string& body) {
  const std::string got = store::content_hash(body);
  if (got != asked_.hash) {
    rejected();
    if (asked_by_key_) {
      by_key_.erase(asked_.hash);
      held_[asked_.hash] = Clock::now() + kHoldBack;
    } else {
      by_key_.insert(asked_.hash);
    }
    return failed("refused tile bytes", !asked_by_key_);
  }
  by_key_.erase(asked_.hash);
  const CachedTile* row = index_->find(asked_.key);
  if (row && row->hash == asked_.hash) {  // (still the version's tile there)
    const std::size_t size = kBytesPerPoint * static_cast<std::size_t>(std::max(0LL, asked_.points));
    present_[asked_.key] = Held{asked_.hash, size};
    memory_ += size;
    make_room();
  }
  ++rep_.tiles;
  rep_.tile_bytes += body.size();
  if (sh_.o.record_fetches) rep_.fetched.push_back(FetchedTile{asked_.key, got, body.size()});
  backoff_.succeeded();
  done();
}

// ---- the memory bound
void Vehicle::drop(Present::iterator it) {
  memory_ -= it->second.size;
  present_.erase(it);
}

// Tiles no disc wants go first, farthest first (the client evicts the least recently used outside
// the discs; for a vehicle driving on, those are the ones left behind).
void Vehicle::make_room() {
  const std::size_t budget = static_cast<std::size_t>(sh_.o.memory_mb * 1024 * 1024);
  if (memory_ <= budget) return;
  std::vector<std::pair<double, TileKey>> unwanted;
  for (const auto& [k, h] : present_) {
    const TileBounds b = grid_->bounds_of(k);
    if (!client::touches(b, focus_now_, sh_.o.radius_m) && !client::touches(b, focus_ahead_, sh_.o.radius_m))
      unwanted.emplace_back(client::box_distance(b, pos_), k);
  }
  std::sort(unwanted.begin(), unwanted.end(), [](const auto& a, const auto& b) { return a.first > b.first || (a.first == b.first && a.second < b.second); });
  for (const auto& [d, k] : unwanted) {
    if (memory_ <= budget) break;
    drop(present_.find(k));
    ++rep_.evicted;
  }
}

}  // namespace pl::fleet
