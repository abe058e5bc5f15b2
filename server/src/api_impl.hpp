// The HTTP API's state and its handlers (Api::Impl), shared by api.cpp (Api::handle, statuses,
// cache headers, gzip, logging), api_read.cpp (maps, manifests, ROI queries, blobs, tiles, places),
// api_write.cpp (uploads, versions, publishing) and api_routes.cpp (the route table). Private to
// pl_server.
#pragma once

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
inline void log_request_problem(bool as_json, const char* level, const char* what, const ApiRequest& req, const std::string& detail) {
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

  ApiResponse manifest(const ApiRequest& req, const std::string& name);

  // The map's current version vouched for fresh (pl/schema/signed_current.hpp): signed with the
  // timestamp key at each request (Ed25519 is deterministic: replicas asked in the same second give
  // the same bytes), so a cache may keep it a second like the map's manifest, never longer.
  ApiResponse current(const ApiRequest& req, const std::string& name);

  // The in-memory index of a published or retired version (which never changes), built from the
  // store's rows on first use and kept (VersionIndexCache).
  std::shared_ptr<const VersionIndex> published_index(const store::MapInfo& m, std::int64_t version);
  // Builds and keeps the index of a published or retired version that version_indexes lacks.
  std::shared_ptr<const VersionIndex> index_version(const store::MapInfo& m, std::int64_t version);

  ApiResponse roi(const ApiRequest& req, const std::string& name, const Target& t);

  // Bytes named by their content hash: the ETag and caching headers, and 304 when If-None-Match
  // names them (else status 200, for the caller to add the bytes).
  static constexpr const char* kImmutable = "public, max-age=31536000, immutable";
  static ApiResponse by_hash(const ApiRequest& req, const std::string& hash, const std::string& route, const char* cache_control);

  ApiResponse blob_response(const ApiRequest& req, const std::string& hash, const std::string& route);

  ApiResponse get_tile(const ApiRequest& req, const std::string& name, const std::string& vs, const std::string& txs, const std::string& tys);

  ApiResponse list_tiles(const ApiRequest& req, const std::string& name, const std::string& vs);

  // The places of a version. A published or retired version's places never change: cached like
  // tiles (in memory by content hash, and by HTTP caches for good). A staged version's may change
  // (and need a token to read): its answer is revalidated every time, and its ETag is the hash of
  // the very bytes sent.
  ApiResponse get_places(const ApiRequest& req, const std::string& name, const std::string& vs);

  // A version's manifest (pl/schema/signed_manifest.hpp): its canonical text, followed by its
  // signature line when it was published signed. A published or retired version's never changes:
  // kept in memory and cached by HTTP caches for good, named by the SHA-256 of the answer. A
  // staged one's (uploaders read it to sign it) is made afresh and revalidated every time.
  ApiResponse get_manifest(const ApiRequest& req, const std::string& name, const std::string& vs);

  // The staged version a write goes to, and who writes (require_role's).
  std::pair<store::VersionInfo, std::string> need_staged(const ApiRequest& req, const std::string& name, const std::string& vs);

  ApiResponse put_tile(const ApiRequest& req, const std::string& name, const std::string& vs, const std::string& txs, const std::string& tys);

  ApiResponse put_places(const ApiRequest& req, const std::string& name, const std::string& vs);

  // A staged version starts with a copy of its parent's places: an upload of a map without places
  // removes them.
  ApiResponse delete_places(const ApiRequest& req, const std::string& name, const std::string& vs);

  ApiResponse delete_tile(const ApiRequest& req, const std::string& name, const std::string& vs, const std::string& txs, const std::string& tys);

  ApiResponse create_version(const ApiRequest& req, const std::string& name);

  // Publishes a version only while the map's current version is still the one it was opened from
  // (its parent): of uploaders publishing at once, the first wins and the others get 409, each to
  // open a new version from the new current one. Nothing torn: the check and the publish are one
  // transaction under the map's write lock, on every replica of a PostgreSQL store alike.
  //
  // A body {"public_key": BASE64, "signature": BASE64} signs the version: the Ed25519 signature of
  // its manifest as GET .../manifest answers it now, checked here against the manifest the store
  // holds in the publish's own transaction, and stored with it. With --fleet-key the signature is
  // required and its key must be one of the fleet's.
  ApiResponse publish(const ApiRequest& req, const std::string& name, const std::string& vs);

  // Publishes a version an update staged (POST /v1/maps/{map}/update with "publish": true): only
  // while its parent is still current, and never unsigned where the fleet's key is required.
  void publish_update(const std::string& name, std::int64_t number, const std::string& by);

  // HEAD is GET without the body (the network side drops it); OPTIONS answers 204 with Allow.
  ApiResponse route(const ApiRequest& req, Api& api);

  static ApiResponse text(int status, std::string body, const std::string& route);
};

}  // namespace pl::server
