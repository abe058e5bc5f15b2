#include "wire.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>

#include "pl/common/text.hpp"
#include "pl/schema/http_client.hpp"
#include "pl/schema/store.hpp"

namespace pl::client::wire {

using nlohmann::json;

namespace {

[[noreturn]] void bad(const std::string& what) { throw WireError(what); }

const json& field(const json& j, const char* key, const char* where) {
  if (!j.is_object()) bad(std::string(where) + " is not a JSON object");
  auto it = j.find(key);
  if (it == j.end()) bad(std::string(where) + " has no \"" + key + "\"");
  return *it;
}

// An integer field in [lo, hi]: JSON numbers that are whole (1, 1.0 is refused: the API writes
// integers), so that no cast of an out-of-range double ever happens.
long long integer(const json& v, const char* key, long long lo, long long hi) {
  long long out = 0;
  if (v.is_number_unsigned()) {
    const auto u = v.get<unsigned long long>();
    if (u > static_cast<unsigned long long>(std::numeric_limits<long long>::max())) bad(std::string("\"") + key + "\" is out of range");
    out = static_cast<long long>(u);
  } else if (v.is_number_integer()) {
    out = v.get<long long>();
  } else {
    bad(std::string("\"") + key + "\" must be a whole number, got " + v.type_name());
  }
  if (out < lo || out > hi) bad(std::string("\"") + key + "\" = " + std::to_string(out) + " is out of range");
  return out;
}

double number(const json& v, const char* key) {
  if (!v.is_number()) bad(std::string("\"") + key + "\" must be a number, got " + v.type_name());
  const double d = v.get<double>();
  if (!std::isfinite(d)) bad(std::string("\"") + key + "\" is not finite");
  return d;
}

json parse(std::string_view body, const char* what) {
  json j = json::parse(body.begin(), body.end(), nullptr, false);
  if (j.is_discarded()) bad(std::string(what) + " is not JSON");
  if (!j.is_object()) bad(std::string(what) + " is not a JSON object");
  return j;
}

}  // namespace

std::string signed_manifest_target(const std::string& map, long long version, int refusals) {
  std::string target = "/v1/maps/" + api::url_encode(map) + "/versions/" + std::to_string(version) + "/manifest";
  if (refusals > 0) target += "?refused=" + std::to_string(refusals);
  return target;
}

std::string current_target(const std::string& map, int refusals) {
  std::string target = "/v1/maps/" + api::url_encode(map) + "/current";
  if (refusals > 0) target += "?refused=" + std::to_string(refusals);
  return target;
}

signing::CurrentVersion verified_current(std::string_view body, const std::vector<std::string>& trusted, const std::string& map,
                                         std::int64_t now) {
  try {
    const signing::SignedCurrent c = signing::verify_signed_current(body, trusted);
    signing::check_current(c.current, map, now, kClockSkewS);
    return c.current;
  } catch (const signing::ManifestError& e) {
    bad(e.what());
  }
}

CachedManifest parse_manifest(std::string_view body, const std::string& map, std::optional<long long> pin) {
  const json j = parse(body, "the manifest");
  CachedManifest m;
  m.map = map;
  m.tile_size = number(field(j, "tile_size", "the manifest"), "tile_size");
  if (!valid_tile_size(m.tile_size))
    bad("the manifest's tile_size " + json(m.tile_size).dump() + " is not between 1 and 1000 m (the sizes maps are made with)");
  if (auto it = j.find("voxel_size"); it != j.end() && !it->is_null()) m.voxel_size = number(*it, "voxel_size");
  const json& o = field(j, "origin", "the manifest");
  m.origin = GeoPoint{number(field(o, "lat", "the manifest's origin"), "lat"), number(field(o, "lon", "the manifest's origin"), "lon"),
                      0.0};
  if (auto it = o.find("alt"); it != o.end() && !it->is_null()) m.origin.alt_m = number(*it, "alt");
  if (std::abs(m.origin.lat_deg) > 90 || std::abs(m.origin.lon_deg) > 180) bad("the manifest's origin is not a latitude and longitude");
  if (pin) {
    m.version = *pin;
  } else {
    const json& current = field(j, "current_version", "the manifest");
    if (current.is_null())
      bad("the map has no published version yet: publish one (pl-map publish) or set TileClientConfig::version");
    m.version = integer(current, "current_version", 1, std::numeric_limits<long long>::max());
  }
  return m;
}

std::optional<MapExtent> parse_manifest_extent(std::string_view body, long long version) {
  const json j = json::parse(body.begin(), body.end(), nullptr, false);
  if (!j.is_object()) return std::nullopt;
  const auto current = j.find("current_version"), bounds = j.find("bounds");
  if (current == j.end() || !current->is_number_integer() || current->get<long long>() != version || bounds == j.end() ||
      !bounds->is_object())
    return std::nullopt;
  const auto lo = bounds->find("min"), hi = bounds->find("max");
  if (lo == bounds->end() || hi == bounds->end() || !lo->is_array() || !hi->is_array() || lo->size() < 2 || hi->size() < 2)
    return std::nullopt;
  double v[4];
  const json* at[4] = {&(*lo)[0], &(*lo)[1], &(*hi)[0], &(*hi)[1]};
  for (int i = 0; i < 4; ++i) {
    if (!at[i]->is_number()) return std::nullopt;
    v[i] = at[i]->get<double>();
    if (!std::isfinite(v[i])) return std::nullopt;
  }
  if (!(v[0] <= v[2] && v[1] <= v[3])) return std::nullopt;
  return MapExtent{v[0], v[1], v[2], v[3]};
}

std::vector<std::string> parse_map_names(std::string_view body) {
  const json j = parse(body, "the list of maps");
  const json& maps = field(j, "maps", "the list of maps");
  if (!maps.is_array()) bad("the list of maps: \"maps\" is not an array");
  std::vector<std::string> names;
  for (const json& m : maps) {
    if (!m.is_object()) bad("the list of maps: an entry is not an object");
    const json& name = field(m, "name", "the list of maps");
    if (!name.is_string() || !valid_map_name(name.get<std::string>())) bad("the list of maps: an entry's name is not a map name");
    names.push_back(name.get<std::string>());
  }
  return names;
}

signing::SignedManifest verified_manifest(std::string_view body, const std::vector<std::string>& trusted, const std::string& map,
                                          long long version) {
  signing::SignedManifest out;
  try {
    out = signing::verify_signed_manifest(body, trusted);
  } catch (const signing::ManifestError& e) {
    bad(e.what());
  }
  if (out.manifest.map != map || out.manifest.version != version)
    bad("the signed manifest is that of map " + out.manifest.map + " version " + std::to_string(out.manifest.version) + ", not of map " +
        map + " version " + std::to_string(version) + " (replayed from elsewhere?)");
  if (!valid_tile_size(out.manifest.tile_size))
    bad("the signed manifest's tile size " + json(out.manifest.tile_size).dump() + " m is not between 1 and 1000 m");
  return out;
}

std::vector<CachedTile> parse_roi(std::string_view body, long long version, double tile_size) {
  const json j = parse(body, "the ROI answer");
  const long long answered = integer(field(j, "version", "the ROI answer"), "version", 1, std::numeric_limits<long long>::max());
  if (answered != version) bad("the server answered for version " + std::to_string(answered));
  const double size = number(field(j, "tile_size", "the ROI answer"), "tile_size");
  if (size != tile_size)
    bad("the server's tile size is " + field(j, "tile_size", "").dump() + " m, the pinned version's " + json(tile_size).dump() +
        " m (was the map store rebuilt? delete the disk cache)");
  const json& tiles = field(j, "tiles", "the ROI answer");
  if (!tiles.is_array()) bad("the ROI answer's \"tiles\" is not a list");
  std::vector<CachedTile> rows;
  rows.reserve(tiles.size());
  for (const json& t : tiles) {
    CachedTile c;
    c.key = TileKey{static_cast<std::int32_t>(integer(field(t, "tx", "a tile of the ROI answer"), "tx", INT32_MIN, INT32_MAX)),
                    static_cast<std::int32_t>(integer(field(t, "ty", "a tile of the ROI answer"), "ty", INT32_MIN, INT32_MAX))};
    const json& h = field(t, "hash", "a tile of the ROI answer");
    if (!h.is_string() || !is_hash(h.get_ref<const std::string&>()))
      bad("tile " + std::to_string(c.key.tx) + "/" + std::to_string(c.key.ty) + " has no valid hash");
    c.hash = h.get<std::string>();
    if (auto it = t.find("points"); it != t.end()) c.points = integer(*it, "points", 0, std::numeric_limits<std::int32_t>::max());
    rows.push_back(std::move(c));
  }
  return rows;
}

std::string error_text(std::string_view body) {
  json j = json::parse(body.begin(), body.end(), nullptr, false);
  if (j.is_object()) {
    auto it = j.find("error");
    if (it != j.end() && it->is_string()) return valid_utf8(it->get<std::string>().substr(0, 500));
  }
  return valid_utf8(body.substr(0, 200));
}

TileCloud verified_tile(std::string_view bytes, const std::string& hash) {
  const std::string got = store::content_hash(bytes);
  if (got != hash)
    bad("the server sent " + std::to_string(bytes.size()) + " bytes whose SHA-256 is " + got +
        " (a proxy altering responses, or a damaged store?)");
  return decode_tile(bytes);
}

void check_places(std::string_view bytes, std::string_view etag) {
  if (bytes.empty()) bad("the server sent empty places (places are never empty)");
  if (bytes.size() > api::kMaxPlacesBytes)
    bad("the server sent " + std::to_string(bytes.size()) + " bytes of places, more than the " +
        std::to_string(api::kMaxPlacesBytes >> 20) + " MiB places may have");
  if (etag.rfind("W/", 0) == 0) etag.remove_prefix(2);
  if (etag.size() < 2 || etag.front() != '"' || etag.back() != '"') return;  // no ETag, or not one of a content hash
  const std::string_view named = etag.substr(1, etag.size() - 2);
  if (!is_hash(named)) return;
  const std::string got = store::content_hash(bytes);
  if (got != named)
    bad("the server sent " + std::to_string(bytes.size()) + " bytes of places whose SHA-256 is " + got + ", not " +
        std::string(named) + " as its ETag says (a proxy altering responses, or a damaged store?)");
}

}  // namespace pl::client::wire
