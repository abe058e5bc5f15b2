// Map updates from change reports (see the header).
#include "pl/maps/map_update.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <set>
#include <sstream>
#include <tuple>
#include <unordered_set>

#include "pl/common/error.hpp"
#include "pl/common/voxel.hpp"
#include "pl/maps/catalog.hpp"
#include "pl/registration/normals.hpp"

namespace pl::maps {

namespace {

using Voxel = std::tuple<std::int32_t, std::int32_t, std::int32_t>;

Voxel voxel_of(const Eigen::Vector3d& p, double v) {
  return {static_cast<std::int32_t>(std::floor(p.x() / v)), static_cast<std::int32_t>(std::floor(p.y() / v)),
          static_cast<std::int32_t>(std::floor(p.z() / v))};
}

constexpr const char* kAction = "update";

}  // namespace

void MapUpdateConfig::validate() const {
  rule.validate();
  if (!(normal_radius_m >= 0) || !std::isfinite(normal_radius_m))
    throw Error("map update: normal_radius_m must be 0 (3 x the map's voxel) or more metres");
  if (!(codec.max_error_m > 0)) throw Error("map update: the codec's max_error_m must be positive");
}

std::string TileUpdate::reason() const {
  std::string out = "-" + std::to_string(removed) + " points in " + std::to_string(removed_voxels) + " voxels passed through, +" +
                    std::to_string(added) + " points in " + std::to_string(added_voxels) + " voxels added";
  out += deleted ? "; nothing left, tile removed" : "";
  out += "; " + std::to_string(passes.size()) + " passes:";
  for (const Pass& p : passes) out += " " + p.vehicle + "/" + p.drive;
  return out;
}

MapUpdateResult update_map(store::Store& s, const std::string& map, const std::vector<schema::ChangeReport>& reports,
                           const MapUpdateConfig& cfg) {
  cfg.validate();
  const store::MapInfo info = need_map(s, map);
  if (!info.current)
    throw Error("map " + map + " has no published version to update (publish one with pl-map publish first)");
  MapUpdateResult r;
  r.parent = *info.current;
  r.summary = detect_changes(reports, r.parent, cfg.rule);
  if (r.summary.used > 0 && std::abs(r.summary.tile_m - info.tile_size) > 1e-9)
    throw Error("the change reports of map " + map + " use " + std::to_string(r.summary.tile_m) + " m tiles, the map " +
                std::to_string(info.tile_size) + " m: they were made against another map of that name");
  std::vector<const TileChange*> candidates;
  for (const TileChange& t : r.summary.tiles)
    if (t.candidate) candidates.push_back(&t);
  if (candidates.empty()) return r;

  const TileGrid grid(info.tile_size);
  const double ev = r.summary.voxel_m;
  const double radius = cfg.normal_radius_m > 0 ? cfg.normal_radius_m : registration::map_normal_radius(info.voxel_size);
  // The parent's tiles, each read and decoded once (neighbouring candidates share neighbours).
  std::map<TileKey, TileCloud> decoded;
  auto load = [&](const TileKey& key) -> const TileCloud& {
    auto [it, fresh] = decoded.try_emplace(key);
    if (!fresh) return it->second;
    const auto rec = s.find_tile(map, r.parent, key);
    if (!rec) return it->second;
    const auto bytes = s.blob(rec->hash);
    if (!bytes) throw Error("map " + map + " v" + std::to_string(r.parent) + ": tile " + std::to_string(key.tx) + " " +
                            std::to_string(key.ty) + " has no stored bytes (check the store with pl-map check)");
    it->second = decode_tile(*bytes);
    return it->second;
  };

  // Each candidate rebuilt, before the store is written.
  struct Rebuilt {
    TileUpdate u;
    TileCloud cloud;
  };
  std::vector<Rebuilt> rebuilt;
  for (const TileChange* c : candidates) {
    Rebuilt b;
    b.u.key = c->key;
    b.u.passes = c->passes;
    b.u.removed_voxels = c->removed.size();
    b.u.added_voxels = c->added.size();
    const TileCloud& old = load(c->key);
    b.u.before = old.size();
    std::set<Voxel> gone;
    for (const auto& v : c->removed) gone.insert({v.x, v.y, v.z});
    for (std::size_t i = 0; i < old.size(); ++i) {
      if (gone.count(voxel_of(old.points[i], ev))) continue;
      b.cloud.points.push_back(old.points[i]);
      if (!old.normals.empty()) b.cloud.normals.push_back(old.normals[i]);
      if (!old.intensity.empty()) b.cloud.intensity.push_back(old.intensity[i]);
    }
    b.u.removed = old.size() - b.cloud.size();
    // The added structure on the map's own voxel grid, in this tile, away from what the map keeps.
    Points3d added;
    for (const auto& q : c->points) {
      const Eigen::Vector3d p(q[0] / 100.0, q[1] / 100.0, q[2] / 100.0);
      if (grid.key_of(p.x(), p.y()) == c->key) added.push_back(p);
    }
    added = voxel_downsample(added, info.voxel_size);
    {
      const double inv = 1.0 / info.voxel_size;
      std::unordered_set<VoxelIndex, VoxelIndexHash> occupied;
      for (const auto& p : b.cloud.points) occupied.insert(voxel_index(p, inv));
      added.erase(std::remove_if(added.begin(), added.end(), [&](const Eigen::Vector3d& p) { return occupied.count(voxel_index(p, inv)) > 0; }),
                  added.end());
    }
    b.u.added = added.size();
    if (b.u.removed == 0 && b.u.added == 0) continue;  // nothing to change: the tile keeps its bytes
    if (!added.empty()) {
      // The added points take the attributes the parent's tile has.
      const bool with_normals = !old.normals.empty(), with_intensity = !old.intensity.empty();
      std::vector<Eigen::Vector3f> normals;  // of the added points
      if (with_normals) {
        // From everything round them: the tile as it will be and its neighbours.
        Points3d context = b.cloud.points;
        const std::size_t first_added = context.size();
        context.insert(context.end(), added.begin(), added.end());
        for (int dx = -1; dx <= 1; ++dx)
          for (int dy = -1; dy <= 1; ++dy) {
            if (dx == 0 && dy == 0) continue;
            const TileCloud& n = load({c->key.tx + dx, c->key.ty + dy});
            context.insert(context.end(), n.points.begin(), n.points.end());
          }
        const auto all = registration::estimate_normals(context, radius);
        normals.assign(all.begin() + static_cast<std::ptrdiff_t>(first_added), all.begin() + static_cast<std::ptrdiff_t>(first_added + added.size()));
      }
      // What the vehicles measured of the new structure is its shape, not its reflectivity: the
      // added points take the median intensity of the tile's kept points (0.5 with none).
      float fill = 0.5f;
      if (!b.cloud.intensity.empty()) {
        std::vector<float> v = b.cloud.intensity;
        std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
        fill = v[v.size() / 2];
      }
      for (std::size_t i = 0; i < added.size(); ++i) {
        b.cloud.points.push_back(added[i]);
        if (with_normals) b.cloud.normals.push_back(normals[i]);
        if (with_intensity) b.cloud.intensity.push_back(fill);
      }
    }
    b.u.after = b.cloud.size();
    b.u.deleted = b.cloud.points.empty();
    rebuilt.push_back(std::move(b));
  }
  r.unchanged = s.list_tiles(map, r.parent).size();
  if (rebuilt.empty()) return r;

  std::size_t used_reports = r.summary.used;
  const std::string note = !cfg.note.empty() ? cfg.note
                                             : "update of v" + std::to_string(r.parent) + " from " + std::to_string(used_reports) +
                                                   " change reports: " + std::to_string(rebuilt.size()) + " tiles rebuilt";
  store::Store::Transaction tx(s);
  r.version = s.create_version(map, r.parent, note);
  std::string detail = note + "\n";
  for (Rebuilt& b : rebuilt) {
    const TileKey& k = b.u.key;
    if (b.u.deleted) {
      s.delete_tile(map, r.version->number, k);
    } else {
      Eigen::Vector3d lo = b.cloud.points.front(), hi = lo;
      for (const auto& p : b.cloud.points) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
      s.put_tile(map, r.version->number, k, encode_tile(b.cloud, cfg.codec), static_cast<std::int64_t>(b.cloud.size()), lo.x(),
                 lo.y(), lo.z(), hi.x(), hi.y(), hi.z());
    }
    if (s.find_tile(map, r.parent, k)) --r.unchanged;
    detail += std::to_string(k.tx) + " " + std::to_string(k.ty) + ": " + b.u.reason() + "\n";
    r.tiles.push_back(std::move(b.u));
  }
  s.log_upload(map, r.version->number, kAction, detail, cfg.who);
  tx.commit();
  return r;
}

std::vector<schema::ChangeReport> stored_reports(const store::Store& s, const std::string& map, std::int64_t version) {
  std::vector<schema::ChangeReport> out;
  for (const auto& info : s.list_reports(map, version))
    if (auto body = s.report_body(map, info.id)) out.push_back(schema::parse_change_report(*body));
  return out;
}

std::vector<std::pair<TileKey, std::string>> update_reasons(const store::Store& s, const std::string& map, std::int64_t version) {
  std::vector<std::pair<TileKey, std::string>> out;
  for (const auto& e : s.upload_log(map)) {
    if (e.action != kAction || e.version != version) continue;
    std::istringstream lines(e.detail);
    std::string line;
    std::getline(lines, line);  // the note
    while (std::getline(lines, line)) {
      TileKey k;
      int used = 0;
      if (std::sscanf(line.c_str(), "%d %d: %n", &k.tx, &k.ty, &used) == 2 && used > 0) out.emplace_back(k, line.substr(static_cast<std::size_t>(used)));
    }
  }
  return out;
}

}  // namespace pl::maps
