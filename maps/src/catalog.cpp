#include "pl/maps/catalog.hpp"

#include "pl/maps/map_update.hpp"

#include <algorithm>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <map>

#include "pl/common/error.hpp"
#include "pl/common/text.hpp"
#include "pl/maps/map_update.hpp"

namespace pl::maps {

namespace {


std::map<TileKey, std::string> tile_hashes(const store::Store& s, const std::string& map, std::int64_t version) {
  std::map<TileKey, std::string> out;
  for (const auto& t : s.list_tiles(map, version)) out[t.key] = t.hash;
  return out;
}

}  // namespace

std::string megabytes(double bytes) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.2f MB", bytes / 1e6);
  return buf;
}

store::MapInfo need_map(const store::Store& s, const std::string& name) {
  auto m = s.find_map(name);
  if (!m) throw Error(s.path() + ": no map named \"" + name + "\" (pl-map list --db " + s.path() + " shows the maps)");
  return *m;
}

namespace {

// Signs a staged version's manifest as the store holds it (inside the caller's transaction, just
// before it is published); returns the upload log's detail.
std::string sign_staged(store::Store& s, const std::string& map, std::int64_t version, const signing::SigningKey& key) {
  const std::string text = signing::manifest_text(signing::manifest_of(s, map, version));
  try {
    signing::sign_staged_version(s, map, version, key.public_key(), key.sign(text));
  } catch (const signing::SignatureMismatch&) {
    throw Error(s.path() + ": map " + map + " version " + std::to_string(version) +
                " changed while it was being signed (another writer at work): nothing published; publish it again");
  }
  return "signed by key " + signing::key_id(key.public_key());
}

}  // namespace

void publish_version(store::Store& s, const std::string& map, std::int64_t version, const signing::SigningKey* key) {
  store::Store::Transaction tx(s);
  const std::string detail = key ? sign_staged(s, map, version, *key) : std::string();
  s.publish(map, version);
  s.log_upload(map, version, "publish", detail, "pl-map");
  tx.commit();
}

std::int64_t rollback_version(store::Store& s, const std::string& map, const signing::SigningKey* key) {
  store::Store::Transaction tx(s);
  // A fleet that checks signatures would refuse an unsigned rollback of a signed map and stay on
  // the version being rolled back: said before anything is written.
  const auto current = need_map(s, map).current;
  if (!key && current && s.signature(map, *current))
    throw Error(s.path() + ": map " + map + " version " + std::to_string(*current) +
                " is signed: vehicles with the fleet's keys would refuse an unsigned rollback; give --signing-key (the "
                "fleet's private key) to sign the new version");
  std::string detail;
  const std::int64_t v = s.rollback(map, [&](std::int64_t staged) {
    if (key) detail = sign_staged(s, map, staged, *key);
  });
  const auto restored = s.find_version(map, v)->parent.value();  // the rollback opened it from there
  s.log_upload(map, v, "rollback", "the content of v" + std::to_string(restored) + (detail.empty() ? "" : ", " + detail), "pl-map");
  tx.commit();
  return v;
}

std::string maps_text(const store::Store& s) {
  std::string out;
  const auto maps = s.list_maps();
  if (maps.empty()) append_format(out, "no maps in %s\n", s.path().c_str());
  for (const auto& m : maps)
    append_format(out, "%-24s current %s, tile %.1f m, voxel %.2f m, origin %.7f %.7f %.2f\n", m.name.c_str(),
           m.current ? ("v" + std::to_string(*m.current)).c_str() : "none", m.tile_size, m.voxel_size, m.origin.lat_deg,
           m.origin.lon_deg, m.origin.alt_m);
  return out;
}

std::string versions_text(const store::Store& s, const std::string& map) {
  const auto m = need_map(s, map);
  std::string out;
  append_format(out, "map %s (tile %.1f m, voxel %.2f m)\n", m.name.c_str(), m.tile_size, m.voxel_size);
  for (const auto& v : s.list_versions(map))
    append_format(out, "  %s v%-4lld %-9s %6lld tiles %10lld points %10s  %s%s%s\n", m.current && *m.current == v.number ? "*" : " ",
           static_cast<long long>(v.number), store::state_name(v.state), static_cast<long long>(v.tiles),
           static_cast<long long>(v.points), megabytes(static_cast<double>(v.bytes)).c_str(), v.created.c_str(),
           v.note.empty() ? "" : "  ", v.note.c_str());
  return out;
}

std::string version_text(const store::Store& s, const std::string& map, std::int64_t version) {
  const auto m = need_map(s, map);
  if (version == 0) {
    if (!m.current) throw Error("map " + map + " has no published version yet: give --version N");
    version = *m.current;
  }
  const auto v = s.find_version(map, version);
  if (!v) throw Error("map " + map + " has no version " + std::to_string(version));
  const auto tiles = s.list_tiles(map, version);
  double lo_x = INFINITY, lo_y = INFINITY, hi_x = -INFINITY, hi_y = -INFINITY;
  for (const auto& t : tiles)
    lo_x = std::min(lo_x, t.min_x), lo_y = std::min(lo_y, t.min_y), hi_x = std::max(hi_x, t.max_x), hi_y = std::max(hi_y, t.max_y);
  const double area_km2 = static_cast<double>(tiles.size()) * m.tile_size * m.tile_size / 1e6;
  const auto number = static_cast<long long>(version);
  std::string out;
  append_format(out, "map          %s\n", m.name.c_str());
  append_format(out, "version      %lld (%s)%s, created %s\n", number, store::state_name(v->state),
         m.current && *m.current == version ? ", current" : "", v->created.c_str());
  append_format(out, "origin       lat %.9f, lon %.9f, alt %.3f m\n", m.origin.lat_deg, m.origin.lon_deg, m.origin.alt_m);
  append_format(out, "grid         %.1f m tiles, %.2f m voxels\n", m.tile_size, m.voxel_size);
  append_format(out, "tiles        %zu covering %.4f km2, %lld points, %s (%.1f MB per km2 of tiles)\n", tiles.size(), area_km2,
         static_cast<long long>(v->points), megabytes(static_cast<double>(v->bytes)).c_str(),
         area_km2 > 0 ? static_cast<double>(v->bytes) / 1e6 / area_km2 : 0.0);
  if (!tiles.empty()) append_format(out, "bounds       x %.1f .. %.1f, y %.1f .. %.1f m\n", lo_x, hi_x, lo_y, hi_y);
  if (const auto sig = s.signature(map, version)) {
    const bool good = signing::verify(sig->public_key, signing::manifest_text(signing::manifest_of(s, map, version)), sig->signature);
    append_format(out, "signature    Ed25519 key %s, %s: %s\n", signing::key_id(sig->public_key).c_str(), sig->signed_at.c_str(),
                  good ? "verifies" : "DOES NOT VERIFY against the manifest (the store was altered after signing)");
  } else {
    append_format(out, "signature    none (vehicles with a fleet key will not use this version)\n");
  }
  return out;
}

VersionDiff diff_versions(const store::Store& s, const std::string& map, std::int64_t from, std::int64_t to) {
  need_map(s, map);
  for (std::int64_t v : {from, to})
    if (!s.find_version(map, v)) throw Error("map " + map + " has no version " + std::to_string(v));
  const auto a = tile_hashes(s, map, from), b = tile_hashes(s, map, to);
  VersionDiff d;
  // Why a tile changed, where an update (pl-map update) said so: the reasons logged by the versions
  // from `from` (exclusive) to `to`, the latest word on a tile kept.
  std::map<TileKey, std::string> why;
  for (std::int64_t v = std::min(from, to) + 1; v <= std::max(from, to); ++v)
    for (auto& [k, reason] : update_reasons(s, map, v)) why[k] = "v" + std::to_string(v) + " update: " + reason;
  auto because = [&](const TileKey& k) {
    const auto it = why.find(k);
    return it == why.end() ? std::string() : "  (" + it->second + ")";
  };
  for (const auto& [k, h] : b) {
    const auto it = a.find(k);
    if (it == a.end()) {
      ++d.added;
      append_format(d.text, "+ %d %d%s\n", k.tx, k.ty, because(k).c_str());
    } else if (it->second != h) {
      ++d.changed;
      append_format(d.text, "~ %d %d%s\n", k.tx, k.ty, because(k).c_str());
    } else {
      ++d.unchanged;
    }
  }
  for (const auto& [k, h] : a)
    if (!b.count(k)) {
      ++d.removed;
      append_format(d.text, "- %d %d%s\n", k.tx, k.ty, because(k).c_str());
    }
  append_format(d.text, "v%lld -> v%lld: %zu added, %zu removed, %zu changed, %zu unchanged\n", static_cast<long long>(from),
         static_cast<long long>(to), d.added, d.removed, d.changed, d.unchanged);
  return d;
}

}  // namespace pl::maps
