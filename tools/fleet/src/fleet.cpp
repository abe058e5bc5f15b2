// The fleet: vehicles as small state machines on one Asio io_context, each with its own strand,
// connection, scan timer and backoff. The tile client's own planning and answer checks decide what
// a vehicle asks for and what it accepts (client/src: make_plan, TileIndex, rows_of_answer,
// wire::parse_manifest / parse_roi / verified_manifest, Backoff); this file only moves the bytes,
// keeps the clock and counts.
//
// A vehicle's life:
//   1. at its start time (spread over ramp_s) it asks for the map's manifest (GET /v1/maps/{map};
//      with fleet keys then the version's signed manifest), as the tile client does before it is ready;
//   2. parked at its route's start, it focuses there (set_focus(xy, xy) and wait_for the localizer's
//      ROI disc, as VehicleLocalizer starts) until every tile of that disc is there, or start_wait_s;
//   3. then it drives: each scan moves it along its route, focuses on (xy, xy + lookahead_s * v)
//      and counts the tiles of the localizer's ROI disc it lacks.
// Between scans its one connection does what the tile client's thread does, one request at a time,
// re-planning after each: the first ROI query of the plan, else the nearest wanted tile the index
// knows and memory lacks; nothing while backing off.
#include "pl/fleet/fleet.hpp"

#include <sys/resource.h>

#include <algorithm>
#include <atomic>
#include <boost/asio.hpp>
#include <boost/asio/ssl.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/ssl.hpp>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <openssl/ssl.h>
#include <random>
#include <set>
#include <sstream>
#include <thread>
#include <unordered_map>

#include "backoff.hpp"
#include "fetch_plan.hpp"
#include "pl/client/localizer.hpp"
#include "pl/client/tile_client.hpp"
#include "pl/client/vehicle_localizer.hpp"
#include "pl/common/error.hpp"
#include "pl/schema/api_rules.hpp"
#include "pl/schema/http_client.hpp"
#include "pl/schema/signed_current.hpp"
#include "pl/schema/signed_manifest.hpp"
#include "pl/schema/store.hpp"
#include "tile_index.hpp"
#include "wire.hpp"

namespace pl::fleet {

namespace net = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;
using tcp = net::ip::tcp;
using Clock = std::chrono::steady_clock;
using json = nlohmann::json;
using client::CachedManifest;
using client::CachedTile;
using client::Disc;
using client::FetchPlan;
using client::TileIndex;

namespace {

constexpr std::size_t kBytesPerPoint = 40;           // the tile client's bound on a decoded point
constexpr std::size_t kMaxBody = std::size_t{64} << 20;  // the largest tile the server takes
constexpr auto kHoldBack = std::chrono::seconds(30);  // a tile refused by both its URLs is left this long

std::string num(double v) {
  char b[64];
  std::snprintf(b, sizeof b, "%.3f", v);
  return b;
}

double secs(Clock::duration d) { return std::chrono::duration<double>(d).count(); }
Clock::duration dur(double s) { return std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(s)); }

Latency summarize(std::vector<float> v) {
  Latency l;
  l.count = v.size();
  if (v.empty()) return l;
  std::sort(v.begin(), v.end());
  auto at = [&](double q) {  // nearest rank
    std::size_t i = static_cast<std::size_t>(std::ceil(q * static_cast<double>(v.size())));
    return static_cast<double>(v[std::min(v.size() - 1, i == 0 ? 0 : i - 1)]);
  };
  l.p50 = at(0.5);
  l.p90 = at(0.9);
  l.p99 = at(0.99);
  l.max = v.back();
  double sum = 0;
  for (float x : v) sum += x;
  l.mean = sum / static_cast<double>(v.size());
  return l;
}

// "http://HOST:PORT[/path]" -> host, port, path ("" when none).
struct Url {
  std::string scheme, host, port, path;
};
Url parse_url(const std::string& url, const std::string& flag) {
  Url u;
  const auto colon = url.find("://");
  if (colon == std::string::npos) throw Error(flag + ": \"" + url + "\" is not a URL: write http://HOST:PORT");
  u.scheme = url.substr(0, colon);
  std::string rest = url.substr(colon + 3);
  const auto slash = rest.find('/');
  if (slash != std::string::npos) {
    u.path = rest.substr(slash);
    rest = rest.substr(0, slash);
  }
  const auto pc = rest.rfind(':');
  if (pc != std::string::npos && rest.find(']') == std::string::npos) {
    u.host = rest.substr(0, pc);
    u.port = rest.substr(pc + 1);
  } else {
    u.host = rest;
    u.port = u.scheme == "https" ? "443" : "80";
  }
  if (u.host.empty() || u.port.empty()) throw Error(flag + ": \"" + url + "\" names no host: write http://HOST:PORT");
  return u;
}

// ---------------------------------------------------------------------------------------------
// Routes: a street grid over the map's extent, driven with a random turn at each crossing.

class Route {
 public:
  Route(const double extent[4], double block, double length, std::mt19937_64& rng) {
    auto lines = [&](double lo, double hi) {
      const double w = hi - lo, inset = std::min(block / 2, w / 4);
      const int n = std::max(2, static_cast<int>(std::floor((w - 2 * inset) / block)) + 1);
      std::vector<double> out;
      for (int i = 0; i < n; ++i) out.push_back(lo + inset + (w - 2 * inset) * i / (n - 1));
      return out;
    };
    const std::vector<double> xs = lines(extent[0], extent[2]), ys = lines(extent[1], extent[3]);
    auto pick = [&](int n) { return static_cast<int>(std::uniform_int_distribution<int>(0, n - 1)(rng)); };
    int i = pick(static_cast<int>(xs.size())), j = pick(static_cast<int>(ys.size())), pi = -1, pj = -1;
    pts_.emplace_back(xs[i], ys[j]);
    cum_.push_back(0);
    while (cum_.back() < length) {
      std::vector<std::pair<int, int>> next;
      for (auto [di, dj] : {std::pair{1, 0}, {-1, 0}, {0, 1}, {0, -1}}) {
        const int ni = i + di, nj = j + dj;
        if (ni < 0 || nj < 0 || ni >= static_cast<int>(xs.size()) || nj >= static_cast<int>(ys.size())) continue;
        if (ni == pi && nj == pj) continue;
        next.emplace_back(ni, nj);
      }
      if (next.empty()) next.emplace_back(pi, pj);  // a dead end: back the way it came
      const auto [ni, nj] = next[static_cast<std::size_t>(pick(static_cast<int>(next.size())))];
      pi = i, pj = j, i = ni, j = nj;
      const Eigen::Vector2d p(xs[i], ys[j]);
      cum_.push_back(cum_.back() + (p - pts_.back()).norm());
      pts_.push_back(p);
    }
  }
  Eigen::Vector2d start() const { return pts_.front(); }
  // The point `s` metres along (monotone calls: a cursor).
  Eigen::Vector2d at(double s) {
    s = std::min(s, cum_.back());
    while (cursor_ + 2 < cum_.size() && cum_[cursor_ + 1] < s) ++cursor_;
    const double len = cum_[cursor_ + 1] - cum_[cursor_];
    const double f = len > 0 ? (s - cum_[cursor_]) / len : 0.0;
    return pts_[cursor_] + f * (pts_[cursor_ + 1] - pts_[cursor_]);
  }

 private:
  std::vector<Eigen::Vector2d> pts_;
  std::vector<double> cum_;
  std::size_t cursor_ = 0;
};

// ---------------------------------------------------------------------------------------------
// What the vehicles share: settings, the truth about the version, progress counters.

struct Shared {
  FleetOptions o;
  tcp::resolver::results_type endpoints;
  std::string host_header;
  std::string host;                       // for SNI and the certificate's name check (https)
  std::optional<net::ssl::context> tls;   // https only
  std::vector<std::string> trusted;
  std::vector<std::string> current_keys;  // timestamp keys: "current" only from a fresh signed statement
  std::unordered_map<TileKey, std::string, TileKeyHash> truth;  // the version's tiles (key -> hash), for stalls
  // Signed manifests already checked, by the content hash of their bytes and the version asked for:
  // the index they give (null: refused). Every vehicle still fetches the bytes and hashes them; the
  // check and the index of a body seen before are the same function of the same bytes, so they are
  // made once and shared (2,000 vehicles parsing a 51,456-tile manifest each took 192 s of the load
  // generator's one core, and as many indexes took gigabytes).
  struct Checked {
    std::shared_ptr<const TileIndex> index;  // null: refused
    CachedManifest manifest;
  };
  std::mutex checked_mutex;
  std::map<std::pair<std::string, long long>, Checked> checked;
  double tile_size = 0;
  double extent[4] = {0, 0, 0, 0};       // of the version's tiles: min x, min y, max x, max y
  Clock::time_point start, end;
  std::atomic<int> ready{0}, driving{0};
  std::atomic<std::size_t> scans{0}, stalled{0}, tile_requests{0}, roi_queries{0}, failures{0}, rejected{0};
};

enum class Kind { Manifest, Current, Signed, Roi, Tile };

struct CacheTally {
  CacheCounts tiles, roi, manifests;
};

void tally(CacheCounts& c, const std::string& value) {
  ++c.answers;
  if (value.empty()) return;
  ++c.with_header;
  std::string v = value;
  std::transform(v.begin(), v.end(), v.begin(), [](unsigned char ch) { return static_cast<char>(std::tolower(ch)); });
  ++c.values[v];
  if (v == "hit")
    ++c.hit;
  else if (v == "miss" || v == "expired")
    ++c.miss;
  else if (v == "pass" || v == "bypass")
    ++c.pass;
  else if (v == "stale" || v == "updating")
    ++c.stale;
  else
    ++c.other;
}

class Vehicle : public std::enable_shared_from_this<Vehicle> {
 public:
  Vehicle(net::io_context& ioc, Shared& sh, int id)
      : sh_(sh),
        strand_(net::make_strand(ioc)),
        tick_(strand_),
        wake_(strand_),
        rng_(seeded(sh.o.seed, id)),
        backoff_(sh.o.retry_min_s, sh.o.retry_max_s, static_cast<unsigned>(rng_())) {
    rep_.id = id;
    rep_.speed = std::uniform_real_distribution<double>(sh.o.speed_min, sh.o.speed_max)(rng_);
    rep_.start_s = std::uniform_real_distribution<double>(0, sh.o.ramp_s)(rng_);
    route_.emplace(sh.extent, sh.o.block_m, rep_.speed * sh.o.duration_s + 200, rng_);
    pos_ = route_->start();
    buffer_.reserve(api::kHttpReadBuffer);
    if (!sh.tls) plain_.emplace(strand_);
  }

  void go() {
    tick_.expires_at(sh_.start + dur(rep_.start_s));
    tick_.async_wait([self = shared_from_this()](beast::error_code ec) { self->on_tick(ec); });
  }

  VehicleReport report() {
    rep_.tile_latency = summarize(tile_ms_);
    rep_.roi_latency = summarize(roi_ms_);
    return rep_;
  }
  const std::vector<float>& tile_ms() const { return tile_ms_; }
  const std::vector<float>& roi_ms() const { return roi_ms_; }
  const CacheTally& cache() const { return cache_; }
  const std::map<std::string, std::size_t>& failure_kinds() const { return failure_kinds_; }

 private:
  enum class Phase { Waiting, Starting, Driving, Stopped };

  // Each vehicle's own random numbers: the same for the same seed and vehicle, whatever the threads.
  static std::mt19937_64 seeded(unsigned long long seed, int id) {
    std::seed_seq seq{static_cast<std::uint32_t>(seed), static_cast<std::uint32_t>(seed >> 32), static_cast<std::uint32_t>(id), 0x666c74u};
    return std::mt19937_64(seq);
  }

  // ---- the clock: one tick a scan
  void on_tick(beast::error_code ec) {
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

  void stop() {
    phase_ = Phase::Stopped;
    close_socket();
    wake_.cancel();
  }

  // The TCP stream under the connection (the TLS stream's, with https).
  beast::tcp_stream& tcp() { return tls_ ? beast::get_lowest_layer(*tls_) : *plain_; }

  void close_socket() {
    if (!plain_ && !tls_) return;
    beast::error_code ignored;
    tcp().socket().shutdown(tcp::socket::shutdown_both, ignored);
    tcp().close();
  }

  // A scan: move along the route, focus, count the needed tiles missing.
  void scan(Clock::time_point now) {
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
  bool start_complete() const {
    for (const TileKey& k : grid_->keys_in_disc(pos_.x(), pos_.y(), sh_.o.roi_radius_m)) {
      const CachedTile* row = index_->find(k);
      if (!row || (row->exists() && !present_.count(k))) return false;
    }
    return true;
  }

  // ---- what to ask next: the tile client's step()
  void pump() {
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
  const FetchPlan& current_plan(Clock::time_point now) {
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
  bool anything_to_do(Clock::time_point now) {
    for (const Eigen::Vector2d& c : {focus_now_, focus_ahead_})
      for (const TileKey& k : grid_->keys_in_disc(c.x(), c.y(), sh_.o.radius_m)) {
        const CachedTile* row = index_->find(k);
        if (!row) return true;
        if (row->exists() && !present_.count(k) && !held_back(row->hash, now)) return true;
      }
    return false;
  }

  TileIndex& index_w() {
    if (own_ != index_) {
      own_ = std::make_shared<TileIndex>(*index_);
      index_ = own_;
    }
    return *own_;
  }

  bool held_back(const std::string& hash, Clock::time_point now) {
    auto it = held_.find(hash);
    if (it == held_.end()) return false;
    if (now < it->second) return true;
    held_.erase(it);
    return false;
  }

  void arm_wake(Clock::time_point at) {
    if (wake_armed_) return;
    wake_armed_ = true;
    wake_.expires_at(at);
    wake_.async_wait([self = shared_from_this()](beast::error_code ec) {
      self->wake_armed_ = false;
      if (!ec) self->pump();
    });
  }

  // ---- one request on the kept-alive connection
  void send(Kind kind, std::string target) {
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
    start_exchange();
  }

  void start_exchange() {
    fresh_ = !connected_;
    if (connected_) return write();
    if (sh_.tls) {  // a TLS stream per connection (no operation of the last one is pending: one request at a time)
      tls_.emplace(strand_, *sh_.tls);
      beast::error_code literal;
      net::ip::make_address(sh_.host, literal);
      if (literal) SSL_set_tlsext_host_name(tls_->native_handle(), sh_.host.c_str());  // SNI carries names only
      tls_->set_verify_callback(net::ssl::host_name_verification(sh_.host));
    }
    tcp().expires_after(dur(sh_.o.timeout_s));
    tcp().async_connect(sh_.endpoints, [self = shared_from_this()](beast::error_code ec, const tcp::endpoint&) {
      if (self->phase_ == Phase::Stopped) return;
      if (ec) return self->transport_failed(ec);
      if (!self->tls_) {
        self->connected_ = true;
        return self->write();
      }
      self->tls_->async_handshake(net::ssl::stream_base::client, [self](beast::error_code e) {
        if (self->phase_ == Phase::Stopped) return;
        if (e) return self->transport_failed(e);
        self->connected_ = true;
        self->write();
      });
    });
  }

  void write() {
    req_ = {};
    req_.method(http::verb::get);
    req_.target(target_);
    req_.version(11);
    req_.set(http::field::host, sh_.host_header);
    req_.set(http::field::user_agent, "pl-fleet");
    if (!sh_.o.token.empty()) req_.set(http::field::authorization, "Bearer " + sh_.o.token);
    req_.keep_alive(true);
    tcp().expires_after(dur(sh_.o.timeout_s));
    auto written = [self = shared_from_this()](beast::error_code ec, std::size_t) {
      if (self->phase_ == Phase::Stopped) return;
      if (ec) return self->transport_failed(ec);
      self->read();
    };
    if (tls_)
      http::async_write(*tls_, req_, std::move(written));
    else
      http::async_write(*plain_, req_, std::move(written));
  }

  void read() {
    parser_.emplace();
    parser_->body_limit(kMaxBody);
    tcp().expires_after(dur(sh_.o.timeout_s));
    auto got = [self = shared_from_this()](beast::error_code ec, std::size_t) {
      if (self->phase_ == Phase::Stopped) return;
      if (ec) return self->transport_failed(ec);
      self->answered();
    };
    if (tls_)
      http::async_read(*tls_, buffer_, *parser_, std::move(got));
    else
      http::async_read(*plain_, buffer_, *parser_, std::move(got));
  }

  void disconnect() {
    close_socket();  // (no TLS close_notify: the server sees the connection end, as when a vehicle drives off)
    buffer_.consume(buffer_.size());
    connected_ = false;
  }

  void transport_failed(const beast::error_code& ec) {
    disconnect();
    // A kept-alive connection the server has since closed fails on first use: once more, fresh
    // (as the client's HttpClient does).
    if (!fresh_ && !resent_ && !stopping_) {
      resent_ = true;
      return start_exchange();
    }
    failed(ec == beast::error::timeout ? "timeout" : ec.message());
  }

  // `why`: a short name of the kind of failure ("HTTP 503", "timeout", "Connection refused", ...).
  // A failed request: counted, then backed off; `now`: the first refusal of an object, asked again at
  // once by its other URL (TileServer::refused's other_url_next).
  void failed(const std::string& why, bool now = false) {
    ++rep_.failures;
    ++failure_kinds_[why];
    sh_.failures.fetch_add(1, std::memory_order_relaxed);
    if (!now) backoff_.failed();
    done();
  }

  void done() {
    busy_ = false;
    if (stopping_) return stop();
    pump();
  }

  void rejected() {
    ++rep_.rejected;
    sh_.rejected.fetch_add(1, std::memory_order_relaxed);
  }

  void answered() {
    const float ms = static_cast<float>(secs(Clock::now() - sent_at_) * 1e3);
    http::response<http::string_body> res = parser_->release();
    parser_.reset();
    if (!res.keep_alive()) disconnect();
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

  void become_ready(const CachedManifest& m) {
    manifest_ = m;
    grid_.emplace(m.tile_size);
    ready_ = true;
    rep_.ready_s = secs(Clock::now() - sh_.start);
    sh_.ready.fetch_add(1, std::memory_order_relaxed);
    backoff_.succeeded();
    done();
  }

  void on_manifest(const std::string& body) {
    CachedManifest m = client::wire::parse_manifest(body, sh_.o.map, sh_.o.version);
    if (sh_.trusted.empty()) return become_ready(m);
    version_ = m.version;  // the signed manifest of that version is next
    backoff_.succeeded();
    done();
  }

  // With timestamp keys: the version a fresh signed statement names (the tile client's
  // TileServer::current). One refused (altered, forged, expired) is counted and asked again by
  // another URL; a vehicle without a disk cache has no verified version to fall back on, and waits.
  void on_current(const std::string& body) {
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

  void on_signed(const std::string& body) {
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

  void on_roi(const std::string& body) {
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

  void on_tile(const std::string& body) {
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

  // The memory bound: tiles no disc wants go first, farthest first (the client evicts the least
  // recently used outside the discs; for a vehicle driving on, those are the ones left behind).
  struct Held {
    std::string hash;
    std::size_t size = 0;
  };
  void drop(std::unordered_map<TileKey, Held, TileKeyHash>::iterator it) {
    memory_ -= it->second.size;
    present_.erase(it);
  }
  void make_room() {
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

  Shared& sh_;
  net::strand<net::io_context::executor_type> strand_;
  std::optional<beast::tcp_stream> plain_;                   // http://
  std::optional<beast::ssl_stream<beast::tcp_stream>> tls_;  // https://
  net::steady_timer tick_, wake_;
  std::mt19937_64 rng_;
  client::Backoff backoff_;
  VehicleReport rep_;
  std::optional<Route> route_;
  Phase phase_ = Phase::Waiting;
  Clock::time_point started_, driving_since_, last_scan_, sent_at_;
  Eigen::Vector2d pos_ = Eigen::Vector2d::Zero(), focus_now_ = Eigen::Vector2d::Zero(), focus_ahead_ = Eigen::Vector2d::Zero();
  TileGrid truth_grid_{sh_.tile_size};

  bool ready_ = false;
  std::optional<long long> version_;  // with fleet keys: the version whose signed manifest is asked for
  int manifest_refusals_ = 0;         // signed manifests refused (the next is asked with ?refused=N)
  int current_refusals_ = 0;          // current-version statements refused (likewise)
  CachedManifest manifest_;
  std::optional<TileGrid> grid_;
  // What the vehicle knows of the version. A complete index from a signed manifest is shared with
  // every vehicle that checked the same bytes; index_w() makes the vehicle's own copy to change.
  std::shared_ptr<TileIndex> own_ = std::make_shared<TileIndex>();
  std::shared_ptr<const TileIndex> index_ = own_;
  std::uint64_t index_gen_ = 0;  // bumped at each change of the index
  std::optional<FetchPlan> plan_;
  Eigen::Vector2d planned_now_ = Eigen::Vector2d::Zero(), planned_ahead_ = Eigen::Vector2d::Zero();
  std::uint64_t planned_index_ = 0;
  std::size_t plan_cursor_ = 0;  // in plan_->wants: where the next look for a tile to fetch starts
  std::unordered_map<TileKey, Held, TileKeyHash> present_;
  std::size_t memory_ = 0;
  std::set<std::string> by_key_;
  std::map<std::string, Clock::time_point> held_;

  bool busy_ = false, stopping_ = false, connected_ = false, fresh_ = false, resent_ = false, wake_armed_ = false;
  Kind kind_ = Kind::Manifest;
  std::string target_;
  std::map<std::string, std::size_t> failure_kinds_;
  Disc roi_disc_{Eigen::Vector2d::Zero(), 0};
  CachedTile asked_;
  bool asked_by_key_ = false;
  http::request<http::empty_body> req_;
  std::optional<http::response_parser<http::string_body>> parser_;
  beast::flat_buffer buffer_;
  std::vector<float> tile_ms_, roi_ms_;
  CacheTally cache_;
};

// ---------------------------------------------------------------------------------------------
// Origins: pl_requests_total by route, before and after.

using Counters = std::map<std::pair<std::string, std::string>, double>;  // (route, status) -> count

Counters scrape(const std::string& url, const FleetOptions& o) {
  const Url u = parse_url(url, "--origin-metrics");
  api::HttpOptions ho;
  ho.timeout_s = std::max(o.timeout_s, 5.0);
  ho.insecure_http = true;
  api::HttpClient c(url, ho);
  const api::HttpResponse r = c.get(u.path.empty() ? "/metrics" : u.path);
  if (r.status != 200) throw Error(url + " answered HTTP " + std::to_string(r.status));
  Counters out;
  std::istringstream in(r.body);
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind("pl_requests_total{", 0) != 0) continue;
    auto field = [&](const std::string& name) {
      const auto at = line.find(name + "=\"");
      if (at == std::string::npos) return std::string();
      const auto from = at + name.size() + 2;
      return line.substr(from, line.find('"', from) - from);
    };
    const auto sp = line.rfind(' ');
    if (sp == std::string::npos) continue;
    out[{field("route"), field("status")}] += std::strtod(line.c_str() + sp + 1, nullptr);
  }
  return out;
}

OriginCounts origin_delta(const std::string& url, const Counters& before, const Counters& after) {
  OriginCounts oc;
  oc.url = url;
  oc.ok = true;
  for (const auto& [key, n] : after) {
    auto b = before.find(key);
    const double d = n - (b == before.end() ? 0.0 : b->second);
    if (d < 0) {
      oc.ok = false;
      oc.error = "pl_requests_total went down (the replica restarted during the run): its counts are left out";
      return oc;
    }
    const std::string& route = key.first;
    if (route == "/metrics" || route == "/healthz" || route == "/readyz") continue;
    if (route == "/v1/blobs/{hash}" || route == "/v1/maps/{map}/versions/{v}/tiles/{tx}/{ty}")
      oc.tiles += d;
    else if (route == "/v1/maps/{map}/roi")
      oc.roi += d;
    else if (route == "/v1/maps/{map}" || route == "/v1/maps/{map}/versions/{v}/manifest")
      oc.manifests += d;
    else
      oc.other += d;
    if (!key.second.empty() && key.second[0] == '5') oc.errors_5xx += d;
  }
  return oc;
}

json latency_json(const Latency& l) {
  return {{"count", l.count}, {"p50_ms", l.p50}, {"p90_ms", l.p90}, {"p99_ms", l.p99}, {"max_ms", l.max}, {"mean_ms", l.mean}};
}

json cache_json(const CacheCounts& c) {
  json j = {{"answers", c.answers}, {"with_header", c.with_header}, {"hit", c.hit},     {"miss", c.miss},
            {"pass", c.pass},       {"stale", c.stale},             {"other", c.other}, {"hit_ratio", c.hit_ratio()}};
  j["values"] = c.values;
  return j;
}

void merge(CacheCounts& into, const CacheCounts& c) {
  into.answers += c.answers;
  into.with_header += c.with_header;
  into.hit += c.hit;
  into.miss += c.miss;
  into.pass += c.pass;
  into.stale += c.stale;
  into.other += c.other;
  for (const auto& [k, n] : c.values) into.values[k] += n;
}

}  // namespace

// -------------------------------------------------------------------------------------------------

void FleetOptions::validate() const {
  auto need = [](bool ok, const std::string& what) {
    if (!ok) throw Error(what);
  };
  need(!server.empty(), "--server is required: the URL of pl-server or of the cache in front of it (http://HOST:PORT)");
  const Url u = parse_url(server, "--server");
  need(u.scheme == "http" || u.scheme == "https", "--server " + server + ": write http://HOST:PORT or https://HOST:PORT");
  need(ca_file.empty() || u.scheme == "https", "--ca-file goes with an https:// --server");
  need(api::valid_map_name(map), "--map must be a map name (1 to 64 of A-Z a-z 0-9 _ . -), got \"" + map + "\"");
  need(!version || *version >= 1, "--map-version must be 1 or more (or left out for the map's current version)");
  need(vehicles >= 1 && vehicles <= 100000, "--vehicles must be between 1 and 100000, got " + std::to_string(vehicles));
  need(std::isfinite(duration_s) && duration_s > 0, "--duration must be a number of seconds > 0");
  need(std::isfinite(speed_min) && speed_min >= 0 && std::isfinite(speed_max) && speed_max >= speed_min && speed_max <= 100,
       "--speed-min and --speed-max: 0 <= min <= max <= 100 m/s, got " + num(speed_min) + " and " + num(speed_max));
  need(std::isfinite(ramp_s) && ramp_s >= 0, "--ramp must be a number of seconds >= 0");
  need(std::isfinite(block_m) && block_m >= 1, "--block must be a number of metres >= 1");
  need(threads >= 1 && threads <= 64, "--threads must be between 1 and 64");
  need(std::isfinite(scan_hz) && scan_hz > 0 && scan_hz <= 100, "--scan-hz must be between 0 and 100");
  need(radius_m == 0 || (radius_m > 0 && radius_m <= 4000), "--radius must be between 0 and 4000 m (0: the vehicle's default)");
  need(roi_radius_m >= 0 && roi_radius_m <= 4000, "--roi-radius must be between 0 and 4000 m (0: the localizer's default)");
  need(lookahead_s == -1 || (lookahead_s >= 0 && lookahead_s <= 60), "--lookahead must be between 0 and 60 s");
  need(timeout_s >= 0 && std::isfinite(timeout_s), "--timeout must be a number of seconds > 0");
  need(retry_min_s >= 0 && retry_max_s >= 0 && (retry_max_s == 0 || retry_max_s >= retry_min_s),
       "--retry-min and --retry-max: seconds, min <= max");
  need(start_wait_s == -1 || start_wait_s >= 0, "--start-wait must be a number of seconds >= 0");
  need(memory_mb >= 0 && std::isfinite(memory_mb), "--memory must be a number of MiB > 0");
  for (const auto& m : origin_metrics) {
    const Url mu = parse_url(m, "--origin-metrics");
    need(mu.scheme == "http", "--origin-metrics " + m + ": a replica's plain http:// address, e.g. http://127.0.0.1:8080/metrics");
  }
}

FleetReport run_fleet(const FleetOptions& options, const FleetObserver& observer) {
  options.validate();
  auto sh = std::make_unique<Shared>();
  FleetOptions& o = sh->o;
  o = options;
  // The vehicle's own settings where left to their defaults.
  {
    const client::TileClientConfig tc;
    const client::VehicleLocalizerConfig vc;
    if (o.roi_radius_m == 0) o.roi_radius_m = vc.localizer.roi_radius_m;
    if (o.radius_m == 0) o.radius_m = std::max(tc.radius_m, vc.localizer.roi_radius_m + 20.0);
    if (o.lookahead_s < 0) o.lookahead_s = vc.lookahead_s;
    if (o.start_wait_s < 0) o.start_wait_s = vc.start_wait_s;
    if (o.timeout_s == 0) o.timeout_s = tc.timeout_s;
    if (o.retry_min_s == 0) o.retry_min_s = tc.retry_min_s;
    if (o.retry_max_s == 0) o.retry_max_s = std::max(tc.retry_max_s, o.retry_min_s);
    if (o.memory_mb == 0) o.memory_mb = tc.memory_mb;
  }
  auto keys = [](const std::string& flag, const std::string& path) {
    try {
      return signing::load_public_keys(path);
    } catch (const Error& e) {
      throw Error(flag + ": " + e.what());
    }
  };
  if (!o.fleet_keys.empty()) sh->trusted = keys("--fleet-keys", o.fleet_keys);
  if (!o.timestamp_keys.empty()) {
    if (sh->trusted.empty()) throw Error("--timestamp-keys needs --fleet-keys: the versions a statement names current are used signed");
    sh->current_keys = keys("--timestamp-keys", o.timestamp_keys);
  }
  // Enough file descriptors for a connection per vehicle.
  rlimit lim{};
  if (getrlimit(RLIMIT_NOFILE, &lim) == 0) {
    const rlim_t want = static_cast<rlim_t>(o.vehicles) + 64;
    if (lim.rlim_cur < want) {
      if (lim.rlim_max != RLIM_INFINITY && lim.rlim_max < want)
        throw Error(std::to_string(o.vehicles) + " vehicles need " + std::to_string(want) + " open files, the limit is " +
                    std::to_string(lim.rlim_max) + ": raise it (ulimit -n) or run fewer vehicles");
      lim.rlim_cur = want;
      setrlimit(RLIMIT_NOFILE, &lim);
    }
  }

  // The version and its tiles: what the stalls are counted against.
  FleetReport rep;
  rep.server = o.server;
  rep.map = o.map;
  {
    api::HttpOptions ho;
    ho.timeout_s = std::max(o.timeout_s, 10.0);
    ho.insecure_http = true;
    ho.ca_file = o.ca_file;
    std::map<std::string, std::string> headers;
    if (!o.token.empty()) headers["Authorization"] = "Bearer " + o.token;
    api::HttpClient c(o.server, ho);
    api::HttpResponse r;
    try {
      r = c.get("/v1/maps/" + api::url_encode(o.map), headers);
    } catch (const std::exception& e) {
      throw Error("cannot reach " + o.server + " (" + e.what() + "): is pl-server (or the cache) running there?");
    }
    if (r.status != 200)
      throw Error(o.server + " answered HTTP " + std::to_string(r.status) + " for map " + o.map + " (" + client::wire::error_text(r.body) +
                  "): check --map (and --token)");
    CachedManifest m;
    try {
      m = client::wire::parse_manifest(r.body, o.map, o.version);
    } catch (const client::wire::WireError& e) {
      throw Error("the manifest of map " + o.map + " from " + o.server + ": " + e.what());
    }
    rep.version = m.version;
    rep.tile_size = sh->tile_size = m.tile_size;
    r = c.get("/v1/maps/" + api::url_encode(o.map) + "/versions/" + std::to_string(m.version) + "/tiles", headers);
    if (r.status != 200)
      throw Error(o.server + " answered HTTP " + std::to_string(r.status) + " for the tiles of map " + o.map + " version " +
                  std::to_string(m.version) + ": is that version published?");
    const json j = json::parse(r.body, nullptr, false);
    if (!j.is_object() || !j.contains("tiles") || !j["tiles"].is_array())
      throw Error("the tile list of map " + o.map + " from " + o.server + " is not what schema/openapi.yaml says");
    for (const auto& t : j["tiles"])
      sh->truth[TileKey{t.at("tx").get<std::int32_t>(), t.at("ty").get<std::int32_t>()}] = t.at("hash").get<std::string>();
    if (sh->truth.empty()) throw Error("map " + o.map + " version " + std::to_string(m.version) + " has no tiles: nothing to drive over");
    rep.map_tiles = sh->truth.size();
    int x0 = INT32_MAX, y0 = INT32_MAX, x1 = INT32_MIN, y1 = INT32_MIN;
    for (const auto& [k, h] : sh->truth) {
      x0 = std::min(x0, k.tx), y0 = std::min(y0, k.ty), x1 = std::max(x1, k.tx), y1 = std::max(y1, k.ty);
    }
    rep.extent[0] = x0 * m.tile_size, rep.extent[1] = y0 * m.tile_size;
    rep.extent[2] = (x1 + 1) * m.tile_size, rep.extent[3] = (y1 + 1) * m.tile_size;
    std::copy(rep.extent, rep.extent + 4, sh->extent);
  }
  rep.vehicles = o.vehicles;
  rep.radius_m = o.radius_m;
  rep.roi_radius_m = o.roi_radius_m;
  rep.lookahead_s = o.lookahead_s;

  std::vector<std::pair<std::string, std::optional<Counters>>> before;
  for (const auto& url : o.origin_metrics) {
    try {
      before.emplace_back(url, scrape(url, o));
    } catch (const std::exception& e) {
      throw Error("--origin-metrics " + url + ": " + e.what() + ": is that replica's /metrics reachable?");
    }
  }

  net::io_context ioc;
  {
    const Url u = parse_url(o.server, "--server");
    tcp::resolver resolver(ioc);
    sh->endpoints = resolver.resolve(u.host, u.port);
    sh->host_header = u.host + ":" + u.port;
    sh->host = u.host;
    if (u.scheme == "https") {  // as the tile client's HttpClient: TLS 1.2 at least, the chain and the name checked
      sh->tls.emplace(net::ssl::context::tls_client);
      SSL_CTX_set_min_proto_version(sh->tls->native_handle(), TLS1_2_VERSION);
      beast::error_code ec;
      if (o.ca_file.empty())
        sh->tls->set_default_verify_paths(ec);
      else
        sh->tls->load_verify_file(o.ca_file, ec);
      if (ec) throw Error("--ca-file " + o.ca_file + ": cannot be loaded (" + ec.message() + "): give a readable PEM file of CA certificates");
      sh->tls->set_verify_mode(net::ssl::verify_peer);
    }
  }
  std::vector<std::shared_ptr<Vehicle>> fleet;
  fleet.reserve(static_cast<std::size_t>(o.vehicles));
  for (int i = 0; i < o.vehicles; ++i) fleet.push_back(std::make_shared<Vehicle>(ioc, *sh, i));
  sh->start = Clock::now() + std::chrono::milliseconds(50);
  sh->end = sh->start + dur(o.duration_s);
  for (auto& v : fleet) v->go();

  net::steady_timer progress(ioc);
  std::function<void(beast::error_code)> tick;
  if (observer) {
    tick = [&](beast::error_code ec) {
      if (ec) return;
      const auto now = Clock::now();
      FleetProgress p;
      p.elapsed_s = std::max(0.0, secs(now - sh->start));
      p.duration_s = o.duration_s;
      p.ready = sh->ready.load();
      p.driving = sh->driving.load();
      p.scans = sh->scans.load();
      p.stalled_scans = sh->stalled.load();
      p.tile_requests = sh->tile_requests.load();
      p.roi_queries = sh->roi_queries.load();
      p.failures = sh->failures.load();
      p.rejected = sh->rejected.load();
      observer(p);
      if (now < sh->end) {
        progress.expires_at(std::min(now + std::chrono::seconds(1), sh->end));
        progress.async_wait(tick);
      }
    };
    progress.expires_at(sh->start);
    progress.async_wait(tick);
  }
  auto cpu_now = [] {
    rusage u{};
    getrusage(RUSAGE_SELF, &u);
    return static_cast<double>(u.ru_utime.tv_sec + u.ru_stime.tv_sec) + 1e-6 * static_cast<double>(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
  };
  const double cpu0 = cpu_now();
  std::vector<std::thread> workers;
  for (int i = 1; i < o.threads; ++i) workers.emplace_back([&] { ioc.run(); });
  ioc.run();
  for (auto& w : workers) w.join();
  rep.duration_s = secs(Clock::now() - sh->start);
  rep.fleet_cpu_s = cpu_now() - cpu0;

  for (const auto& [url, b] : before) {
    try {
      rep.origins.push_back(origin_delta(url, *b, scrape(url, o)));
    } catch (const std::exception& e) {
      OriginCounts oc;
      oc.url = url;
      oc.error = std::string("not scraped after the run: ") + e.what();
      rep.origins.push_back(oc);
    }
  }

  std::vector<float> tile_ms, roi_ms;
  for (auto& v : fleet) {
    VehicleReport r = v->report();
    rep.scans += r.scans, rep.stalled_scans += r.stalled_scans, rep.missing_tiles += r.missing_tiles;
    rep.tile_requests += r.tile_requests, rep.tiles += r.tiles, rep.tile_bytes += r.tile_bytes, rep.roi_queries += r.roi_queries;
    rep.roi_with_have += r.roi_with_have, rep.manifest_requests += r.manifest_requests, rep.bytes += r.bytes;
    rep.rejected += r.rejected, rep.failures += r.failures, rep.retries += r.retries, rep.evicted += r.evicted;
    rep.vehicles_ready += r.ready_s >= 0;
    rep.vehicles_driving += r.driving_s >= 0;
    rep.vehicles_stalled += r.stalled_scans > 0;
    tile_ms.insert(tile_ms.end(), v->tile_ms().begin(), v->tile_ms().end());
    roi_ms.insert(roi_ms.end(), v->roi_ms().begin(), v->roi_ms().end());
    merge(rep.cache_tiles, v->cache().tiles);
    merge(rep.cache_roi, v->cache().roi);
    merge(rep.cache_manifests, v->cache().manifests);
    for (const auto& [k, n] : v->failure_kinds()) rep.failure_kinds[k] += n;
    rep.per_vehicle.push_back(std::move(r));
  }
  rep.tile_latency = summarize(std::move(tile_ms));
  rep.roi_latency = summarize(std::move(roi_ms));
  rep.origin_ok = !rep.origins.empty();
  for (const auto& oc : rep.origins) {
    rep.origin_ok = rep.origin_ok && oc.ok;
    rep.origin_tiles += oc.tiles;
    rep.origin_roi += oc.roi;
    rep.origin_all += oc.tiles + oc.roi + oc.manifests + oc.other;
  }
  rep.origin_tile_share = rep.tile_requests ? rep.origin_tiles / static_cast<double>(rep.tile_requests) : 0.0;
  rep.origin_roi_share = rep.roi_queries ? rep.origin_roi / static_cast<double>(rep.roi_queries) : 0.0;
  return rep;
}

std::string report_json(const FleetReport& r) {
  json j;
  j["server"] = r.server;
  j["map"] = r.map;
  j["version"] = r.version;
  j["tile_size"] = r.tile_size;
  j["map_tiles"] = r.map_tiles;
  j["extent"] = {r.extent[0], r.extent[1], r.extent[2], r.extent[3]};
  j["vehicles"] = r.vehicles;
  j["duration_s"] = r.duration_s;
  j["fleet_cpu_s"] = r.fleet_cpu_s;
  j["radius_m"] = r.radius_m;
  j["roi_radius_m"] = r.roi_radius_m;
  j["lookahead_s"] = r.lookahead_s;
  j["vehicles_ready"] = r.vehicles_ready;
  j["vehicles_driving"] = r.vehicles_driving;
  j["vehicles_stalled"] = r.vehicles_stalled;
  for (const auto& [k, v] : std::initializer_list<std::pair<const char*, std::size_t>>{
           {"scans", r.scans}, {"stalled_scans", r.stalled_scans}, {"missing_tiles", r.missing_tiles},
           {"tile_requests", r.tile_requests}, {"tiles", r.tiles}, {"tile_bytes", r.tile_bytes},
           {"roi_queries", r.roi_queries}, {"roi_with_have", r.roi_with_have}, {"manifest_requests", r.manifest_requests},
           {"bytes", r.bytes}, {"rejected", r.rejected}, {"failures", r.failures}, {"retries", r.retries}, {"evicted", r.evicted}})
    j[k] = v;
  j["failure_kinds"] = r.failure_kinds;
  j["tile_latency"] = latency_json(r.tile_latency);
  j["roi_latency"] = latency_json(r.roi_latency);
  j["cache"] = {{"tiles", cache_json(r.cache_tiles)}, {"roi", cache_json(r.cache_roi)}, {"manifests", cache_json(r.cache_manifests)}};
  json origins = json::array();
  for (const auto& oc : r.origins)
    origins.push_back({{"url", oc.url}, {"ok", oc.ok}, {"error", oc.error}, {"tiles", oc.tiles}, {"roi", oc.roi},
                       {"manifests", oc.manifests}, {"other", oc.other}, {"errors_5xx", oc.errors_5xx}});
  j["origin"] = {{"replicas", origins},       {"ok", r.origin_ok},
                 {"tiles", r.origin_tiles},    {"roi", r.origin_roi},
                 {"all", r.origin_all},        {"tile_share", r.origin_tile_share},
                 {"roi_share", r.origin_roi_share}};
  json rows = json::array();
  for (const auto& v : r.per_vehicle)
    rows.push_back({{"id", v.id},
                    {"speed", v.speed},
                    {"start_s", v.start_s},
                    {"ready_s", v.ready_s},
                    {"driving_s", v.driving_s},
                    {"distance_m", v.distance_m},
                    {"scans", v.scans},
                    {"stalled_scans", v.stalled_scans},
                    {"missing_tiles", v.missing_tiles},
                    {"tile_requests", v.tile_requests},
                    {"tiles", v.tiles},
                    {"tile_bytes", v.tile_bytes},
                    {"roi_queries", v.roi_queries},
                    {"roi_with_have", v.roi_with_have},
                    {"manifest_requests", v.manifest_requests},
                    {"bytes", v.bytes},
                    {"rejected", v.rejected},
                    {"failures", v.failures},
                    {"retries", v.retries},
                    {"evicted", v.evicted},
                    {"tile_latency", latency_json(v.tile_latency)},
                    {"roi_latency", latency_json(v.roi_latency)}});
  j["per_vehicle"] = rows;
  return j.dump(1) + "\n";
}

std::string report_text(const FleetReport& r) {
  char b[512];
  std::string s;
  auto line = [&](const char* fmt, auto... args) {
    std::snprintf(b, sizeof b, fmt, args...);
    s += b;
  };
  auto pct = [](double a, double n) { return n > 0 ? 100.0 * a / n : 0.0; };
  line("pl-fleet: %d vehicles for %.1f s on map %s version %lld (%zu tiles of %g m) via %s\n", r.vehicles, r.duration_s, r.map.c_str(),
       r.version, r.map_tiles, r.tile_size, r.server.c_str());
  line("  vehicles: %d ready, %d driving, %d stalled at least once; pl-fleet's own CPU: %.1f s (%.0f %% of one core)\n", r.vehicles_ready,
       r.vehicles_driving, r.vehicles_stalled, r.fleet_cpu_s, r.duration_s > 0 ? 100 * r.fleet_cpu_s / r.duration_s : 0.0);
  line("  scans: %zu, with stalls %zu (%.2f %%), missing tiles %zu\n", r.scans, r.stalled_scans, pct(r.stalled_scans, r.scans),
       r.missing_tiles);
  line("  tiles: %zu requests, %zu arrived (%.1f MB), rejected %zu, failures %zu, retries %zu\n", r.tile_requests, r.tiles,
       r.tile_bytes / 1e6, r.rejected, r.failures, r.retries);
  if (!r.failure_kinds.empty()) {
    std::string kinds;
    for (const auto& [k, n] : r.failure_kinds) kinds += (kinds.empty() ? "" : ", ") + k + " " + std::to_string(n);
    line("  failures by kind: %s\n", kinds.c_str());
  }
  line("  ROI queries: %zu (%zu with have=); manifests: %zu; all bodies %.1f MB\n", r.roi_queries, r.roi_with_have, r.manifest_requests,
       r.bytes / 1e6);
  line("  tile latency ms: p50 %.2f  p90 %.2f  p99 %.2f  max %.2f  (%zu)\n", r.tile_latency.p50, r.tile_latency.p90, r.tile_latency.p99,
       r.tile_latency.max, r.tile_latency.count);
  line("  ROI latency ms:  p50 %.2f  p90 %.2f  p99 %.2f  max %.2f  (%zu)\n", r.roi_latency.p50, r.roi_latency.p90, r.roi_latency.p99,
       r.roi_latency.max, r.roi_latency.count);
  auto cache = [&](const char* what, const CacheCounts& c) {
    if (!c.with_header)
      line("  cache %s: no X-Cache header (%zu answers)\n", what, c.answers);
    else
      line("  cache %s: hit %.1f %% of %zu (miss %zu, pass %zu, stale %zu, other %zu)\n", what, 100 * c.hit_ratio(), c.with_header, c.miss,
           c.pass, c.stale, c.other);
  };
  cache("tiles", r.cache_tiles);
  cache("ROI", r.cache_roi);
  if (!r.origins.empty()) {
    line("  origin: %.0f tile requests (%.2f %% of the vehicles'), %.0f ROI (%.2f %%), %.0f in all%s\n", r.origin_tiles,
         100 * r.origin_tile_share, r.origin_roi, 100 * r.origin_roi_share, r.origin_all, r.origin_ok ? "" : " (incomplete: see below)");
    for (const auto& oc : r.origins)
      if (!oc.ok) line("    %s: %s\n", oc.url.c_str(), oc.error.c_str());
  }
  return s;
}

}  // namespace pl::fleet
