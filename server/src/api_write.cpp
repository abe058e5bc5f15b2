// The API's writes: uploads of tiles and places, deletes, new versions, publishing.
#include "api_impl.hpp"

namespace pl::server {

// The staged version a write goes to, and who writes (require_role's).
std::pair<store::VersionInfo, std::string> Api::Impl::need_staged(const ApiRequest& req, const std::string& name, const std::string& vs) {
  std::string by = require_role(req, store::Role::Upload);
  auto m = need_map(name);
  auto info = need_version(m, parse_version(vs), true);
  if (info.state != store::VersionState::Staged)
    fail(409, "map " + name + " version " + std::to_string(info.number) + " is " + store::state_name(info.state) +
                  ": open a new version with POST /v1/maps/" + name + "/versions");
  return {info, by};
}

ApiResponse Api::Impl::put_tile(const ApiRequest& req, const std::string& name, const std::string& vs, const std::string& txs, const std::string& tys) {
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

ApiResponse Api::Impl::put_places(const ApiRequest& req, const std::string& name, const std::string& vs) {
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
ApiResponse Api::Impl::delete_places(const ApiRequest& req, const std::string& name, const std::string& vs) {
  auto [info, by] = need_staged(req, name, vs);
  store::Store::Transaction tx(db());
  if (!db().delete_places(name, info.number)) fail(404, "map " + name + " version " + std::to_string(info.number) + " has no places");
  db().log_upload(name, info.number, "delete_places", "", by);
  tx.commit();
  return json_response(200, {{"deleted", true}}, "/v1/maps/{map}/versions/{v}/places");
}

ApiResponse Api::Impl::delete_tile(const ApiRequest& req, const std::string& name, const std::string& vs, const std::string& txs, const std::string& tys) {
  auto [info, by] = need_staged(req, name, vs);
  TileKey key{parse_tile_index(txs), parse_tile_index(tys)};
  store::Store::Transaction tx(db());
  if (!db().delete_tile(name, info.number, key)) fail(404, "version " + std::to_string(info.number) + " has no tile " + txs + "/" + tys);
  db().log_upload(name, info.number, "delete_tile", txs + "/" + tys, by);
  tx.commit();
  return json_response(200, {{"deleted", true}}, "/v1/maps/{map}/versions/{v}/tiles/{tx}/{ty}");
}

ApiResponse Api::Impl::create_version(const ApiRequest& req, const std::string& name) {
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
ApiResponse Api::Impl::publish(const ApiRequest& req, const std::string& name, const std::string& vs) {
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
void Api::Impl::publish_update(const std::string& name, std::int64_t number, const std::string& by) {
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

}  // namespace pl::server
