// Per-tile change detection scores against pl-sim's changes.csv (see the header).
#include "pl/eval/changes.hpp"

#include <cmath>
#include <filesystem>
#include <cstdio>
#include <fstream>
#include <map>
#include <optional>
#include <set>
#include <sstream>

#include "pl/common/error.hpp"

namespace pl::eval {

namespace {

// A CSV with a header line, read as text fields by column name.
struct Csv {
  std::string path;
  std::map<std::string, std::size_t> column;
  std::vector<std::vector<std::string>> rows;

  explicit Csv(const std::string& file) : path(file) {
    std::ifstream f(file);
    if (!f) throw Error(file + ": cannot read");
    std::string line;
    if (!std::getline(f, line)) throw Error(file + ": empty (a header line was expected)");
    std::size_t i = 0;
    for (const std::string& name : split(line)) column[name] = i++;
    while (std::getline(f, line))
      if (!line.empty()) rows.push_back(split(line));
  }
  static std::vector<std::string> split(const std::string& line) {
    std::vector<std::string> out;
    std::stringstream ss(line);
    std::string field;
    while (std::getline(ss, field, ',')) out.push_back(field);
    if (!line.empty() && line.back() == ',') out.emplace_back();
    return out;
  }
  std::size_t col(const std::string& name) const {
    auto it = column.find(name);
    if (it == column.end()) throw Error(path + ": no column \"" + name + "\"");
    return it->second;
  }
  const std::string& at(std::size_t row, const std::string& name) const {
    const std::size_t c = col(name);
    if (c >= rows[row].size()) throw Error(path + ":" + std::to_string(row + 2) + ": too few fields");
    return rows[row][c];
  }
  double number(std::size_t row, const std::string& name) const {
    const std::string& s = at(row, name);
    char* end = nullptr;
    const double v = std::strtod(s.c_str(), &end);
    if (s.empty() || *end != '\0' || !std::isfinite(v))
      throw Error(path + ":" + std::to_string(row + 2) + ": \"" + name + "\" is not a number (\"" + s + "\")");
    return v;
  }
};

}  // namespace

ChangeScore score_changes(const std::string& changes_csv, const std::string& candidates_csv, const ChangeTruthOptions& o) {
  const TileGrid grid(o.tile_m);
  const std::string seen_csv = (std::filesystem::path(changes_csv).parent_path() / "changes_seen.csv").string();
  const Csv changes(changes_csv), seen(seen_csv), cands(candidates_csv);
  ChangeScore score;
  std::set<TileKey> observed, candidate;
  for (std::size_t r = 0; r < cands.rows.size(); ++r) {
    const TileKey k{static_cast<std::int32_t>(cands.number(r, "tx")), static_cast<std::int32_t>(cands.number(r, "ty"))};
    if (cands.number(r, "passes") >= 1) observed.insert(k);
    if (cands.number(r, "candidate") != 0) candidate.insert(k);
  }
  std::map<long, bool> grown;  // id -> vegetation grown (else a thing moved, removed or added)
  for (std::size_t r = 0; r < changes.rows.size(); ++r) grown[static_cast<long>(changes.number(r, "id"))] = changes.at(r, "change") == "grown";
  score.changes = grown.size();
  // Rays that saw each change, per tile.
  std::map<std::pair<long, TileKey>, double> rays;
  for (std::size_t r = 0; r < seen.rows.size(); ++r) {
    const long id = static_cast<long>(seen.number(r, "id"));
    if (!grown.count(id)) throw Error(seen_csv + ":" + std::to_string(r + 2) + ": change " + std::to_string(id) + " is not in " + changes_csv);
    rays[{id, grid.key_of(seen.number(r, "x"), seen.number(r, "y"))}] += seen.number(r, "rays");
  }
  std::set<TileKey> truth, things, marginal;
  std::set<long> seen_ids;
  for (const auto& [key, n] : rays) {
    const auto& [id, tile] = key;
    if (!observed.count(tile)) continue;
    if (n < static_cast<double>(o.min_rays)) {
      marginal.insert(tile);
      continue;
    }
    seen_ids.insert(id);
    truth.insert(tile);
    if (!grown[id]) things.insert(tile);
  }
  score.seen_changes = seen_ids.size();
  for (const TileKey& k : truth) marginal.erase(k);
  for (const TileKey& k : marginal) candidate.erase(k);
  score.marginal = marginal.size();
  score.candidates = candidate.size();
  score.truth = truth.size();
  for (const TileKey& k : candidate) {
    if (truth.count(k)) ++score.true_positives;
    else score.false_positives.push_back(k);
  }
  for (const TileKey& k : truth) {
    const bool found = candidate.count(k) > 0;
    if (!found) score.missed.push_back(k);
    if (things.count(k)) {
      ++score.things_truth;
      score.things_found += found;
    } else {
      ++score.growth_truth;
      score.growth_found += found;
    }
  }
  score.precision = score.candidates ? static_cast<double>(score.true_positives) / static_cast<double>(score.candidates) : 1.0;
  score.recall = score.truth ? static_cast<double>(score.true_positives) / static_cast<double>(score.truth) : 1.0;
  return score;
}

std::string change_score_text(const ChangeScore& s) {
  char buf[512];
  std::string out;
  std::snprintf(buf, sizeof buf,
                "changes: %zu things changed, %zu seen changing by the drive's rays in a tile some pass saw\n"
                "tiles: %zu candidates, %zu truly changed, %zu right; %zu where fewer rays saw a change, not scored\n"
                "precision %.3f, recall %.3f (things moved, removed or added: %zu of %zu tiles; vegetation grown: %zu of %zu)\n",
                s.changes, s.seen_changes, s.candidates, s.truth, s.true_positives, s.marginal, s.precision, s.recall, s.things_found,
                s.things_truth, s.growth_found, s.growth_truth);
  out += buf;
  auto list = [&](const char* what, const std::vector<TileKey>& keys) {
    if (keys.empty()) return;
    out += what;
    for (const TileKey& k : keys) out += " (" + std::to_string(k.tx) + "," + std::to_string(k.ty) + ")";
    out += "\n";
  };
  list("false candidates:", s.false_positives);
  list("missed:", s.missed);
  return out;
}

}  // namespace pl::eval
