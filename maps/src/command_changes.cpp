// pl-map changes and update: the tiles the fleet's change reports agree changed
// (change_detect.hpp), and a staged version with only those tiles rebuilt (map_update.hpp).
#include <algorithm>
#include <fstream>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "command.hpp"
#include "pl/common/error.hpp"
#include "pl/common/text.hpp"
#include "pl/maps/catalog.hpp"
#include "pl/maps/change_detect.hpp"
#include "pl/maps/map_update.hpp"
#include "pl/schema/change_report.hpp"
#include "pl/schema/signed_manifest.hpp"
#include "pl/schema/store.hpp"

namespace pl::maps {

namespace {

void rule_options(CLI::App& c, ChangeRule& rule) {
  cli::number(c, "--min-drives", rule.min_drives, "independent passes that must agree on a voxel", cli::between(1, 100));
  cli::number(c, "--window", rule.window, "... among a tile's last this many passes", cli::between(1, 1000));
  cli::number(c, "--min-cells", rule.min_cells, "agreed voxels for a tile to be a candidate", cli::at_least(1));
  cli::number(c, "--independent-s", rule.independent_s, "drives of one vehicle starting closer than this are one pass, s",
              cli::at_least(0));
}

}  // namespace

// Change candidates from change reports (pl-localize --change-report): which tiles independent
// drives agree changed (pl/maps/change_detect.hpp states the rule).
void add_changes(cli::Tool& tool, std::ostream& out) {
  struct Opts {
    std::vector<std::string> reports;
    long long version = 0;
    std::string out;
    ChangeRule rule;
  };
  auto o = std::make_shared<Opts>();
  CLI::App& c = tool.command("changes", "which tiles changed, from the change reports of several drives (pl-localize "
                             "--change-report): a tile is a candidate when independent drives agree (docs/map-updates.md)", [o, &out] {
    const std::vector<pl::schema::ChangeReport> reports = pl::schema::read_change_reports(o->reports);
    long long version = o->version;
    if (version == 0)
      for (const auto& r : reports) version = std::max<long long>(version, r.version);
    const ChangeSummary s = detect_changes(reports, version, o->rule);
    std::size_t candidates = 0;
    for (const auto& t : s.tiles) candidates += t.candidate;
    out << format_text("%zu reports, %zu independent passes against v%lld; %zu tiles seen, %zu change candidates "
          "(%d of the last %d passes agreeing on %zu voxels or more)\n",
          s.reports, s.used, version, s.tiles.size(), candidates, o->rule.min_drives, o->rule.window, o->rule.min_cells);
    if (!o->out.empty()) {
      std::ofstream f(o->out, std::ios::binary | std::ios::trunc);
      f << change_summary_csv(s);
      if (!f.flush()) throw pl::Error(o->out + ": write failed");
    }
    return 0;
  });
  c.add_option("--reports", o->reports, "change reports (JSON)")->required()->expected(1, -1)->type_name("FILE...")
      ->check(CLI::ExistingFile);
  cli::number(c, "--version", o->version, "the map version the reports were made against (default: the newest named)",
              cli::at_least(1))->default_str("");
  cli::output_file(c, "--out", o->out, "the tiles as CSV: tx,ty,passes,agreed,added,removed,candidate,drives");
  rule_options(c, o->rule);
}

// A staged version from the change reports: only the candidate tiles rebuilt (pl/maps/map_update.hpp).
void add_update(cli::Tool& tool, std::ostream& out) {
  struct Opts {
    std::string db, map, signing_key;
    std::vector<std::string> reports;
    bool publish = false;
    MapUpdateConfig cfg;
  };
  auto o = std::make_shared<Opts>();
  CLI::App& c = tool.command("update", "stage a new version of a map from its change reports: only the tiles independent drives "
                             "agree changed are rebuilt (old points minus the removed, plus the added), every other tile keeps its "
                             "bytes (docs/map-updates.md)", [o, &out] {
    std::optional<pl::signing::SigningKey> key;
    if (!o->signing_key.empty()) key = pl::signing::SigningKey::load(o->signing_key);  // before anything is written
    auto store = pl::store::Store::open(o->db, false);
    // The reports given, else those the store holds against the current version (sent by the
    // vehicles: POST /v1/maps/{map}/reports).
    std::vector<pl::schema::ChangeReport> reports = pl::schema::read_change_reports(o->reports);
    if (o->reports.empty()) {
      const auto m = need_map(store, o->map);
      if (m.current) reports = stored_reports(store, o->map, *m.current);
    }
    const MapUpdateResult r = update_map(store, o->map, reports, o->cfg);
    std::size_t candidates = 0;
    for (const auto& t : r.summary.tiles) candidates += t.candidate;
    out << format_text("%zu reports, %zu independent passes against v%lld; %zu change candidates\n", r.summary.reports, r.summary.used,
          static_cast<long long>(r.parent), candidates);
    if (!r.version) {
      out << format_text("nothing to update: no tile changed (v%lld stays current)\n", static_cast<long long>(r.parent));
      return 0;
    }
    for (const auto& t : r.tiles) out << format_text("~ %d %d: %s\n", t.key.tx, t.key.ty, t.reason().c_str());
    const auto number = static_cast<long long>(r.version->number);
    out << format_text("map %s version %lld staged (parent v%lld): %zu tiles rebuilt, %zu keep their bytes\n", o->map.c_str(), number,
          static_cast<long long>(r.parent), r.tiles.size(), r.unchanged);
    if (o->publish) {
      publish_version(store, o->map, r.version->number, key ? &*key : nullptr);
      out << format_text("map %s: version %lld is current\n", o->map.c_str(), number);
    }
    return 0;
  });
  db_option(c, o->db, false);
  c.add_option("--map", o->map, "the map's name")->required()->type_name("NAME");
  c.add_option("--reports", o->reports, "change reports (JSON, pl-localize --change-report) instead of those the store holds "
               "(sent to pl-server by the vehicles); those against other versions than the current one do not count")
      ->expected(1, -1)->type_name("FILE...")->check(CLI::ExistingFile);
  rule_options(c, o->cfg.rule);
  c.add_flag("--publish", o->publish, "publish the staged version at once");
  c.add_option("--signing-key", o->signing_key, "(with --publish) sign the version's manifest with this Ed25519 private key")
      ->type_name("FILE");
}

}  // namespace pl::maps
