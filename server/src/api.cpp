#include "pl/server/api.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <deque>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <shared_mutex>
#include <sstream>
#include <unordered_map>
#include <unordered_set>

#include <zlib.h>

#include "pl/common/error.hpp"
#include "pl/common/text.hpp"
#include "pl/common/tile_codec.hpp"
#include "pl/common/tile_key.hpp"
#include "pl/schema/api_rules.hpp"
#include "pl/schema/change_report.hpp"
#include "pl/schema/signed_current.hpp"
#include "pl/schema/signed_manifest.hpp"
#include "pl/schema/store.hpp"
#include "api_parts.hpp"
#include "rate_limit.hpp"
#include "version_index.hpp"
#include "viewer.hpp"

using nlohmann::json;

namespace pl::server {

// ---------------------------------------------------------------------------------------------
// Helpers (the request and answer parts are in api_parts.hpp)

using namespace api_parts;

namespace {

// Content-addressed tiles never change: a byte-bounded cache shared by all threads.
class BlobCache {
 public:
  // Bytes, and their content hash when their key is not it (a manifest's: the hash is its ETag,
  // kept with it so that no request hashes the bytes again).
  struct Entry {
    std::shared_ptr<const std::string> bytes;  // null: not kept
    std::string hash;
  };

  explicit BlobCache(std::size_t capacity) : capacity_(capacity) {}
  std::shared_ptr<const std::string> get(const std::string& key) { return find(key).bytes; }
  Entry find(const std::string& key) {
    std::shared_lock lock(mutex_);
    auto it = map_.find(key);
    return it == map_.end() ? Entry{} : it->second;
  }
  void put(const std::string& key, std::shared_ptr<const std::string> bytes, std::string hash = {}) {
    if (bytes->size() > capacity_) return;
    std::unique_lock lock(mutex_);
    if (map_.count(key)) return;
    size_ += bytes->size();
    map_.emplace(key, Entry{std::move(bytes), std::move(hash)});
    order_.push_back(key);
    while (size_ > capacity_ && !order_.empty()) {  // oldest first
      auto it = map_.find(order_.front());
      size_ -= it->second.bytes->size();
      map_.erase(it);
      order_.pop_front();
    }
  }

 private:
  std::size_t capacity_, size_ = 0;
  std::shared_mutex mutex_;
  std::unordered_map<std::string, Entry> map_;
  std::deque<std::string> order_;
};

// The maps' rows (origin, tile size, current version) for the ROI queries, which would otherwise
// read the store on every query (a third of a query's time on SQLite; a round trip on PostgreSQL).
// A row is used for at most kFresh; this server's own writes to a map drop its row at once, so its
// own publishes show at the next query and another writer's (pl-map, another replica) within
// kFresh, well inside the second HTTP caches may keep an ROI answer anyway.
class MapRows {
 public:
  static constexpr std::chrono::milliseconds kFresh{250};

  // `read` reads the row from the store; when it fails because the store is out of reach
  // (`unreachable()` says so), the last row read is used, however old: published versions never
  // change, so the answers stay right, only a publish made meanwhile is not seen yet.
  template <typename Read, typename Unreachable>
  std::optional<store::MapInfo> get(const std::string& name, Read read, Unreachable unreachable) {
    const auto now = std::chrono::steady_clock::now();
    std::uint64_t gen;
    std::optional<store::MapInfo> stale;
    {
      std::shared_lock lock(mutex_);
      auto it = rows_.find(name);
      if (it != rows_.end() && now - it->second.read_at < kFresh) return it->second.row;
      if (it != rows_.end()) stale = it->second.row;
      gen = generation_;
    }
    std::optional<store::MapInfo> row;
    try {
      row = read();
    } catch (...) {
      if (stale && unreachable()) return stale;
      throw;
    }
    std::unique_lock lock(mutex_);
    // A drop() while this read ran may have made it stale: keep it only when none came between.
    if (row && gen == generation_) {
      if (rows_.size() >= kMaxRows) rows_.clear();
      rows_[name] = {*row, now};
    }
    return row;
  }
  void drop(const std::string& name) {
    std::unique_lock lock(mutex_);
    rows_.erase(name);
    ++generation_;
  }

 private:
  static constexpr std::size_t kMaxRows = 1024;
  struct Entry {
    store::MapInfo row;
    std::chrono::steady_clock::time_point read_at;
  };
  std::shared_mutex mutex_;
  std::unordered_map<std::string, Entry> rows_;
  std::uint64_t generation_ = 0;
};

// A request's problem on stderr, with its id: "pl-server: request ID "METHOD TARGET": WHAT: DETAIL",
// or with --log-json one JSON object.
void log_request_problem(bool as_json, const char* level, const char* what, const ApiRequest& req, const std::string& detail) {
  if (as_json)
    std::fprintf(stderr, "%s\n",
                 json({{"level", level}, {"msg", what}, {"request_id", printable(req.request_id)}, {"method", printable(req.method)},
                       {"target", printable(req.target)}, {"error", printable(detail)}})
                     .dump(-1, ' ', false, json::error_handler_t::replace)
                     .c_str());
  else
    std::fprintf(stderr, "pl-server: request %s \"%s %s\": %s: %s\n", printable(req.request_id).c_str(), printable(req.method).c_str(),
                 printable(req.target).c_str(), what, printable(detail).c_str());
  std::fflush(stderr);
}

// The map store cannot be reached (a PostgreSQL server restarting or cut off): 503, retry.
struct StoreUnreachable : Error {
  using Error::Error;
};

}  // namespace

TileUpload check_tile_upload(std::string_view bytes, double tile_size, const TileKey& key) {
  TileCloud cloud;
  try {
    cloud = decode_tile(bytes);
  } catch (const Error& e) {
    throw Error(std::string("the body is not a valid tile: ") + e.what());
  }
  if (cloud.points.empty()) throw Error("the tile has no points");
  TileBounds b = TileGrid(tile_size).bounds_of(key);
  const double slack = 0.01;  // quantization of positions near the tile's edge
  Eigen::Vector3d lo = cloud.points.front(), hi = lo;
  for (const auto& p : cloud.points) {
    if (!(p.x() >= b.min_x - slack && p.x() <= b.max_x + slack && p.y() >= b.min_y - slack && p.y() <= b.max_y + slack))
      throw Error("point (" + std::to_string(p.x()) + ", " + std::to_string(p.y()) + ") lies outside tile " + std::to_string(key.tx) +
                  "/" + std::to_string(key.ty) + " of this map's " + std::to_string(tile_size) + " m grid");
    lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
  }
  TileUpload up;
  up.points = cloud.size();
  for (int c = 0; c < 3; ++c) up.min[c] = lo[c], up.max[c] = hi[c];
  return up;
}

// ---------------------------------------------------------------------------------------------
// The API

struct Api::Impl {
  ApiConfig cfg;
  Metrics& metrics;
  BlobCache blobs;
  // Tile lookups of published and retired versions (immutable): "map/v/tx/ty" -> hash.
  std::shared_mutex tiles_mutex;
  std::unordered_map<std::string, std::string> tile_hashes;
  VersionIndexCache version_indexes{8};  // ROI lookups of published and retired versions
  MapRows map_rows;                       // for ROI queries
  RateLimiter upload_limits{cfg.upload_rate, cfg.upload_burst};  // per token, of writes
  Viewer viewer{cfg};  // the viewer's files, overviews and live vehicles (viewer.cpp)

  Impl(ApiConfig c, Metrics& m) : cfg(std::move(c)), metrics(m), blobs(cfg.blob_cache_bytes) {}

  // One store connection per thread (SQLite connections must not be shared across threads). A
  // PostgreSQL connection whose server went away (a restart, a network cut) is replaced at the next
  // call; while no new one can be made, calls throw StoreUnreachable (answered 503, retry).
  static std::unique_ptr<store::Store>& thread_conn() {
    thread_local std::unique_ptr<store::Store> conn;
    return conn;
  }
  store::Store& db() {
    thread_local std::string conn_path;
    // After a failed connect, this thread does not dial again for a second: requests meanwhile are
    // answered at once (503) instead of each waiting for a connect timeout.
    thread_local std::chrono::steady_clock::time_point retry_at{};
    thread_local std::string last_failure;
    auto& conn = thread_conn();
    if (!conn || conn_path != cfg.db || !conn->usable()) {
      conn.reset();
      if (std::chrono::steady_clock::now() < retry_at) throw StoreUnreachable(last_failure);
      try {
        conn = std::make_unique<store::Store>(store::Store::open(cfg.db, false));
      } catch (const Error& e) {
        if (!store::is_postgres_url(cfg.db)) throw;
        retry_at = std::chrono::steady_clock::now() + std::chrono::seconds(1);
        last_failure = e.what();
        throw StoreUnreachable(last_failure);
      }
      conn_path = cfg.db;
    }
    return *conn;
  }
  // After a failed call: whether it failed because the store went away under this thread's connection.
  static bool store_lost() { return thread_conn() && !thread_conn()->usable(); }

  // The request's token, looked up in the store each time: a token added or revoked (pl-map token)
  // counts at the next request, on every replica, without a restart.
  std::optional<store::Store::TokenInfo> token_of(const ApiRequest& req) {
    if (req.authorization.empty()) return std::nullopt;
    const std::string prefix = "Bearer ";
    if (req.authorization.rfind(prefix, 0) != 0) fail(401, "the Authorization header must be \"Bearer TOKEN\"");
    auto token = db().find_token(req.authorization.substr(prefix.size()));
    if (!token) fail(401, "unknown or revoked token");
    return token;
  }
  std::optional<store::Role> role_of(const ApiRequest& req) {
    auto token = token_of(req);
    return token ? std::optional<store::Role>(token->role) : std::nullopt;
  }
  // Returns who the upload log names for the request: its token's id ("token 7", never the token).
  std::string require_role(const ApiRequest& req, store::Role needed) {
    // Before the token is looked at: a token sent in clear over a network is to be rotated anyway.
    if (static_cast<int>(needed) >= static_cast<int>(store::Role::Report) && !req.from_loopback && !cfg.plain_uploads)
      fail(403, "uploads over plain HTTP are taken only from this machine: send them over HTTPS through the TLS proxy "
                "(deploy/nginx), or start pl-server with --plain-uploads when a TLS proxy on another machine forwards them");
    auto token = token_of(req);
    if (!token) fail(401, std::string("this needs a bearer token with the ") + store::role_name(needed) + " role");
    if (static_cast<int>(token->role) < static_cast<int>(needed))
      fail(403, std::string("this needs the ") + store::role_name(needed) + " role; the token has " + store::role_name(token->role));
    if (static_cast<int>(needed) >= static_cast<int>(store::Role::Report)) {
      const double wait = upload_limits.take(std::to_string(token->id));
      if (wait > 0) {
        const std::string after = std::to_string(static_cast<long>(std::ceil(wait)));
        throw HttpError{429,
                        "this token sends more than " + std::to_string(static_cast<long>(cfg.upload_rate)) +
                            " uploads a second (pl-server --upload-rate): send again in " + after + " s",
                        {{"Retry-After", after}}};
      }
    }
    return "token " + std::to_string(token->id);
  }
  // Readers: a token is needed only with --read-token-required. Returns whether staged versions show.
  bool check_reader(const ApiRequest& req) {
    auto role = role_of(req);
    if (cfg.read_token_required && !role) fail(401, "this server needs a bearer token to read maps");
    return role && static_cast<int>(*role) >= static_cast<int>(store::Role::Upload);
  }

  store::MapInfo need_map(const std::string& name) {
    auto m = db().find_map(name);
    if (!m) fail(404, "no map named \"" + name + "\"");
    return *m;
  }
  store::VersionInfo need_version(const store::MapInfo& m, std::int64_t v, bool staged_visible) {
    auto info = db().find_version(m.name, v);
    if (!info || (info->state == store::VersionState::Staged && !staged_visible))
      fail(404, "map " + m.name + " has no version " + std::to_string(v));
    return *info;
  }

  ApiResponse list_maps(const ApiRequest& req) {
    check_reader(req);
    json maps = json::array();
    for (const auto& m : db().list_maps())
      maps.push_back({{"name", m.name}, {"current_version", m.current ? json(*m.current) : json(nullptr)}});
    return revalidated(json_response(200, {{"maps", maps}}, "/v1/maps"));
  }

  ApiResponse create_map(const ApiRequest& req) {
    const std::string by = require_role(req, store::Role::Admin);
    json j;
    try {
      j = json::parse(req.body);
      std::string name = j.at("name").get<std::string>();
      const json& o = j.at("origin");
      GeoPoint origin{o.at("lat").get<double>(), o.at("lon").get<double>(), o.value("alt", 0.0)};
      double tile = j.value("tile_size", 20.0), voxel = j.value("voxel_size", 0.2);
      if (!api::valid_tile_size(tile) || !(voxel > 0.0 && voxel <= 5.0)) fail(400, "tile_size must be in [1, 1000] m and voxel_size in (0, 5] m");
      if (std::abs(origin.lat_deg) > 90 || std::abs(origin.lon_deg) > 180) fail(400, "origin lat must be in [-90, 90] and lon in [-180, 180]");
      if (db().find_map(name)) fail(409, "a map named \"" + name + "\" exists already");
      store::MapInfo m;
      store::Store::Transaction tx(db());  // the change and its log entry together
      try {
        m = db().create_map(name, origin, tile, voxel);
      } catch (const Error& e) {
        fail(400, e.what());
      }
      db().log_upload(name, std::nullopt, "create_map", req.body, by);
      tx.commit();
      return json_response(201, {{"name", m.name}, {"tile_size", m.tile_size}, {"voxel_size", m.voxel_size}}, "/v1/maps");
    } catch (const json::exception& e) {
      fail(400, std::string("expected JSON {\"name\", \"origin\": {\"lat\", \"lon\", \"alt\"}, \"tile_size\", \"voxel_size\"}: ") + e.what());
    }
  }

  ApiResponse manifest(const ApiRequest& req, const std::string& name) {
    check_reader(req);
    auto m = need_map(name);
    json j = {{"name", m.name},
              {"current_version", m.current ? json(*m.current) : json(nullptr)},
              {"origin", {{"lat", m.origin.lat_deg}, {"lon", m.origin.lon_deg}, {"alt", m.origin.alt_m}}},
              {"tile_size", m.tile_size},
              {"voxel_size", m.voxel_size}};
    if (m.current) {
      const auto index = published_index(m, *m.current);
      const auto& t = index->totals();
      j["tile_count"] = index->size();
      j["points"] = t.points;
      j["bytes"] = t.bytes;
      if (index->size() > 0) j["bounds"] = {{"min", {t.min[0], t.min[1], t.min[2]}}, {"max", {t.max[0], t.max[1], t.max[2]}}};
    } else {
      j["tile_count"] = 0;
      j["points"] = 0;
      j["bytes"] = 0;
    }
    return revalidated(json_response(200, j, "/v1/maps/{map}"));
  }

  // The map's current version vouched for fresh (pl/schema/signed_current.hpp): signed with the
  // timestamp key at each request (Ed25519 is deterministic: replicas asked in the same second give
  // the same bytes), so a cache may keep it a second like the map's manifest, never longer.
  ApiResponse current(const ApiRequest& req, const std::string& name) {
    const std::string route = "/v1/maps/{map}/current";
    check_reader(req);
    if (!cfg.timestamp_key)
      fail(404, "this server signs no current-version statements: start pl-server with --timestamp-key FILE (a key of pl-map key-gen) "
                "and give the vehicles its public key (pl-localize --timestamp-keys)");
    auto m = need_map(name);
    if (!m.current) fail(404, "map " + name + " has no published version yet");
    const std::int64_t now = signing::unix_now();
    return revalidated(text(200, signing::sign_current({name, *m.current, now, now + cfg.timestamp_lifetime_s}, *cfg.timestamp_key), route));
  }

  // The in-memory index of a published or retired version (which never changes), built from the
  // store's rows on first use and kept (VersionIndexCache).
  std::shared_ptr<const VersionIndex> published_index(const store::MapInfo& m, std::int64_t version) {
    auto index = version_indexes.find(m.name, version);
    return index ? index : index_version(m, version);
  }
  // Builds and keeps the index of a published or retired version that version_indexes lacks.
  std::shared_ptr<const VersionIndex> index_version(const store::MapInfo& m, std::int64_t version) {
    auto index = std::make_shared<const VersionIndex>(m.tile_size, db().list_tiles(m.name, version));
    version_indexes.put(m.name, version, index);
    return index;
  }

  ApiResponse roi(const ApiRequest& req, const std::string& name, const Target& t) {
    bool staged = check_reader(req);
    auto found = map_rows.get(name, [&] { return db().find_map(name); }, [] {
      try {
        throw;
      } catch (const StoreUnreachable&) {
        return true;
      } catch (...) {
        return store_lost();
      }
    });
    if (!found) fail(404, "no map named \"" + name + "\"");
    const store::MapInfo& m = *found;
    double x = query_number(t, "x", true, 0), y = query_number(t, "y", true, 0), r = query_number(t, "radius", true, 0);
    if (!(r >= 0 && r <= api::kMaxRoiRadiusM)) fail(400, "radius must be between 0 and 5000 m");
    const bool version_asked = t.query.count("version") > 0;
    std::int64_t version = 0;
    if (version_asked) {
      version = parse_version(t.query.at("version"));
    } else {
      if (!m.current) fail(404, "map " + name + " has no published version");
      version = *m.current;
    }
    // A version indexed here is published or retired, and stays so: no trip to the store (whose
    // version row sums the version's tiles) on the vehicles' every query, and the index looked up once.
    std::shared_ptr<const VersionIndex> index = version_indexes.find(name, version);
    bool staged_version = false;
    if (!index && version_asked) {
      const store::VersionInfo info = need_version(m, version, staged);
      staged_version = info.state == store::VersionState::Staged;
    }
    std::set<std::string> have;
    if (t.query.count("have"))
      for (auto h : split_fields(t.query.at("have"), ",")) {
        std::string hs(h);
        if (!api::is_hash(hs)) fail(400, "have= takes comma-separated tile hashes (64 hex digits)");
        have.insert(hs);
      }
    // A published or retired version never changes: its tiles are indexed in memory once. A staged
    // one is read from the store each time, candidates from the R*Tree over tile boxes (grown by a
    // tile, since a tile's points need not reach its square's edge); then, either way, the exact
    // test against each tile's square.
    if (staged_version) {
      index = std::make_shared<const VersionIndex>(
          m.tile_size, db().tiles_in_box(name, version, x - r - m.tile_size, y - r - m.tile_size, x + r + m.tile_size, y + r + m.tile_size));
    } else if (!index) {
      index = index_version(m, version);
    }
    std::vector<const VersionIndex::Tile*> send;
    std::unordered_set<std::string_view> in_roi;  // for drop: only asked for with have=
    for (const VersionIndex::Tile* tile : index->in_disc(x, y, r)) {
      if (have.empty()) {
        send.push_back(tile);
        continue;
      }
      in_roi.insert(tile->hash);
      if (!have.count(tile->hash)) send.push_back(tile);
    }
    std::vector<std::string_view> drop;
    for (const auto& h : have)
      if (!in_roi.count(h)) drop.push_back(h);
    ApiResponse res;
    res.status = 200;
    res.body = roi_body(name, version, m.tile_size, send, drop);
    res.route = "/v1/maps/{map}/roi";
    res.revalidate = true;
    // The answer to one URL is fixed by the version it is of (a published or retired version's
    // tiles never change) and by the map itself (a store rebuilt under the same name has another
    // creation time): the tag says those, without hashing the body on every request. A staged
    // version's answer changes with its tiles: its tag is the body's hash.
    if (!staged_version) res.etag = answer_tag(m, version, req.target);
    return res;
  }

  // Bytes named by their content hash: the ETag and caching headers, and 304 when If-None-Match
  // names them (else status 200, for the caller to add the bytes).
  static constexpr const char* kImmutable = "public, max-age=31536000, immutable";
  static ApiResponse by_hash(const ApiRequest& req, const std::string& hash, const std::string& route, const char* cache_control) {
    std::string etag = "\"" + hash + "\"";
    ApiResponse r;
    r.route = route;
    r.headers = {{"ETag", etag}, {"Cache-Control", cache_control}};
    if (!req.if_none_match.empty() && (req.if_none_match == "*" || req.if_none_match.find(etag) != std::string::npos)) {
      r.status = 304;
      r.content_type.clear();
    }
    return r;
  }

  ApiResponse blob_response(const ApiRequest& req, const std::string& hash, const std::string& route) {
    ApiResponse r = by_hash(req, hash, route, kImmutable);
    if (r.status == 304) return r;
    auto bytes = blobs.get(hash);
    if (!bytes) {
      auto b = db().blob(hash);
      if (!b) fail(404, "no tile with hash " + hash);
      bytes = std::make_shared<const std::string>(std::move(*b));
      blobs.put(hash, bytes);
    }
    r.status = 200;
    r.content_type = "application/vnd.google.draco";
    r.blob = std::move(bytes);
    r.blob_hash = hash;
    return r;
  }

  ApiResponse get_tile(const ApiRequest& req, const std::string& name, const std::string& vs, const std::string& txs, const std::string& tys) {
    const std::string route = "/v1/maps/{map}/versions/{v}/tiles/{tx}/{ty}";
    bool staged = check_reader(req);
    std::int64_t v = parse_version(vs);
    TileKey key{parse_tile_index(txs), parse_tile_index(tys)};
    std::string cache_key = name + "/" + std::to_string(v) + "/" + std::to_string(key.tx) + "/" + std::to_string(key.ty);
    {
      std::shared_lock lock(tiles_mutex);
      auto it = tile_hashes.find(cache_key);
      if (it != tile_hashes.end()) return blob_response(req, it->second, route);
    }
    auto m = need_map(name);
    auto info = need_version(m, v, staged);
    auto rec = db().find_tile(name, v, key);
    if (!rec) fail(404, "map " + name + " version " + std::to_string(v) + " has no tile " + std::to_string(key.tx) + "/" + std::to_string(key.ty));
    if (info.state != store::VersionState::Staged) {
      std::unique_lock lock(tiles_mutex);
      tile_hashes.emplace(cache_key, rec->hash);
    }
    return blob_response(req, rec->hash, route);
  }

  ApiResponse list_tiles(const ApiRequest& req, const std::string& name, const std::string& vs) {
    bool staged = check_reader(req);
    auto m = need_map(name);
    auto info = need_version(m, parse_version(vs), staged);
    json tiles = json::array();
    for (const auto& t : db().list_tiles(name, info.number))
      tiles.push_back({{"tx", t.key.tx}, {"ty", t.key.ty}, {"hash", t.hash}, {"points", t.points}, {"bytes", t.bytes}});
    return revalidated(json_response(200, {{"version", info.number}, {"state", store::state_name(info.state)}, {"tiles", tiles}},
                                     "/v1/maps/{map}/versions/{v}/tiles"));
  }

  // The places of a version. A published or retired version's places never change: cached like
  // tiles (in memory by content hash, and by HTTP caches for good). A staged version's may change
  // (and need a token to read): its answer is revalidated every time, and its ETag is the hash of
  // the very bytes sent.
  ApiResponse get_places(const ApiRequest& req, const std::string& name, const std::string& vs) {
    const std::string route = "/v1/maps/{map}/versions/{v}/places";
    bool staged = check_reader(req);
    auto m = need_map(name);
    auto info = need_version(m, parse_version(vs), staged);
    const std::string none = "map " + name + " version " + std::to_string(info.number) +
                             " has no places: rebuild it with pl-map build and pl-map tile";
    if (info.state == store::VersionState::Staged) {
      auto bytes = db().places(name, info.number);
      if (!bytes) fail(404, none);
      const std::string hash = store::content_hash(*bytes);
      ApiResponse r = by_hash(req, hash, route, "private, no-cache");
      if (r.status == 304) return r;
      r.content_type = "application/octet-stream";
      r.blob = std::make_shared<const std::string>(std::move(*bytes));
      r.blob_hash = hash;
      return r;
    }
    auto hash = db().places_hash(name, info.number);
    if (!hash) fail(404, none);
    ApiResponse r = by_hash(req, *hash, route, kImmutable);
    if (r.status == 304) return r;
    // Keyed apart from tile blobs, so that GET /v1/blobs/{hash} never answers with places.
    const std::string key = "places/" + *hash;
    auto bytes = blobs.get(key);
    if (!bytes) {
      auto b = db().places(name, info.number);
      if (!b) fail(404, none);
      bytes = std::make_shared<const std::string>(std::move(*b));
      blobs.put(key, bytes);
    }
    r.content_type = "application/octet-stream";
    r.blob = std::move(bytes);
    r.blob_hash = *hash;
    return r;
  }

  // A version's manifest (pl/schema/signed_manifest.hpp): its canonical text, followed by its
  // signature line when it was published signed. A published or retired version's never changes:
  // kept in memory and cached by HTTP caches for good, named by the SHA-256 of the answer. A
  // staged one's (uploaders read it to sign it) is made afresh and revalidated every time.
  ApiResponse get_manifest(const ApiRequest& req, const std::string& name, const std::string& vs) {
    const std::string route = "/v1/maps/{map}/versions/{v}/manifest";
    bool staged = check_reader(req);
    auto m = need_map(name);
    auto info = need_version(m, parse_version(vs), staged);
    const bool fixed = info.state != store::VersionState::Staged;
    const std::string key = "manifest/" + name + "/" + std::to_string(info.number);
    // Kept with its hash (the ETag): a request for a kept manifest hashes nothing.
    BlobCache::Entry answer = fixed ? blobs.find(key) : BlobCache::Entry{};
    if (!answer.bytes) {
      std::string text = signing::manifest_text(signing::manifest_of(db(), name, info.number));
      if (auto sig = db().signature(name, info.number)) text += signing::signature_line(sig->public_key, sig->signature);
      answer.hash = store::content_hash(text);
      answer.bytes = std::make_shared<const std::string>(std::move(text));
      if (fixed) blobs.put(key, answer.bytes, answer.hash);
    }
    ApiResponse r = by_hash(req, answer.hash, route, fixed ? kImmutable : "private, no-cache");
    if (r.status == 304) return r;
    r.content_type = "text/plain; charset=utf-8";
    if (fixed) {  // sent from a file of its own, like tiles
      r.blob = std::move(answer.bytes);
      r.blob_hash = std::move(answer.hash);
    } else {
      r.body = *answer.bytes;
    }
    return r;
  }

  // The staged version a write goes to, and who writes (require_role's).
  std::pair<store::VersionInfo, std::string> need_staged(const ApiRequest& req, const std::string& name, const std::string& vs) {
    std::string by = require_role(req, store::Role::Upload);
    auto m = need_map(name);
    auto info = need_version(m, parse_version(vs), true);
    if (info.state != store::VersionState::Staged)
      fail(409, "map " + name + " version " + std::to_string(info.number) + " is " + store::state_name(info.state) +
                    ": open a new version with POST /v1/maps/" + name + "/versions");
    return {info, by};
  }

  ApiResponse put_tile(const ApiRequest& req, const std::string& name, const std::string& vs, const std::string& txs, const std::string& tys) {
    const std::string route = "/v1/maps/{map}/versions/{v}/tiles/{tx}/{ty}";
    auto [info, by] = need_staged(req, name, vs);
    TileKey key{parse_tile_index(txs), parse_tile_index(tys)};
    auto m = need_map(name);
    TileUpload up;
    try {
      up = check_tile_upload(req.body, m.tile_size, key);
    } catch (const Error& e) {
      fail(422, e.what());
    }
    store::Store::Transaction tx(db());  // the change and its log entry together
    auto rec = db().put_tile(name, info.number, key, req.body, static_cast<std::int64_t>(up.points), up.min[0], up.min[1], up.min[2],
                             up.max[0], up.max[1], up.max[2]);
    db().log_upload(name, info.number, "put_tile", std::to_string(key.tx) + "/" + std::to_string(key.ty) + " " + rec.hash, by);
    tx.commit();
    return json_response(200, {{"tx", key.tx}, {"ty", key.ty}, {"hash", rec.hash}, {"points", rec.points}, {"bytes", rec.bytes}}, route);
  }

  ApiResponse put_places(const ApiRequest& req, const std::string& name, const std::string& vs) {
    auto [info, by] = need_staged(req, name, vs);
    if (req.body.empty()) fail(422, "the body is empty: PUT the places file that pl-map build wrote (1 byte to 64 MiB)");
    store::Store::Transaction tx(db());
    db().put_places(name, info.number, req.body);
    const std::string hash = store::content_hash(req.body);
    db().log_upload(name, info.number, "put_places", hash + " " + std::to_string(req.body.size()) + " bytes", by);
    tx.commit();
    return json_response(200, {{"version", info.number}, {"hash", hash}, {"bytes", req.body.size()}},
                         "/v1/maps/{map}/versions/{v}/places");
  }

  // A staged version starts with a copy of its parent's places: an upload of a map without places
  // removes them.
  ApiResponse delete_places(const ApiRequest& req, const std::string& name, const std::string& vs) {
    auto [info, by] = need_staged(req, name, vs);
    store::Store::Transaction tx(db());
    if (!db().delete_places(name, info.number)) fail(404, "map " + name + " version " + std::to_string(info.number) + " has no places");
    db().log_upload(name, info.number, "delete_places", "", by);
    tx.commit();
    return json_response(200, {{"deleted", true}}, "/v1/maps/{map}/versions/{v}/places");
  }

  ApiResponse delete_tile(const ApiRequest& req, const std::string& name, const std::string& vs, const std::string& txs, const std::string& tys) {
    auto [info, by] = need_staged(req, name, vs);
    TileKey key{parse_tile_index(txs), parse_tile_index(tys)};
    store::Store::Transaction tx(db());
    if (!db().delete_tile(name, info.number, key)) fail(404, "version " + std::to_string(info.number) + " has no tile " + txs + "/" + tys);
    db().log_upload(name, info.number, "delete_tile", txs + "/" + tys, by);
    tx.commit();
    return json_response(200, {{"deleted", true}}, "/v1/maps/{map}/versions/{v}/tiles/{tx}/{ty}");
  }

  ApiResponse create_version(const ApiRequest& req, const std::string& name) {
    const std::string by = require_role(req, store::Role::Upload);
    need_map(name);
    std::string note;
    if (!req.body.empty()) {
      try {
        note = json::parse(req.body).value("note", "");
      } catch (const json::exception& e) {
        fail(400, std::string("expected an optional JSON body {\"note\": \"...\"}: ") + e.what());
      }
    }
    store::Store::Transaction tx(db());
    auto v = db().create_version(name, std::nullopt, note);
    db().log_upload(name, v.number, "create_version", note, by);
    tx.commit();
    return json_response(201, {{"version", v.number}, {"parent", v.parent ? json(*v.parent) : json(nullptr)}, {"state", "staged"}},
                         "/v1/maps/{map}/versions");
  }

  // Publishes a version only while the map's current version is still the one it was opened from
  // (its parent): of uploaders publishing at once, the first wins and the others get 409, each to
  // open a new version from the new current one. Nothing torn: the check and the publish are one
  // transaction under the map's write lock, on every replica of a PostgreSQL store alike.
  //
  // A body {"public_key": BASE64, "signature": BASE64} signs the version: the Ed25519 signature of
  // its manifest as GET .../manifest answers it now, checked here against the manifest the store
  // holds in the publish's own transaction, and stored with it. With --fleet-key the signature is
  // required and its key must be one of the fleet's.
  ApiResponse publish(const ApiRequest& req, const std::string& name, const std::string& vs) {
    auto [info, by] = need_staged(req, name, vs);
    std::optional<std::pair<std::string, std::string>> sig;  // public key, signature
    if (!req.body.empty()) {
      const json j = json::parse(req.body, nullptr, false);
      const char* expected = "expected no body, or the JSON {\"public_key\": BASE64, \"signature\": BASE64} of an Ed25519 signature";
      if (!j.is_object() || !j.contains("public_key") || !j.contains("signature") || !j["public_key"].is_string() || !j["signature"].is_string())
        fail(400, expected);
      auto key = signing::decode_base64(j["public_key"].get<std::string>());
      auto s = signing::decode_base64(j["signature"].get<std::string>());
      if (!key || key->size() != 32 || !s || s->size() != 64) fail(400, std::string(expected) + " (32 and 64 bytes)");
      sig.emplace(std::move(*key), std::move(*s));
    }
    if (!cfg.fleet_keys.empty()) {
      if (!sig)
        fail(422, "this server publishes signed versions only (pl-server --fleet-key): publish with pl-map push --signing-key KEY");
      if (std::find(cfg.fleet_keys.begin(), cfg.fleet_keys.end(), sig->first) == cfg.fleet_keys.end())
        fail(403, "the version is signed by key " + signing::key_id(sig->first) +
                      ", which is not one of this server's fleet keys (pl-server --fleet-key): sign with the fleet's key");
    }
    bool published = false;
    {
      store::Store::Transaction tx(db());
      std::string detail;
      if (sig) {
        try {
          signing::sign_staged_version(db(), name, info.number, sig->first, sig->second);
        } catch (const signing::SignatureMismatch&) {
          fail(422, "the signature does not verify against version " + std::to_string(info.number) +
                        "'s manifest as the store holds it: sign the bytes GET /v1/maps/" + name + "/versions/" +
                        std::to_string(info.number) + "/manifest answers after the last upload");
        }
        detail = "signed by key " + signing::key_id(sig->first);
      }
      published = db().publish_if_current(name, info.number, info.parent);
      if (published) {
        db().log_upload(name, info.number, "publish", detail, by);
        tx.commit();
      }
    }
    if (!published) {
      const auto now = db().find_map(name);
      const std::string current = now && now->current ? "version " + std::to_string(*now->current) : "no version";
      const std::string opened = info.parent ? "version " + std::to_string(*info.parent) : "no version";
      db().log_upload(name, info.number, "publish_refused", current + " is current, not " + opened, by);
      fail(409, "map " + name + " changed while version " + std::to_string(info.number) + " was staged: it was opened from " + opened +
                    ", and " + current + " is current now (another upload was published first). Open a new version (POST /v1/maps/" +
                    name + "/versions), upload the changes to it and publish that: pl-map push does all of this when run again");
    }
    map_rows.drop(name);
    return json_response(200, {{"version", info.number}, {"state", "published"}}, "/v1/maps/{map}/versions/{v}/publish");
  }

  // Publishes a version an update staged (POST /v1/maps/{map}/update with "publish": true): only
  // while its parent is still current, and never unsigned where the fleet's key is required.
  void publish_update(const std::string& name, std::int64_t number, const std::string& by) {
    if (!cfg.fleet_keys.empty())
      fail(422, "version " + std::to_string(number) + " is staged; this server publishes signed versions only (pl-server "
                "--fleet-key): sign and publish it with pl-map push --signing-key, or pl-map publish --signing-key on the store");
    const auto info = db().find_version(name, number);
    store::Store::Transaction tx(db());
    if (!info || !db().publish_if_current(name, number, info->parent))
      fail(409, "map " + name + " changed while the update was staged: version " + std::to_string(number) + " stays staged");
    db().log_upload(name, number, "publish", "update", by);
    tx.commit();
    map_rows.drop(name);
  }

  // HEAD is GET without the body (the network side drops it); OPTIONS answers 204 with Allow.
  ApiResponse route(const ApiRequest& req, Api& api) {
    Target t = parse_target(req.target);
    const auto& s = t.segments;
    const std::string& m = req.method;
    const bool get = m == "GET" || m == "HEAD";
    auto options = [](const char* allow) {
      ApiResponse r;
      r.status = 204;
      r.content_type.clear();
      r.headers = {{"Allow", allow}};
      return r;
    };
    auto only = [&](bool ok, const std::string& route, const char* allow) {
      if (m == "OPTIONS") return true;
      if (!ok) method_not_allowed(m, route, allow);
      return false;
    };
    if (s.size() == 1 && (s[0] == "healthz" || s[0] == "readyz" || s[0] == "metrics")) {
      const std::string route = "/" + s[0];
      if (only(get, route, kReadOnly)) return options(kReadOnly);
      if (s[0] == "healthz") return text(200, "ok\n", route);
      if (s[0] == "readyz") return api.ready() ? text(200, "ready\n", route) : text(503, "not ready\n", route);
      // The store's size when it answers (-1 while it is out of reach: the rest still renders).
      std::int64_t bytes = -1;
      try {
        bytes = db().database_bytes();
      } catch (...) {
      }
      ApiResponse r = text(200, metrics.render(bytes), route);
      r.content_type = "text/plain; version=0.0.4";
      return r;
    }
    if (!s.empty() && s[0] == "viewer") {  // static files: no token, they hold no map data
      if (only(get, "/viewer/{file}", kReadOnly)) return options(kReadOnly);
      return viewer.file(req);
    }
    if (s.empty() || s[0] != "v1") fail(404, "no such resource: " + req.target);
    if (s.size() == 3 && s[1] == "blobs") {
      if (only(get, "/v1/blobs/{hash}", kReadOnly)) return options(kReadOnly);
      check_reader(req);
      if (!api::is_hash(s[2])) fail(400, "a blob is named by its SHA-256 (64 lowercase hex digits)");
      return blob_response(req, s[2], "/v1/blobs/{hash}");
    }
    if (s.size() < 2 || s[1] != "maps") fail(404, "no such resource: " + req.target);
    if (s.size() == 2) {
      const char* allow = "GET, HEAD, POST, OPTIONS";
      if (only(get || m == "POST", "/v1/maps", allow)) return options(allow);
      return get ? list_maps(req) : create_map(req);
    }
    const std::string& map = s[2];
    if (s.size() == 3) {
      if (only(get, "/v1/maps/{map}", kReadOnly)) return options(kReadOnly);
      return manifest(req, map);
    }
    if (s.size() == 4 && s[3] == "current") {
      if (only(get, "/v1/maps/{map}/current", kReadOnly)) return options(kReadOnly);
      return current(req, map);
    }
    if (s.size() == 4 && s[3] == "roi") {
      if (only(get, "/v1/maps/{map}/roi", kReadOnly)) return options(kReadOnly);
      return roi(req, map, t);
    }
    if (s.size() == 4 && s[3] == "reports") {
      const char* allow = "GET, HEAD, POST, OPTIONS";
      if (only(get || m == "POST", "/v1/maps/{map}/reports", allow)) return options(allow);
      if (get) {
        require_role(req, store::Role::Upload);
        return list_reports(db(), t, map);
      }
      return post_report(db(), req, map, require_role(req, store::Role::Report));
    }
    if (s.size() == 4 && s[3] == "changes") {
      if (only(get, "/v1/maps/{map}/changes", kReadOnly)) return options(kReadOnly);
      check_reader(req);
      return changes(db(), t, map);
    }
    if (s.size() == 4 && s[3] == "update") {
      if (only(m == "POST", "/v1/maps/{map}/update", kPostOnly)) return options(kPostOnly);
      const std::string by = require_role(req, store::Role::Admin);
      return update(db(), req, map, by, [&](std::int64_t number) { publish_update(map, number, by); });
    }
    if (s.size() == 4 && s[3] == "vehicles") {
      if (only(get, "/v1/maps/{map}/vehicles", kReadOnly)) return options(kReadOnly);
      check_reader(req);
      return viewer.vehicles(need_map(map).name);
    }
    if (s.size() == 5 && s[3] == "vehicles") {
      if (only(m == "POST", "/v1/maps/{map}/vehicles/{id}", kPostOnly)) return options(kPostOnly);
      require_role(req, store::Role::Report);
      return viewer.post_vehicle(req, need_map(map).name, s[4]);
    }
    if (s.size() == 4 && s[3] == "events") {
      if (only(get, "/v1/maps/{map}/events", kReadOnly)) return options(kReadOnly);
      check_reader(req);
      return viewer.events(need_map(map).name, m == "HEAD");
    }
    if (s[3] != "versions") fail(404, "no such resource: " + req.target);
    if (s.size() == 4) {
      const char* allow = "GET, HEAD, POST, OPTIONS";
      if (only(get || m == "POST", "/v1/maps/{map}/versions", allow)) return options(allow);
      if (get) {  // the version list (the viewer's): staged ones for upload tokens only
        const bool staged = check_reader(req);
        return Viewer::versions(db(), need_map(map), staged);
      }
      return create_version(req, map);
    }
    if (s.size() == 6 && s[5] == "overview") {
      if (only(get, "/v1/maps/{map}/versions/{v}/overview", kReadOnly)) return options(kReadOnly);
      const bool staged = check_reader(req);
      const auto mi = need_map(map);
      return viewer.overview(db(), req, mi, need_version(mi, parse_version(s[4]), staged));
    }
    if (s.size() == 6 && s[5] == "publish") {
      if (only(m == "POST", "/v1/maps/{map}/versions/{v}/publish", kPostOnly)) return options(kPostOnly);
      return publish(req, map, s[4]);
    }
    if (s.size() == 6 && s[5] == "manifest") {
      if (only(get, "/v1/maps/{map}/versions/{v}/manifest", kReadOnly)) return options(kReadOnly);
      return get_manifest(req, map, s[4]);
    }
    if (s.size() == 6 && s[5] == "places") {
      const char* allow = "GET, HEAD, PUT, DELETE, OPTIONS";
      if (only(get || m == "PUT" || m == "DELETE", "/v1/maps/{map}/versions/{v}/places", allow)) return options(allow);
      if (get) return get_places(req, map, s[4]);
      return m == "PUT" ? put_places(req, map, s[4]) : delete_places(req, map, s[4]);
    }
    if (s.size() == 6 && s[5] == "tiles") {
      if (only(get, "/v1/maps/{map}/versions/{v}/tiles", kReadOnly)) return options(kReadOnly);
      return list_tiles(req, map, s[4]);
    }
    if (s.size() == 8 && s[5] == "tiles") {
      const char* allow = "GET, HEAD, PUT, DELETE, OPTIONS";
      if (only(get || m == "PUT" || m == "DELETE", "/v1/maps/{map}/versions/{v}/tiles/{tx}/{ty}", allow)) return options(allow);
      if (get) return get_tile(req, map, s[4], s[6], s[7]);
      if (m == "PUT") return put_tile(req, map, s[4], s[6], s[7]);
      return delete_tile(req, map, s[4], s[6], s[7]);
    }
    fail(404, "no such resource: " + req.target);
  }

  static ApiResponse text(int status, std::string body, const std::string& route) {
    ApiResponse r;
    r.status = status;
    r.body = std::move(body);
    r.content_type = "text/plain";
    r.route = route;
    return r;
  }
};

Api::Api(ApiConfig cfg, Metrics& metrics) : impl_(std::make_unique<Impl>(std::move(cfg), metrics)) {
  impl_->db();  // fail at start-up, not on the first request, when the store cannot be opened
}

Api::~Api() = default;

// Ready: not draining, and the store answers a query (the schema version: a read of the store
// itself on both engines, not of any map).
bool Api::ready() {
  if (draining_) return false;
  try {
    impl_->db().schema_version();
    return true;
  } catch (...) {
    return false;
  }
}

std::size_t Api::body_limit(const std::string& method, const std::string& target) {
  if (method == "PUT" && target.find("/tiles/") != std::string::npos) return 64u << 20;
  if (method == "PUT") {
    const Target t = parse_target(target);  // as route() reads it
    const auto& s = t.segments;
    if (s.size() == 6 && s[0] == "v1" && s[1] == "maps" && s[3] == "versions" && s[5] == "places") return api::kMaxPlacesBytes;
  }
  if (method == "POST") {
    const Target t = parse_target(target);
    const auto& s = t.segments;
    if (s.size() == 4 && s[0] == "v1" && s[1] == "maps" && s[3] == "reports") return schema::ChangeReportLimits{}.max_bytes;
    return 64u << 10;
  }
  return 0;
}

// The route template of a target, for metrics of requests that failed before reaching a handler.
constexpr std::size_t kGzipMinBytes = 256;

static std::string route_template(const std::string& target) {
  Target t = parse_target(target);
  const auto& s = t.segments;
  if (s.size() == 1 && (s[0] == "healthz" || s[0] == "readyz" || s[0] == "metrics")) return "/" + s[0];
  if (!s.empty() && s[0] == "viewer") return "/viewer/{file}";
  if (s.size() == 5 && s[0] == "v1" && s[1] == "maps" && s[3] == "vehicles") return "/v1/maps/{map}/vehicles/{id}";
  if (s.size() < 2 || s[0] != "v1") return "other";
  if (s[1] == "blobs" && s.size() == 3) return "/v1/blobs/{hash}";
  if (s[1] != "maps") return "other";
  static const char* names[] = {"v1", "maps", "{map}", "", "{v}", "", "{tx}", "{ty}"};
  std::string out;
  for (std::size_t i = 0; i < s.size() && i < 8; ++i) out += "/" + (names[i][0] ? std::string(names[i]) : s[i]);
  return s.size() > 8 ? "other" : out;
}

ApiResponse Api::handle(const ApiRequest& req) {
  ApiResponse r;
  try {
    try {
      r = impl_->route(req, *this);
    } catch (const HttpError& e) {
      r = json_response(e.status, {{"error", e.message}, {"status", e.status}}, route_template(req.target));
      r.headers = e.headers;
      if (e.status == 401)  // RFC 6750: which scheme, and whether a token was sent but refused
        r.headers.emplace_back("WWW-Authenticate", req.authorization.empty() ? "Bearer realm=\"pl-server\""
                                                                             : "Bearer realm=\"pl-server\", error=\"invalid_token\"");
    }
    // The answers that change as maps are published (ApiResponse::revalidate): an HTTP cache in
    // front (deploy/varnish, deploy/nginx) may keep one for a second, then revalidate it by its ETag
    // (weak: a proxy may re-encode the body). An answer to a request with a token is that token's:
    // private.
    const bool get = req.method == "GET" || req.method == "HEAD";
    if (r.status == 200 && get && r.revalidate) {
      const std::string tag = "\"" + (r.etag.empty() ? store::content_hash(r.body).substr(0, 32) : r.etag) + "\"";
      r.headers.emplace_back("ETag", "W/" + tag);
      r.headers.emplace_back("Cache-Control", req.authorization.empty() ? "public, max-age=1" : "private, no-cache");
      if (!req.if_none_match.empty() && (req.if_none_match == "*" || req.if_none_match.find(tag) != std::string::npos)) {
        r.status = 304;
        r.body.clear();
        r.content_type.clear();
        r.headers.emplace_back("Vary", "Accept-Encoding");  // as the 200 it stands for
      }
    }
    // JSON answers: compressed when the client accepts gzip and it pays (a few hundred bytes on).
    if (r.content_type == "application/json" && !r.blob) {
      r.headers.emplace_back("Vary", "Accept-Encoding");
      if (r.body.size() >= kGzipMinBytes && accepts_gzip(req.accept_encoding)) {
        r.body = gzip(r.body);
        r.headers.emplace_back("Content-Encoding", "gzip");
      }
    }
    return r;
  } catch (...) {
    // The store out of reach (its server restarting): 503 with Retry-After, which clients and
    // caches retry; nothing was written (a write's transaction did not commit).
    std::string unreachable;
    try {
      throw;
    } catch (const StoreUnreachable& e) {
      unreachable = e.what();
    } catch (const std::exception& e) {
      if (Impl::store_lost()) unreachable = e.what();
    } catch (...) {
    }
    if (!unreachable.empty()) {
      // The details (the store's address, the driver's words) go to the log, not to the client.
      log_request_problem(impl_->cfg.log_json, "warning", "the map store is unreachable", req, unreachable);
      const bool read = req.method == "GET" || req.method == "HEAD";
      ApiResponse e = json_response(
          503,
          {{"error", std::string("the map store is unreachable just now: retry in a second") +
                         (read ? "" : " (a change whose answer this is was not made, unless the store lost contact while committing it: "
                                      "read back before repeating one that is not idempotent, such as opening a version)")},
           {"status", 503}},
          route_template(req.target));
      e.headers.emplace_back("Retry-After", "1");
      return e;
    }
    // Anything else unexpected (a store failure, a bug, memory): a 500 for this request only,
    // logged with the request id; the server goes on serving.
    std::string what = "unknown exception";
    try {
      throw;
    } catch (const std::exception& e) {
      what = e.what();
    } catch (...) {
    }
    log_request_problem(impl_->cfg.log_json, "error", "internal error", req, what);
    ApiResponse e;
    e.status = 500;
    e.body = "{\"error\":\"internal error: see the server log for request " + printable(req.request_id, 64) + "\",\"status\":500}\n";
    e.route = "other";
    return e;
  }
}

}  // namespace pl::server
