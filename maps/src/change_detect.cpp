// Change candidates from many drives' change reports: the rule is in the header.
#include "pl/maps/change_detect.hpp"

#include <algorithm>
#include <cstdio>
#include <map>
#include <set>
#include <tuple>
#include <unordered_map>

#include "pl/common/error.hpp"

namespace pl::maps {

namespace {

using schema::ChangeCell;
using schema::ChangeReport;

std::uint64_t key_of(std::int64_t x, std::int64_t y, std::int64_t z) {
  constexpr std::int64_t k = 1 << 20;  // 21 bits a coordinate: a tile's voxels are far inside
  return static_cast<std::uint64_t>((x + k) & 0x1FFFFF) << 42 | static_cast<std::uint64_t>((y + k) & 0x1FFFFF) << 21 |
         static_cast<std::uint64_t>((z + k) & 0x1FFFFF);
}

struct PassCells {
  const ChangeReport* report;
  const schema::TileChangeEvidence* tile;
  std::vector<const ChangeCell*> added, removed;
};

}  // namespace

void ChangeRule::validate() const {
  auto need = [](bool ok, const char* what) {
    if (!ok) throw Error(std::string("change rule: ") + what);
  };
  need(min_drives >= 1, "min_drives must be 1 or more");
  need(window >= min_drives, "window must be at least min_drives (the passes judged hold the ones that must agree)");
  need(independent_s >= 0, "independent_s must be 0 or more seconds");
  need(added_min >= 1 && removed_min >= 1, "added_min and removed_min must be 1 or more");
  need(added_free_ratio >= 0 && removed_seen_ratio >= 0, "the ratios must be 0 or more");
  need(added_stays >= added_min, "added_stays must be at least added_min");
  need(tolerance_voxels >= 0 && tolerance_voxels <= 3, "tolerance_voxels must be within 0..3");
  need(min_cells >= 1, "min_cells must be 1 or more");
}

ChangeSummary detect_changes(const std::vector<ChangeReport>& reports, std::int64_t version, const ChangeRule& rule) {
  rule.validate();
  ChangeSummary out;
  out.version = version;
  out.reports = reports.size();
  // The reports against this version, one per independent drive: of one vehicle's drives starting
  // within independent_s of each other, the latest.
  std::vector<const ChangeReport*> chosen;
  for (const ChangeReport& r : reports)
    if (r.version == version) chosen.push_back(&r);
  std::sort(chosen.begin(), chosen.end(), [](const ChangeReport* a, const ChangeReport* b) {
    return std::tie(a->vehicle, a->start, a->drive) < std::tie(b->vehicle, b->start, b->drive);
  });
  std::vector<const ChangeReport*> passes;
  for (std::size_t i = 0; i < chosen.size(); ++i) {
    const bool superseded = i + 1 < chosen.size() && chosen[i + 1]->vehicle == chosen[i]->vehicle &&
                            chosen[i + 1]->start - chosen[i]->start < rule.independent_s;
    if (!superseded) passes.push_back(chosen[i]);
  }
  std::sort(passes.begin(), passes.end(), [](const ChangeReport* a, const ChangeReport* b) {
    return std::tie(a->start, a->vehicle, a->drive) < std::tie(b->start, b->vehicle, b->drive);
  });
  out.used = passes.size();
  if (passes.empty()) return out;
  const ChangeReport& first = *passes.front();
  out.voxel_m = first.voxel_m;
  out.tile_m = first.tile_m;
  for (const ChangeReport* p : passes)
    if (p->map != first.map || p->voxel_m != first.voxel_m || p->tile_m != first.tile_m)
      throw Error("change reports of map " + first.map + " v" + std::to_string(version) + " disagree: drive " + p->drive +
                  " has map " + p->map + ", voxel " + std::to_string(p->voxel_m) + " m, tile " + std::to_string(p->tile_m) +
                  " m (aggregate reports of one map and one evidence grid)");

  // Per tile, its passes in time order with each pass's changed voxels.
  std::map<TileKey, std::vector<PassCells>> by_tile;
  for (const ChangeReport* p : passes)
    for (const schema::TileChangeEvidence& t : p->tiles) {
      if (t.scans < rule.min_scans) continue;
      PassCells pc{p, &t, {}, {}};
      for (const ChangeCell& c : t.cells) {
        if (c.added >= rule.added_min && (c.added >= rule.added_free_ratio * c.free || c.added >= rule.added_stays))
          pc.added.push_back(&c);
        if (c.passed >= rule.removed_min && c.passed >= rule.removed_seen_ratio * c.seen) pc.removed.push_back(&c);
      }
      by_tile[t.key].push_back(std::move(pc));
    }

  const int tol = rule.tolerance_voxels;
  for (auto& [key, all] : by_tile) {
    const std::size_t from = all.size() > static_cast<std::size_t>(rule.window) ? all.size() - static_cast<std::size_t>(rule.window) : 0;
    const std::vector<PassCells> judged(all.begin() + static_cast<std::ptrdiff_t>(from), all.end());
    // Votes: per voxel, the passes that found it changed or a voxel within the tolerance.
    std::unordered_map<std::uint64_t, int> votes;
    for (const PassCells& pc : judged) {
      std::set<std::uint64_t> near;
      for (const auto* list : {&pc.added, &pc.removed})
        for (const ChangeCell* c : *list)
          for (int dx = -tol; dx <= tol; ++dx)
            for (int dy = -tol; dy <= tol; ++dy)
              for (int dz = -tol; dz <= tol; ++dz) near.insert(key_of(c->x + dx, c->y + dy, c->z + dz));
      for (std::uint64_t k : near) ++votes[k];
    }
    auto agreed = [&](const ChangeCell* c) { return votes[key_of(c->x, c->y, c->z)] >= rule.min_drives; };
    TileChange tc;
    tc.key = key;
    std::map<std::tuple<std::int32_t, std::int32_t, std::int32_t>, ChangeCell> added, removed;
    for (const PassCells& pc : judged) {
      tc.passes.push_back({pc.report->vehicle, pc.report->drive, pc.report->start});
      std::size_t n = 0;
      std::set<std::tuple<std::int32_t, std::int32_t, std::int32_t>> agreed_added;
      for (const ChangeCell* c : pc.added)
        if (agreed(c)) {
          ++n;
          agreed_added.insert({c->x, c->y, c->z});
          ChangeCell& s = added.try_emplace({c->x, c->y, c->z}, ChangeCell{c->x, c->y, c->z, 0, 0, 0, 0}).first->second;
          s.added += c->added, s.free += c->free, s.seen += c->seen, s.passed += c->passed;
        }
      for (const ChangeCell* c : pc.removed)
        if (agreed(c)) {
          ++n;
          ChangeCell& s = removed.try_emplace({c->x, c->y, c->z}, ChangeCell{c->x, c->y, c->z, 0, 0, 0, 0}).first->second;
          s.added += c->added, s.free += c->free, s.seen += c->seen, s.passed += c->passed;
        }
      tc.agreed = std::max(tc.agreed, n);
      for (const auto& q : pc.tile->points) {  // the new structure: this pass's sample of its agreed voxels
        const auto v = schema::voxel_of_cm(q, out.voxel_m);
        if (agreed_added.count({v[0], v[1], v[2]})) tc.points.push_back(q);
      }
    }
    std::sort(tc.points.begin(), tc.points.end());
    tc.points.erase(std::unique(tc.points.begin(), tc.points.end()), tc.points.end());
    tc.candidate = tc.agreed >= rule.min_cells && static_cast<int>(judged.size()) >= rule.min_drives;
    for (auto& [k, c] : added) tc.added.push_back(c);
    for (auto& [k, c] : removed) tc.removed.push_back(c);
    out.tiles.push_back(std::move(tc));
  }
  return out;
}

std::string change_summary_csv(const ChangeSummary& s) {
  std::string out = "tx,ty,passes,agreed,added,removed,candidate,drives\n";
  char buf[160];
  for (const TileChange& t : s.tiles) {
    std::snprintf(buf, sizeof buf, "%d,%d,%zu,%zu,%zu,%zu,%d,", t.key.tx, t.key.ty, t.passes.size(), t.agreed, t.added.size(),
                  t.removed.size(), t.candidate ? 1 : 0);
    out += buf;
    for (std::size_t i = 0; i < t.passes.size(); ++i) out += (i ? " " : "") + t.passes[i].vehicle + "/" + t.passes[i].drive;
    out += "\n";
  }
  return out;
}

}  // namespace pl::maps
