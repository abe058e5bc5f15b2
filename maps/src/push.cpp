#include "pl/maps/push.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <optional>
#include <thread>
#include <nlohmann/json.hpp>

#include "pl/schema/http_client.hpp"
#include "pl/common/error.hpp"
#include "pl/common/progress.hpp"
#include "pl/schema/signed_manifest.hpp"
#include "pl/schema/store.hpp"

using nlohmann::json;

namespace pl::maps {

namespace {

json expect(const api::HttpResponse& r, std::initializer_list<int> ok, const std::string& what) {
  for (int s : ok)
    if (r.status == s) return r.body.empty() ? json() : json::parse(r.body, nullptr, false);
  std::string why = r.body;
  json j = json::parse(r.body, nullptr, false);
  if (!j.is_discarded() && j.contains("error")) why = j["error"].get<std::string>();
  throw Error(what + ": the server answered " + std::to_string(r.status) + ": " + why);
}

}  // namespace

PushReport push_version(const PushOptions& o) {
  auto store = store::Store::open(o.db, false);
  auto map = store.find_map(o.map);
  const std::string source_name = store::display_name(o.db);  // a database URL's password never in a message
  if (!map) throw Error(source_name + ": no map named \"" + o.map + "\"");
  auto version = store.find_version(o.map, o.version);
  if (!version) throw Error(source_name + ": map " + o.map + " has no version " + std::to_string(o.version));
  auto tiles = store.list_tiles(o.map, o.version);
  std::optional<signing::SigningKey> key;
  if (!o.signing_key.empty()) key = signing::SigningKey::load(o.signing_key);  // before anything is sent

  api::HttpOptions http_options;
  http_options.timeout_s = 60.0;
  http_options.ca_file = o.ca_file;
  http_options.insecure_http = o.insecure_http;
  api::HttpClient http(o.server, http_options);
  // The server limits each token's uploads a second (429 with Retry-After): wait as it says and
  // send again, a bounded number of times.
  auto send = [&](const std::string& method, const std::string& target, const std::string& body,
                  const std::map<std::string, std::string>& headers) {
    for (int attempt = 0;; ++attempt) {
      api::HttpResponse r = http.request(method, target, body, headers);
      if (r.status != 429 || attempt == 50) return r;
      double after = 1;
      try {
        after = std::stod(r.header("retry-after"));
      } catch (const std::exception&) {
      }
      std::this_thread::sleep_for(std::chrono::duration<double>(std::clamp(after, 0.05, 60.0)));
    }
  };
  std::map<std::string, std::string> auth = {{"Authorization", "Bearer " + o.token}};
  const std::string base = "/v1/maps/" + api::url_encode(o.map);
  auto manifest = http.get(base, auth);
  if (manifest.status == 404) {
    json create = {{"name", o.map},
                   {"origin", {{"lat", map->origin.lat_deg}, {"lon", map->origin.lon_deg}, {"alt", map->origin.alt_m}}},
                   {"tile_size", map->tile_size},
                   {"voxel_size", map->voxel_size}};
    expect(send("POST", "/v1/maps", create.dump(), auth), {201}, "creating map " + o.map + " on " + o.server);
    manifest = http.get(base, auth);
  }
  json m = expect(manifest, {200}, "reading map " + o.map + " on " + o.server);
  if (std::abs(m["tile_size"].get<double>() - map->tile_size) > 1e-9 || std::abs(m["voxel_size"].get<double>() - map->voxel_size) > 1e-9 ||
      std::abs(m["origin"]["lat"].get<double>() - map->origin.lat_deg) > 1e-9 ||
      std::abs(m["origin"]["lon"].get<double>() - map->origin.lon_deg) > 1e-9)
    throw Error("map " + o.map + " on " + o.server + " has another origin, tile size or voxel size than the local one: not pushing");

  json note = {{"note", "pushed from " + source_name + " v" + std::to_string(o.version)}};
  json opened = expect(send("POST", base + "/versions", note.dump(), auth), {201}, "opening a version of " + o.map);
  PushReport r;
  r.remote_version = opened["version"].get<std::int64_t>();
  const std::string vbase = base + "/versions/" + std::to_string(r.remote_version);
  json remote = expect(http.get(vbase + "/tiles", auth), {200}, "listing the tiles of the new version");
  std::map<TileKey, std::string> have;
  for (const auto& t : remote["tiles"]) have[{t["tx"].get<int>(), t["ty"].get<int>()}] = t["hash"].get<std::string>();

  Progress bar("pushing tiles", tiles.size());
  std::map<TileKey, bool> local;
  for (const auto& t : tiles) {
    local[t.key] = true;
    ++r.tiles;
    auto it = have.find(t.key);
    if (it != have.end() && it->second == t.hash) {
      ++r.skipped;
    } else {
      auto bytes = store.blob(t.hash);
      if (!bytes) throw Error(source_name + ": the bytes of tile " + std::to_string(t.key.tx) + "/" + std::to_string(t.key.ty) + " are missing");
      expect(send("PUT", vbase + "/tiles/" + std::to_string(t.key.tx) + "/" + std::to_string(t.key.ty), *bytes, auth), {200},
             "uploading tile " + std::to_string(t.key.tx) + "/" + std::to_string(t.key.ty));
      ++r.uploaded;
      r.bytes += bytes->size();
    }
    bar.update(r.tiles);
  }
  bar.finish();
  for (const auto& [key, hash] : have)
    if (!local.count(key)) {
      // 404: gone already (a proxy may repeat a DELETE whose answer it lost).
      expect(send("DELETE", vbase + "/tiles/" + std::to_string(key.tx) + "/" + std::to_string(key.ty), "", auth), {200, 404},
             "deleting tile " + std::to_string(key.tx) + "/" + std::to_string(key.ty));
      ++r.deleted;
    }
  // The places go with the tiles: the new version started with a copy of the server's current ones.
  if (const auto places = store.places(o.map, o.version)) {
    expect(send("PUT", vbase + "/places", *places, auth), {200}, "uploading the places");
    r.places = true;
  } else {
    expect(send("DELETE", vbase + "/places", "", auth), {200, 404}, "removing the places the local version lacks");
  }
  std::string publish_body;
  if (key) {
    // Sign what the local version is, once the server is seen to hold exactly that.
    signing::Manifest mine = signing::manifest_of(store, o.map, o.version);
    mine.version = r.remote_version;
    mine.parent = opened["parent"].is_number_integer() ? std::optional<std::int64_t>(opened["parent"].get<std::int64_t>()) : std::nullopt;
    const std::string text = signing::manifest_text(mine);
    const auto theirs = http.get(vbase + "/manifest", auth);
    expect(theirs, {200}, "reading the manifest of version " + std::to_string(r.remote_version) + " to sign it");
    if (theirs.body != text) {
      std::size_t line = 1;
      for (std::size_t i = 0; i < std::min(text.size(), theirs.body.size()) && text[i] == theirs.body[i]; ++i) line += text[i] == '\n';
      throw Error("the server's version " + std::to_string(r.remote_version) + " of map " + o.map + " is not the local version " +
                  std::to_string(o.version) + " (their manifests differ from line " + std::to_string(line) +
                  "): not signing it, nothing published. Was it written to meanwhile? Run pl-map push again");
    }
    publish_body = json{{"public_key", signing::encode_base64(key->public_key())}, {"signature", signing::encode_base64(key->sign(text))}}.dump();
  }
  expect(send("POST", vbase + "/publish", publish_body, auth), {200}, "publishing version " + std::to_string(r.remote_version));
  return r;
}

}  // namespace pl::maps
