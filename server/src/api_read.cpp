// The API's reads: maps, manifests, current-version statements, ROI queries, blobs, tiles, places.
#include "api_impl.hpp"

namespace pl::server {

ApiResponse Api::Impl::manifest(const ApiRequest& req, const std::string& name) {
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
ApiResponse Api::Impl::current(const ApiRequest& req, const std::string& name) {
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
std::shared_ptr<const VersionIndex> Api::Impl::published_index(const store::MapInfo& m, std::int64_t version) {
  auto index = version_indexes.find(m.name, version);
  return index ? index : index_version(m, version);
}

// Builds and keeps the index of a published or retired version that version_indexes lacks.
std::shared_ptr<const VersionIndex> Api::Impl::index_version(const store::MapInfo& m, std::int64_t version) {
  auto index = std::make_shared<const VersionIndex>(m.tile_size, db().list_tiles(m.name, version));
  version_indexes.put(m.name, version, index);
  return index;
}

ApiResponse Api::Impl::roi(const ApiRequest& req, const std::string& name, const Target& t) {
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

ApiResponse Api::Impl::by_hash(const ApiRequest& req, const std::string& hash, const std::string& route, const char* cache_control) {
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

ApiResponse Api::Impl::blob_response(const ApiRequest& req, const std::string& hash, const std::string& route) {
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

ApiResponse Api::Impl::get_tile(const ApiRequest& req, const std::string& name, const std::string& vs, const std::string& txs, const std::string& tys) {
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

ApiResponse Api::Impl::list_tiles(const ApiRequest& req, const std::string& name, const std::string& vs) {
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
ApiResponse Api::Impl::get_places(const ApiRequest& req, const std::string& name, const std::string& vs) {
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
ApiResponse Api::Impl::get_manifest(const ApiRequest& req, const std::string& name, const std::string& vs) {
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

}  // namespace pl::server
