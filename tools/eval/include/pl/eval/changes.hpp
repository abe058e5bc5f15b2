// Change detection against the simulator's truth: pl-map changes' candidate tiles scored per tile
// against what pl-sim's probe rays saw change (changes.csv and changes_seen.csv of an epoch-1 drive).
//
// A tile truly changed where min_rays or more of the drive's probe rays saw one changed thing change
// in it: a parked car gone, a hedge grown a metre at its end or half a metre up — and not a hedge
// 10 cm thicker, which no ray tells from the old one at 0.3 m, nor a canopy grown above the sensor's
// view. Only tiles some pass saw are scored; a tile where fewer rays saw a change is scored neither
// way (the evidence of a change at a tile's edge may fall on either side of it).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "pl/common/tile_key.hpp"

namespace pl::eval {

struct ChangeTruthOptions {
  double tile_m = 20.0;
  std::uint64_t min_rays = 20;  // probe rays that saw a change in a tile for it to count there
};

struct ChangeScore {
  std::size_t changes = 0, seen_changes = 0;  // things changed, and those the rays saw change in a tile scored
  std::size_t candidates = 0, truth = 0, true_positives = 0;
  std::size_t marginal = 0;  // tiles not scored: fewer than min_rays saw a change there
  double precision = 0, recall = 0;
  std::size_t things_truth = 0, things_found = 0;  // tiles of moved, removed or added things
  std::size_t growth_truth = 0, growth_found = 0;  // tiles only vegetation grew into
  std::vector<TileKey> false_positives, missed;
};

// Reads changes.csv, changes_seen.csv beside it and the candidates; throws pl::Error naming the
// file, the line and the problem.
ChangeScore score_changes(const std::string& changes_csv, const std::string& candidates_csv, const ChangeTruthOptions& options = {});

std::string change_score_text(const ChangeScore& score);

}  // namespace pl::eval
